/* Minimal FMI 1.0 type and function declarations for fmucal's example models, written for this
 * project from the FMI 1.0 specifications ("FMI for Model Exchange 1.0", chapter 3, and "FMI for
 * Co-Simulation 1.0", chapter 3): only what fmu_framework1.c implements.
 *
 * FMI 1.0 has two separate APIs, each its own FMU: Model Exchange (FMUCAL_FMI1 = 1) and
 * Co-Simulation (FMUCAL_FMI1 = 2). Both share the types and the get/set functions; they differ
 * in the callback struct (Co-Simulation adds stepFinished), the status enumeration
 * (Co-Simulation adds fmiPending) and their remaining functions.
 *
 * FMI 1.0 exports every function as "<modelIdentifier>_fmiXxx" so that several FMUs can be
 * linked into one program. Here each function name below is a macro that adds the prefix
 * FMI1_PREFIX, the model identifier as a C token (the model file defines it, e.g.
 * `#define FMI1_PREFIX Furuta`), so the skeleton writes `fmiGetReal` and defines
 * `Furuta_fmiGetReal`. With FMUCAL_FMI1_UNPREFIXED the plain names are exported instead (a
 * broken fixture: an importer must refuse it). */
#ifndef FMUCAL_FMI1_H
#define FMUCAL_FMI1_H
#include <stddef.h>

/* ---- names ---------------------------------------------------------------- */

#define FMI1_JOIN2(prefix, name) prefix##_##name
#define FMI1_JOIN(prefix, name) FMI1_JOIN2(prefix, name)
#if defined(FMUCAL_FMI1_UNPREFIXED)
#define FMI1_FUNCTION(name) name
#else
#ifndef FMI1_PREFIX
#error "FMI 1.0 builds need FMI1_PREFIX, the model identifier as a C token (e.g. #define FMI1_PREFIX Furuta)"
#endif
#define FMI1_FUNCTION(name) FMI1_JOIN(FMI1_PREFIX, name)
#endif

/* both APIs */
#define fmiGetVersion FMI1_FUNCTION(fmiGetVersion)
#define fmiSetDebugLogging FMI1_FUNCTION(fmiSetDebugLogging)
#define fmiGetReal FMI1_FUNCTION(fmiGetReal)
#define fmiGetInteger FMI1_FUNCTION(fmiGetInteger)
#define fmiGetBoolean FMI1_FUNCTION(fmiGetBoolean)
#define fmiGetString FMI1_FUNCTION(fmiGetString)
#define fmiSetReal FMI1_FUNCTION(fmiSetReal)
#define fmiSetInteger FMI1_FUNCTION(fmiSetInteger)
#define fmiSetBoolean FMI1_FUNCTION(fmiSetBoolean)
#define fmiSetString FMI1_FUNCTION(fmiSetString)
/* Model Exchange */
#define fmiGetModelTypesPlatform FMI1_FUNCTION(fmiGetModelTypesPlatform)
#define fmiInstantiateModel FMI1_FUNCTION(fmiInstantiateModel)
#define fmiFreeModelInstance FMI1_FUNCTION(fmiFreeModelInstance)
#define fmiSetTime FMI1_FUNCTION(fmiSetTime)
#define fmiSetContinuousStates FMI1_FUNCTION(fmiSetContinuousStates)
#define fmiCompletedIntegratorStep FMI1_FUNCTION(fmiCompletedIntegratorStep)
#define fmiInitialize FMI1_FUNCTION(fmiInitialize)
#define fmiGetDerivatives FMI1_FUNCTION(fmiGetDerivatives)
#define fmiGetEventIndicators FMI1_FUNCTION(fmiGetEventIndicators)
#define fmiEventUpdate FMI1_FUNCTION(fmiEventUpdate)
#define fmiGetContinuousStates FMI1_FUNCTION(fmiGetContinuousStates)
#define fmiGetNominalContinuousStates FMI1_FUNCTION(fmiGetNominalContinuousStates)
#define fmiGetStateValueReferences FMI1_FUNCTION(fmiGetStateValueReferences)
#define fmiTerminate FMI1_FUNCTION(fmiTerminate)
/* Co-Simulation */
#define fmiGetTypesPlatform FMI1_FUNCTION(fmiGetTypesPlatform)
#define fmiInstantiateSlave FMI1_FUNCTION(fmiInstantiateSlave)
#define fmiInitializeSlave FMI1_FUNCTION(fmiInitializeSlave)
#define fmiTerminateSlave FMI1_FUNCTION(fmiTerminateSlave)
#define fmiResetSlave FMI1_FUNCTION(fmiResetSlave)
#define fmiFreeSlaveInstance FMI1_FUNCTION(fmiFreeSlaveInstance)
#define fmiSetRealInputDerivatives FMI1_FUNCTION(fmiSetRealInputDerivatives)
#define fmiGetRealOutputDerivatives FMI1_FUNCTION(fmiGetRealOutputDerivatives)
#define fmiDoStep FMI1_FUNCTION(fmiDoStep)
#define fmiCancelStep FMI1_FUNCTION(fmiCancelStep)
#define fmiGetStatus FMI1_FUNCTION(fmiGetStatus)
#define fmiGetRealStatus FMI1_FUNCTION(fmiGetRealStatus)
#define fmiGetIntegerStatus FMI1_FUNCTION(fmiGetIntegerStatus)
#define fmiGetBooleanStatus FMI1_FUNCTION(fmiGetBooleanStatus)
#define fmiGetStringStatus FMI1_FUNCTION(fmiGetStringStatus)

