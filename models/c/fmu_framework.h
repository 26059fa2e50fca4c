/* Shared skeleton of fmucal's example FMUs: Model Exchange + Co-Simulation in one binary, for
 * FMI 2.0 by default and for FMI 3.0 when compiled with -DFMUCAL_FMI3, from the same model file;
 * for FMI 1.0, whose Model Exchange and Co-Simulation are separate FMUs with different function
 * sets, one of them per binary: -DFMUCAL_FMI1=1 (Model Exchange) or -DFMUCAL_FMI1=2
 * (Co-Simulation), with FMI1_PREFIX (the model identifier as a C token) defined by the model.
 * The model hooks declared below, the Model struct and the Co-Simulation integrator
 * (fmu_cosim.c) are the same in every build; only the exported API differs (fmu_framework1.c,
 * fmu_framework2.c or fmu_framework3.c, chosen in fmu_framework.c). The hooks speak FMI 2.0's
 * types (fmi2Status, fmi2ValueReference, fmi2Type) in every build: fmi2.h declares only types,
 * and the 1.0 and 3.0 skeletons convert statuses (fmi2OK..fmi2Fatal have the numeric values of
 * fmiOK..fmiFatal and fmi3OK..fmi3Fatal).
 *
 * A model file defines, before including this header:
 *   MODEL_IDENTIFIER, MODEL_GUID   strings matching modelDescription.xml
 *   FMI1_PREFIX                     FMI 1.0 builds only: MODEL_IDENTIFIER as a C token (the
 *                                   prefix of the exported function names, Furuta_fmiGetReal)
 *   N_REAL, N_INTEGER, N_BOOLEAN   number of value references of each type (>= 1)
 *   NX, NZ                          number of continuous states and event indicators
 *   CS_STEP                         internal step of the Co-Simulation integrator
 *   CS_IMPLICIT                     1: L-stable SDIRK2 (stiff models), 0: classic RK4
 * and optionally, to behave as some exporting tools do (named after the FMI 2.0 functions; the
 * 3.0 skeleton applies them in fmi3EnterInitializationMode, fmi3CompletedIntegratorStep and
 * fmi3GetFloat64/fmi3SetFloat64; the 1.0 skeleton in fmiInitialize, fmiCompletedIntegratorStep
 * and fmiGetReal, but not IS_DISCRETE_REAL, as FMI 1.0 has no Continuous-Time Mode):
 *   IS_DISCRETE_REAL(vr)            1 for Real value references of variability "discrete";
 *                                   setting them in Continuous-Time Mode is an error (FMI 2.0
 *                                   section 3.2.3), as it always is for Integer and Boolean
 *   TOLERANCE_VR                    Real value reference that receives the tolerance passed to
 *                                   fmi2SetupExperiment (0 when toleranceDefined is false)
 *   WARN_TOLERANCE_IN_ME            log a warning when a Model Exchange instance is given a
 *                                   tolerance (it has no integrator to use it)
 *   COMPLETED_STEPS_VR              Integer value reference counting fmi2CompletedIntegratorStep
 *                                   calls (FMUs with dynamic state selection act on every one)
 *   REPORTED_REAL(m, vr)            the value fmi2GetReal reports for Real value reference vr
 *                                   (default m->r[vr]); the equations and fmi2GetContinuousStates
 *                                   still use m->r, so a sensor error can be built in
 *   FMI3_FLOAT64_SIZE(vr)           FMI 3.0 builds: number of elements of the Float64 variable
 *                                   with value reference vr (default 1). An array of n elements
 *                                   is m->r[vr..vr+n-1]; FMI 3.0 gives it the one value reference
 *                                   vr (the macro is 0 for vr+1..vr+n-1, which name nothing),
 *                                   FMI 2.0 describes its elements as n scalars
 *   N_STRING                        number of String variables (default none): m->s[k], at most
 *                                   STRING_CAP - 1 bytes each (a longer value is refused); FMI 1.0
 *                                   and 2.0 give String k the value reference k (each base type
 *                                   numbers its own), FMI 3.0 numbers them as below. The getter
 *                                   calls model_derivatives first (as fmi2GetReal does), so a model
 *                                   computes String outputs there
 *   N_BINARY                        FMI 3.0 builds: number of Binary variables (default none):
 *                                   m->bin[k] with m->binSize[k] bytes, at most BINARY_CAP
 *   N_UINT64                        FMI 3.0 builds: number of UInt64 variables (default none):
 *                                   m->u64[k] (for example structural parameters, which a model
 *                                   checks in model_initialize)
 * then implements the model_* hooks declared below and includes fmu_framework.c.
 *
 * FMI 3.0 value references are unique across all types, so the 3.0 skeleton numbers them from
 * the 2.0 ones (the placeholders of N_INTEGER and N_BOOLEAN >= 1 keep their numbers):
 *   Float64 m->r[k]                 k                                  (2.0's Real k)
 *   Int32 m->i[k]                   N_REAL + k                         (2.0's Integer k)
 *   Boolean m->b[k]                 N_REAL + N_INTEGER + k             (2.0's Boolean k)
 *   time (causality independent)    N_REAL + N_INTEGER + N_BOOLEAN
 *   event indicator k (local, read) N_REAL + N_INTEGER + N_BOOLEAN + 1 + k
 *   UInt64 m->u64[k]                N_REAL + N_INTEGER + N_BOOLEAN + 1 + NZ + k
 *   String m->s[k]                  the same + N_UINT64 + k
 *   Binary m->bin[k]                the same + N_UINT64 + N_STRING + k */
