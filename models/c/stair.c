/* A staircase after the Modelica Reference FMUs' Stair: the Integer output counter starts at 1
 * and grows by 1 at every whole second, by time events. Once it reaches 10 (at t = 9) the model
 * asks to terminate the simulation (terminateSimulation, FMI 2.0 section 3.2.2 and 4.2.3, FMI 3.0
 * section 3.2.2 and 4.2.4); an importer that goes on to the next event (t = 10, the default stop
 * time) gets an error, as the Reference FMU's "Variable "counter" cannot be incremented for
 * values >= 10". In Co-Simulation the step that reaches t = 9 ends there: FMI 2.0 answers
 * fmi2Discard with fmi2Terminated = true and fmi2LastSuccessfulTime = 9, FMI 3.0 answers fmi3OK
 * with terminateSimulation = true and lastSuccessfulTime = 9 (fmu_framework2.c,
 * fmu_framework3.c); a further step is refused. Like the Reference FMU, a start value of 10 or
 * more for counter is refused. Descriptions: xml/Stair.xml (2.0), xml/fmi3/Stair.xml (3.0). */
#define MODEL_IDENTIFIER "Stair"
#define MODEL_GUID "{6a1f3c2e-3b44-4d1c-9a43-f0a1c0de000c}"
#define N_REAL 1
#define N_INTEGER 2 /* counter, and a flag the description does not mention */
#define N_BOOLEAN 1
#define NX 0
#define NZ 0
#define CS_STEP 0.2
#define CS_IMPLICIT 0
#include "fmu_framework.h"

enum { COUNTER, OVERFLOW };
enum { COUNTER_MAX = 10 };
static const fmi2ValueReference STATE_VR[NX_ALLOC] = {0};
static const fmi2ValueReference DER_VR[NX_ALLOC] = {0};

static void model_defaults(Model *m) { m->i[COUNTER] = 1; }

static fmi2Status model_instantiated(Model *m) { (void)m; return fmi2OK; }

static fmi2Status model_initialize(Model *m) {
    if (m->i[COUNTER] >= COUNTER_MAX) {
        fmu_log(m, fmi2Error, "logStatusError", "The maximum value for variable \"counter\" is %d.", COUNTER_MAX);
        return fmi2Error;
    }
    m->nextEventTime = floor(m->time + 1e-9) + 1.0;
    m->nextEventTimeDefined = 1;
    return fmi2OK;
}

static double model_nominal(int k) { (void)k; return 1.0; }
static void model_event_indicators(Model *m, double *z) { (void)m; (void)z; }

static fmi2Status model_derivatives(Model *m) {
    /* Set by an event that would take the counter past its maximum, reported here (the event
     * hook returns no status; the skeletons evaluate the model right after every event). */
    if (m->i[OVERFLOW]) {
        fmu_log(m, fmi2Error, "logStatusError",
                "Variable \"counter\" cannot be incremented for values >= %d (t=%g).", COUNTER_MAX, m->time);
        return fmi2Error;
    }
    return fmi2OK;
}

static void model_event_update(Model *m) {
    /* The importer (or the Co-Simulation integrator) clears nextEventTimeDefined as it handles
     * the event; the time says whether this is the scheduled one. */
    if (m->time < m->nextEventTime - 1e-9) return;
    if (m->i[COUNTER] >= COUNTER_MAX) {
        m->i[OVERFLOW] = 1;
        return;
    }
    m->i[COUNTER]++;
    m->nextEventTime += 1.0;
    m->nextEventTimeDefined = 1;
    m->terminateSimulation = m->i[COUNTER] >= COUNTER_MAX;
}

#include "fmu_framework.c"
