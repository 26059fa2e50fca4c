/* Robertson's stiff chemical kinetics (three species, rate constants 0.04, 3e7, 1e4).
 * Explicit integrators need tiny steps here; Co-Simulation uses the framework's SDIRK2. */
#define MODEL_IDENTIFIER "Robertson"
#define FMI1_PREFIX Robertson /* FMI 1.0 builds: the exported names' prefix */
#define MODEL_GUID "{6a1f3c2e-3b44-4d1c-9a43-f0a1c0de0004}"
#define N_REAL 9
#define N_INTEGER 1
#define N_BOOLEAN 1
#define NX 3
#define NZ 0
#define CS_STEP 1e-3
#define CS_IMPLICIT 1
#include "fmu_framework.h"

enum { Y1, Y2, Y3, DER_Y1, DER_Y2, DER_Y3, K1, K2, K3 };
static const fmi2ValueReference STATE_VR[NX] = {Y1, Y2, Y3};
static const fmi2ValueReference DER_VR[NX] = {DER_Y1, DER_Y2, DER_Y3};

static void model_defaults(Model *m) {
    m->r[Y1] = 1.0;
    m->r[Y2] = 0.0;
    m->r[Y3] = 0.0;
    m->r[K1] = 0.04;
    m->r[K2] = 3e7;
    m->r[K3] = 1e4;
}

static fmi2Status model_instantiated(Model *m) { (void)m; return fmi2OK; }
static fmi2Status model_initialize(Model *m) { (void)m; return fmi2OK; }
static double model_nominal(int k) { return k == 1 ? 1e-5 : 1.0; }
static void model_event_indicators(Model *m, double *z) { (void)m; (void)z; }
static void model_event_update(Model *m) { (void)m; }

static fmi2Status model_derivatives(Model *m) {
    double *r = m->r;
    double a = r[K1] * r[Y1], b = r[K3] * r[Y2] * r[Y3], c = r[K2] * r[Y2] * r[Y2];
    r[DER_Y1] = -a + b;
    r[DER_Y2] = a - b - c;
    r[DER_Y3] = c;
    return fmi2OK;
}

#include "fmu_framework.c"