#ifndef FMUCAL_FMU_FRAMEWORK_H
#define FMUCAL_FMU_FRAMEWORK_H

#include "fmi2.h" /* the hooks' types, in every build */
#if defined(FMUCAL_FMI3) && defined(FMUCAL_FMI1)
#error "FMUCAL_FMI1 and FMUCAL_FMI3 exclude each other"
#endif
#if defined(FMUCAL_FMI3)
#include "fmi3.h"
#elif defined(FMUCAL_FMI1)
#if FMUCAL_FMI1 != 1 && FMUCAL_FMI1 != 2
#error "FMUCAL_FMI1 is 1 (Model Exchange) or 2 (Co-Simulation)"
#endif
#include "fmi1.h"
#endif
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef IS_DISCRETE_REAL
#define IS_DISCRETE_REAL(vr) 0
#endif

#ifndef REPORTED_REAL
#define REPORTED_REAL(m, vr) ((m)->r[(vr)])
#endif

#ifndef STRING_CAP
#define STRING_CAP 256
#endif
#ifndef BINARY_CAP
#define BINARY_CAP 256
#endif
#if (defined(N_BINARY) || defined(N_UINT64)) && !defined(FMUCAL_FMI3)
#error "Binary and UInt64 variables exist in FMI 3.0 builds only"
#endif

#define NX_ALLOC (NX > 0 ? NX : 1)
#define NZ_ALLOC (NZ > 0 ? NZ : 1)

typedef enum {
    MODE_INSTANTIATED,
    MODE_INITIALIZATION,
    MODE_EVENT,
    MODE_CONTINUOUS,
    MODE_STEP_COMPLETE,
    MODE_TERMINATED,
    MODE_ERROR
} Mode;

typedef struct Model {
    double r[N_REAL];
    int i[N_INTEGER];
    int b[N_BOOLEAN];
#ifdef N_STRING
    char s[N_STRING][STRING_CAP];
#endif
#ifdef N_BINARY
    unsigned char bin[N_BINARY][BINARY_CAP];
    size_t binSize[N_BINARY];
#endif
#ifdef N_UINT64
    uint64_t u64[N_UINT64];
#endif
    double time;
    fmi2Type type;
    Mode mode;
#if defined(FMUCAL_FMI3)
    fmi3InstanceEnvironment instanceEnvironment;
    fmi3LogMessageCallback logMessage;
    int earlyReturnAllowed;
#elif defined(FMUCAL_FMI1)
    fmiCallbackLogger logger; /* called with the instance itself */
#else
    fmi2CallbackFunctions cb;
#endif
    char instanceName[256];
    char resourceDir[4096];
    int loggingOn;
    /* events */
    int nextEventTimeDefined;
    double nextEventTime;
    int terminateSimulation;
    int valuesChanged;
    /* co-simulation */
    int csTerminated;
    double lastSuccessfulTime;
} Model;

/* Model hooks. */
static void model_defaults(Model *m);
static fmi2Status model_instantiated(Model *m);
static fmi2Status model_initialize(Model *m);
static fmi2Status model_derivatives(Model *m);
static void model_event_indicators(Model *m, double *z);
static void model_event_update(Model *m);
static double model_nominal(int stateIndex);

static void fmu_log(Model *m, fmi2Status status, const char *category, const char *fmt, ...);

/* Clears the optional String, Binary and UInt64 storage (at a reset, before model_defaults;
 * inline: the FMI 1.0 Model Exchange API has no reset). */
static inline void clear_extra_storage(Model *m) {
    (void)m;
#ifdef N_STRING
    memset(m->s, 0, sizeof m->s);
#endif
#ifdef N_BINARY
    memset(m->bin, 0, sizeof m->bin);
    memset(m->binSize, 0, sizeof m->binSize);
#endif
#ifdef N_UINT64
    memset(m->u64, 0, sizeof m->u64);
#endif
}

#endif
