/* Spring-mass-damper: a mass on a linear spring with viscous damping, driven by a continuous
 * input force F, with an extra external force on the mass so that missing effects can be
 * added from outside the model (an injection port, zero by default).
 *   x' = v,  m v' = F + Fext - k x - d v
 * Test variant (models/build.rs), physics the description does not mention:
 *   HIDDEN_CUBIC_SPRING=k3   a hardening spring force -k3 x^3 (fmucal's cubic_spring effect) */
#define MODEL_IDENTIFIER "SpringMass"
#define MODEL_GUID "{6a1f3c2e-3b44-4d1c-9a43-f0a1c0de0009}"
#define N_REAL 9
#define N_INTEGER 1
#define N_BOOLEAN 1
#define NX 2
#define NZ 0
#define CS_STEP 1e-3
#define CS_IMPLICIT 0
#include "fmu_framework.h"

enum { X, DER_X, V, DER_V, F, F_EXT, MASS, K, D };
static const fmi2ValueReference STATE_VR[NX] = {X, V};
static const fmi2ValueReference DER_VR[NX] = {DER_X, DER_V};

static void model_defaults(Model *m) {
    m->r[X] = 0.0;
    m->r[V] = 0.0;
    m->r[F] = 0.0;
    m->r[F_EXT] = 0.0;
    m->r[MASS] = 1.0;
    m->r[K] = 4.0;
    m->r[D] = 0.3;
}

static fmi2Status model_instantiated(Model *m) { (void)m; return fmi2OK; }

static fmi2Status model_initialize(Model *m) {
    if (!(m->r[MASS] > 0)) {
        fmu_log(m, fmi2Error, "logStatusError", "need m > 0 (m=%g)", m->r[MASS]);
        return fmi2Error;
    }
    return fmi2OK;
}

static double model_nominal(int k) { (void)k; return 1.0; }
static void model_event_indicators(Model *m, double *z) { (void)m; (void)z; }
static void model_event_update(Model *m) { (void)m; }

static fmi2Status model_derivatives(Model *m) {
    double *r = m->r;
    double x = r[X], v = r[V];
    double fExt = r[F_EXT];
#ifdef HIDDEN_CUBIC_SPRING
    /* A test variant: a hardening spring that the model's description does not mention (the
     * discrepancy a diagnosis must find), -k3 x^3 as fmucal's cubic_spring effect, added where
     * the external force enters (so injecting that effect through mass.Fext is the same
     * arithmetic). */
    fExt += -(HIDDEN_CUBIC_SPRING) * (x * x * x);
#endif
    double force = r[F] + fExt - r[K] * x - r[D] * v;
    r[DER_X] = v;
    r[DER_V] = force / r[MASS];
    return fmi2OK;
}

#include "fmu_framework.c"
