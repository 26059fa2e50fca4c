/* A damped oscillator whose three coefficients are the elements of one array parameter k:
 *   x' = v,  v' = k[3] - k[1] x - k[2] v,  x(0) = 1, v(0) = 0.
 * With the defaults k = {1, 2, 3} it is critically damped and x(t) = 3 - 2 (1 + t) exp(-t).
 * The FMI 3.0 description declares k as one Float64 array (<Dimension start="3"/>, value
 * reference K1), the FMI 2.0 one as the scalars k[1], k[2], k[3] (value references K1..K3):
 * a fixture for calibrating one element of an array parameter. */
#define MODEL_IDENTIFIER "ArrayParams"
#define MODEL_GUID "{6a1f3c2e-3b44-4d1c-9a43-f0a1c0de000a}"
#define N_REAL 7
#define N_INTEGER 1
#define N_BOOLEAN 1
#define NX 2
#define NZ 0
#define CS_STEP 1e-3
#define CS_IMPLICIT 0
enum { X, DER_X, V, DER_V, K1, K2, K3 };
/* FMI 3.0: k is m->r[K1..K3] under the one value reference K1. */
#define FMI3_FLOAT64_SIZE(vr) ((vr) == K1 ? 3 : ((vr) == K2 || (vr) == K3) ? 0 : 1)
#include "fmu_framework.h"

static const fmi2ValueReference STATE_VR[NX] = {X, V};
static const fmi2ValueReference DER_VR[NX] = {DER_X, DER_V};

static void model_defaults(Model *m) {
    m->r[X] = 1.0;
    m->r[V] = 0.0;
    m->r[K1] = 1.0;
    m->r[K2] = 2.0;
    m->r[K3] = 3.0;
}

static fmi2Status model_instantiated(Model *m) { (void)m; return fmi2OK; }
static fmi2Status model_initialize(Model *m) { (void)m; return fmi2OK; }
static double model_nominal(int k) { (void)k; return 1.0; }
static void model_event_indicators(Model *m, double *z) { (void)m; (void)z; }
static void model_event_update(Model *m) { (void)m; }

static fmi2Status model_derivatives(Model *m) {
    double *r = m->r;
    r[DER_X] = r[V];
    r[DER_V] = r[K3] - r[K1] * r[X] - r[K2] * r[V];
    return fmi2OK;
}

#include "fmu_framework.c"
