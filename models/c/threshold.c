/* A comparator without continuous states: above = (u > threshold), crossings counts the switches.
 * Its one event indicator, u - threshold, moves only with the continuous input u, so an importer
 * that never evaluates the indicators of a model without states misses every switch (FMPy
 * integrates a stand-in state to find them). */
#define MODEL_IDENTIFIER "Threshold"
#define MODEL_GUID "{6a1f3c2e-3b44-4d1c-9a43-f0a1c0de0008}"
#define N_REAL 2
#define N_INTEGER 1
#define N_BOOLEAN 1
#define NX 0
#define NZ 1
#define CS_STEP 1e-3
#define CS_IMPLICIT 0
#include "fmu_framework.h"

enum { U, THRESHOLD };
enum { CROSSINGS };
enum { ABOVE };
static const fmi2ValueReference STATE_VR[NX_ALLOC] = {0};
static const fmi2ValueReference DER_VR[NX_ALLOC] = {0};

static void model_defaults(Model *m) {
    m->r[U] = 0.0;
    m->r[THRESHOLD] = 1.0;
    m->i[CROSSINGS] = 0;
    m->b[ABOVE] = 0;
}

static fmi2Status model_instantiated(Model *m) { (void)m; return fmi2OK; }

static fmi2Status model_initialize(Model *m) {
    m->b[ABOVE] = m->r[U] > m->r[THRESHOLD];
    m->i[CROSSINGS] = 0;
    return fmi2OK;
}

static double model_nominal(int k) { (void)k; return 1.0; }
static fmi2Status model_derivatives(Model *m) { (void)m; return fmi2OK; }
static void model_event_indicators(Model *m, double *z) { z[0] = m->r[U] - m->r[THRESHOLD]; }

/* At a root the indicator may be exactly 0: a switch is due once it reaches the other side. */
static void model_event_update(Model *m) {
    double z = m->r[U] - m->r[THRESHOLD];
    if ((!m->b[ABOVE] && z >= 0) || (m->b[ABOVE] && z <= 0)) {
        m->b[ABOVE] = !m->b[ABOVE];
        m->i[CROSSINGS]++;
    }
}

#include "fmu_framework.c"
