/* Bouncing ball: free fall with a state event at the floor, where the velocity is reversed and
 * scaled by the restitution coefficient e. Once a bounce leaves less than vMin, the ball rests. */
#define MODEL_IDENTIFIER "BouncingBall"
#define FMI1_PREFIX BouncingBall /* FMI 1.0 builds: the exported names' prefix */
#define MODEL_GUID "{6a1f3c2e-3b44-4d1c-9a43-f0a1c0de0002}"
#define N_REAL 7
#define N_INTEGER 1
#define N_BOOLEAN 1
#define NX 2
#define NZ 1
#define CS_STEP 1e-3
#define CS_IMPLICIT 0
#include "fmu_framework.h"

enum { H, DER_H, V, DER_V, G, E, V_MIN };
enum { RESTING };
static const fmi2ValueReference STATE_VR[NX] = {H, V};
static const fmi2ValueReference DER_VR[NX] = {DER_H, DER_V};

static void model_defaults(Model *m) {
    m->r[H] = 1.0;
    m->r[V] = 0.0;
    m->r[G] = 9.81;
    m->r[E] = 0.7;
    m->r[V_MIN] = 0.01;
    m->b[RESTING] = 0;
}

static fmi2Status model_instantiated(Model *m) { (void)m; return fmi2OK; }
static fmi2Status model_initialize(Model *m) { (void)m; return fmi2OK; }
static double model_nominal(int k) { (void)k; return 1.0; }

static fmi2Status model_derivatives(Model *m) {
    if (m->b[RESTING]) {
        m->r[DER_H] = 0.0;
        m->r[DER_V] = 0.0;
    } else {
        m->r[DER_H] = m->r[V];
        m->r[DER_V] = -m->r[G];
    }
    return fmi2OK;
}

static void model_event_indicators(Model *m, double *z) { z[0] = m->b[RESTING] ? 1.0 : m->r[H]; }

static void model_event_update(Model *m) {
    if (m->b[RESTING] || !(m->r[H] <= 1e-12) || !(m->r[V] < 0)) return;
    double v = -m->r[E] * m->r[V];
    if (v < m->r[V_MIN]) {
        m->b[RESTING] = 1;
        m->r[H] = 0.0;
        m->r[V] = 0.0;
    } else {
        m->r[H] = 1e-300; /* just above the floor, so the indicator starts positive */
        m->r[V] = v;
    }
    m->valuesChanged = 1;
}

#include "fmu_framework.c"