/* ---- types (the "standard32" platform) ------------------------------------ */

typedef void *fmiComponent;
typedef unsigned int fmiValueReference;
typedef double fmiReal;
typedef int fmiInteger;
typedef char fmiBoolean; /* a char in FMI 1.0 (an int in 2.0) */
typedef const char *fmiString;

#define fmiTrue ((fmiBoolean)1)
#define fmiFalse ((fmiBoolean)0)
#define fmiUndefinedValueReference ((fmiValueReference)(-1))

/* fmiPending exists in Co-Simulation only; the others have the same numbers in both APIs. */
typedef enum { fmiOK, fmiWarning, fmiDiscard, fmiError, fmiFatal, fmiPending } fmiStatus;

/* The logger's first argument is the instance itself (FMI 2.0 passes the environment). */
typedef void (*fmiCallbackLogger)(fmiComponent c, fmiString instanceName, fmiStatus status, fmiString category,
                                  fmiString message, ...);
typedef void *(*fmiCallbackAllocateMemory)(size_t nobj, size_t size);
typedef void (*fmiCallbackFreeMemory)(void *obj);
typedef void (*fmiStepFinished)(fmiComponent c, fmiStatus status);

/* Both APIs pass the callbacks by value; the specifications name both structs
 * fmiCallbackFunctions, here they are told apart. */
typedef struct {
    fmiCallbackLogger logger;
    fmiCallbackAllocateMemory allocateMemory;
    fmiCallbackFreeMemory freeMemory;
} fmiMECallbackFunctions;

typedef struct {
    fmiCallbackLogger logger;
    fmiCallbackAllocateMemory allocateMemory;
    fmiCallbackFreeMemory freeMemory;
    fmiStepFinished stepFinished;
} fmiCSCallbackFunctions;

/* Model Exchange: what fmiInitialize and fmiEventUpdate report. */
typedef struct {
    fmiBoolean iterationConverged;
    fmiBoolean stateValueReferencesChanged;
    fmiBoolean stateValuesChanged;
    fmiBoolean terminateSimulation;
    fmiBoolean upcomingTimeEvent;
    fmiReal nextEventTime;
} fmiEventInfo;

/* Co-Simulation: what fmiGetXxxStatus can be asked. */
typedef enum { fmiDoStepStatus, fmiPendingStatus, fmiLastSuccessfulTime } fmiStatusKind;

#if defined(__GNUC__)
#define FMI1_EXPORT __attribute__((visibility("default")))
#else
#define FMI1_EXPORT
#endif

/* ---- functions ------------------------------------------------------------ */

FMI1_EXPORT const char *fmiGetVersion(void);
FMI1_EXPORT fmiStatus fmiSetDebugLogging(fmiComponent c, fmiBoolean loggingOn);
FMI1_EXPORT fmiStatus fmiGetReal(fmiComponent c, const fmiValueReference vr[], size_t nvr, fmiReal value[]);
FMI1_EXPORT fmiStatus fmiGetInteger(fmiComponent c, const fmiValueReference vr[], size_t nvr, fmiInteger value[]);
FMI1_EXPORT fmiStatus fmiGetBoolean(fmiComponent c, const fmiValueReference vr[], size_t nvr, fmiBoolean value[]);
FMI1_EXPORT fmiStatus fmiGetString(fmiComponent c, const fmiValueReference vr[], size_t nvr, fmiString value[]);
FMI1_EXPORT fmiStatus fmiSetReal(fmiComponent c, const fmiValueReference vr[], size_t nvr, const fmiReal value[]);
FMI1_EXPORT fmiStatus fmiSetInteger(fmiComponent c, const fmiValueReference vr[], size_t nvr,
                                    const fmiInteger value[]);
