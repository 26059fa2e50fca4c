/* Shared skeleton of fmucal's example FMUs (FMI 2.0, Model Exchange + Co-Simulation).
 *
 * A model file defines, before including this header:
 *   MODEL_IDENTIFIER, MODEL_GUID   strings matching modelDescription.xml
 *   N_REAL, N_INTEGER, N_BOOLEAN   number of value references of each type (>= 1)
 *   NX, NZ                          number of continuous states and event indicators
 *   CS_STEP                         internal step of the Co-Simulation integrator
 *   CS_IMPLICIT                     1: L-stable SDIRK2 (stiff models), 0: classic RK4
 * and optionally, to behave as some exporting tools do:
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
 * then implements the model_* hooks declared below and includes fmu_framework.c. */
#ifndef FMUCAL_FMU_FRAMEWORK_H
#define FMUCAL_FMU_FRAMEWORK_H

#include "fmi2.h"
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef IS_DISCRETE_REAL
#define IS_DISCRETE_REAL(vr) 0
#endif

#ifndef REPORTED_REAL
#define REPORTED_REAL(m, vr) ((m)->r[(vr)])
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
    double time;
    fmi2Type type;
    Mode mode;
    fmi2CallbackFunctions cb;
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

#endif