FMI1_EXPORT fmiStatus fmiSetBoolean(fmiComponent c, const fmiValueReference vr[], size_t nvr,
                                    const fmiBoolean value[]);
FMI1_EXPORT fmiStatus fmiSetString(fmiComponent c, const fmiValueReference vr[], size_t nvr,
                                   const fmiString value[]);

#if FMUCAL_FMI1 == 2 /* Co-Simulation */
FMI1_EXPORT const char *fmiGetTypesPlatform(void);
FMI1_EXPORT fmiComponent fmiInstantiateSlave(fmiString instanceName, fmiString fmuGUID, fmiString fmuLocation,
                                             fmiString mimeType, fmiReal timeout, fmiBoolean visible,
                                             fmiBoolean interactive, fmiCSCallbackFunctions functions,
                                             fmiBoolean loggingOn);
FMI1_EXPORT fmiStatus fmiInitializeSlave(fmiComponent c, fmiReal tStart, fmiBoolean StopTimeDefined, fmiReal tStop);
FMI1_EXPORT fmiStatus fmiTerminateSlave(fmiComponent c);
FMI1_EXPORT fmiStatus fmiResetSlave(fmiComponent c);
FMI1_EXPORT void fmiFreeSlaveInstance(fmiComponent c);
FMI1_EXPORT fmiStatus fmiSetRealInputDerivatives(fmiComponent c, const fmiValueReference vr[], size_t nvr,
                                                 const fmiInteger order[], const fmiReal value[]);
FMI1_EXPORT fmiStatus fmiGetRealOutputDerivatives(fmiComponent c, const fmiValueReference vr[], size_t nvr,
                                                  const fmiInteger order[], fmiReal value[]);
FMI1_EXPORT fmiStatus fmiCancelStep(fmiComponent c);
FMI1_EXPORT fmiStatus fmiDoStep(fmiComponent c, fmiReal currentCommunicationPoint, fmiReal communicationStepSize,
                                fmiBoolean newStep);
FMI1_EXPORT fmiStatus fmiGetStatus(fmiComponent c, const fmiStatusKind s, fmiStatus *value);
FMI1_EXPORT fmiStatus fmiGetRealStatus(fmiComponent c, const fmiStatusKind s, fmiReal *value);
FMI1_EXPORT fmiStatus fmiGetIntegerStatus(fmiComponent c, const fmiStatusKind s, fmiInteger *value);
FMI1_EXPORT fmiStatus fmiGetBooleanStatus(fmiComponent c, const fmiStatusKind s, fmiBoolean *value);
FMI1_EXPORT fmiStatus fmiGetStringStatus(fmiComponent c, const fmiStatusKind s, fmiString *value);
#else /* Model Exchange */
FMI1_EXPORT const char *fmiGetModelTypesPlatform(void);
FMI1_EXPORT fmiComponent fmiInstantiateModel(fmiString instanceName, fmiString GUID,
                                             fmiMECallbackFunctions functions, fmiBoolean loggingOn);
FMI1_EXPORT void fmiFreeModelInstance(fmiComponent c);
FMI1_EXPORT fmiStatus fmiSetTime(fmiComponent c, fmiReal time);
FMI1_EXPORT fmiStatus fmiSetContinuousStates(fmiComponent c, const fmiReal x[], size_t nx);
FMI1_EXPORT fmiStatus fmiCompletedIntegratorStep(fmiComponent c, fmiBoolean *callEventUpdate);
FMI1_EXPORT fmiStatus fmiInitialize(fmiComponent c, fmiBoolean toleranceControlled, fmiReal relativeTolerance,
                                    fmiEventInfo *eventInfo);
FMI1_EXPORT fmiStatus fmiGetDerivatives(fmiComponent c, fmiReal derivatives[], size_t nx);
FMI1_EXPORT fmiStatus fmiGetEventIndicators(fmiComponent c, fmiReal eventIndicators[], size_t ni);
FMI1_EXPORT fmiStatus fmiEventUpdate(fmiComponent c, fmiBoolean intermediateResults, fmiEventInfo *eventInfo);
FMI1_EXPORT fmiStatus fmiGetContinuousStates(fmiComponent c, fmiReal states[], size_t nx);
FMI1_EXPORT fmiStatus fmiGetNominalContinuousStates(fmiComponent c, fmiReal x_nominal[], size_t nx);
FMI1_EXPORT fmiStatus fmiGetStateValueReferences(fmiComponent c, fmiValueReference vrx[], size_t nx);
FMI1_EXPORT fmiStatus fmiTerminate(fmiComponent c);
#endif

#endif
