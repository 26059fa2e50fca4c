/* Spring-mass-damper: a mass on a linear spring with viscous damping, driven by a continuous
 * input force F, with an extra external force on the mass so that missing effects can be
 * added from outside the model (an injection port, zero by default).
 *   x' = v,  m v' = F + Fext - k x - d v
 * The exported-shape build (models/build.rs, xml/exported/SpringMassExported.xml, without the
 * injection port) starts the mass away from rest with SPRING_MASS_X0 (default 0).
 * Test variants (models/build.rs), physics the description does not mention; the forces are
 * added to the external force (so injecting the same formula through mass.Fext is the same
 * arithmetic):
 *   HIDDEN_CUBIC_SPRING=k3          a hardening spring force -k3 x^3 (fmucal's cubic_spring)
 *   HIDDEN_COULOMB=F                Coulomb friction -F tanh(v / 1e-3) (coulomb_friction)
 *   HIDDEN_STRIBECK_COULOMB=Fc with HIDDEN_STRIBECK_STATIC=Fs and HIDDEN_STRIBECK_VELOCITY=vs
 *                                   Stribeck friction -(Fc + (Fs - Fc) exp(-(v/vs)^2)) tanh(v / 1e-3)
 *                                   (stribeck_friction)
 *   HIDDEN_VISCOUS=c                extra viscous damping -c v (viscous_damping)
 *   HIDDEN_QUADRATIC_DRAG=c         quadratic drag -c v |v| (quadratic_drag)
 *   HIDDEN_POSITION_SENSOR_OFFSET=b the reported mass.x is the true position + b (sensor_offset);
 *                                   the equations and the continuous states use the true one
 * and effects none of fmucal's effect kinds expresses:
 *   HIDDEN_DRIFTING_STIFFNESS=a     the spring stiffens with time, k (1 + a t / HIDDEN_DRIFT_TIME)
 *                                   (HIDDEN_DRIFT_TIME default 20 s, the DefaultExperiment's stop)
 *   HIDDEN_PERIODIC_FORCE=A         a periodic disturbance A sin(HIDDEN_PERIODIC_OMEGA t)
 *                                   (HIDDEN_PERIODIC_OMEGA default 2.7 rad/s)
 *   HIDDEN_ONE_SIDED_FRICTION=F     Coulomb friction only while x > 0 (a pad rubbing on one side),
 *                                   -F tanh(v / 1e-3) (1 + tanh(x / 1e-2)) / 2
 *   HIDDEN_GROWING_MASS=a           the mass grows with time, m (1 + a t / HIDDEN_DRIFT_TIME) */
#define MODEL_IDENTIFIER "SpringMass"
#define MODEL_GUID "{6a1f3c2e-3b44-4d1c-9a43-f0a1c0de0009}"
#define N_REAL 9
#define N_INTEGER 1
#define N_BOOLEAN 1
#define NX 2
#define NZ 0
#define CS_STEP 1e-3
#define CS_IMPLICIT 0
#ifdef HIDDEN_POSITION_SENSOR_OFFSET
/* A test variant: the position sensor reads HIDDEN_POSITION_SENSOR_OFFSET too much. Only what
 * fmi2GetReal reports changes (as fmucal's sensor_offset changes the output series). */
#define REPORTED_REAL(m, vr) ((m)->r[(vr)] + ((vr) == X ? (HIDDEN_POSITION_SENSOR_OFFSET) : 0.0))
#endif
#ifndef SPRING_MASS_X0
#define SPRING_MASS_X0 0.0
#endif
#ifndef HIDDEN_DRIFT_TIME
#define HIDDEN_DRIFT_TIME 20.0
#endif
#ifndef HIDDEN_PERIODIC_OMEGA
#define HIDDEN_PERIODIC_OMEGA 2.7
#endif
#include "fmu_framework.h"

enum { X, DER_X, V, DER_V, F, F_EXT, MASS, K, D };
static const fmi2ValueReference STATE_VR[NX] = {X, V};
static const fmi2ValueReference DER_VR[NX] = {DER_X, DER_V};

static void model_defaults(Model *m) {
    m->r[X] = SPRING_MASS_X0;
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
#ifdef HIDDEN_COULOMB
    fExt += -(HIDDEN_COULOMB) * tanh(v / 1e-3);
#endif
#ifdef HIDDEN_STRIBECK_COULOMB
    {
        const double fc = HIDDEN_STRIBECK_COULOMB, fs = HIDDEN_STRIBECK_STATIC;
        const double q = v / (HIDDEN_STRIBECK_VELOCITY);
        fExt += -(fc + (fs - fc) * exp(-q * q)) * tanh(v / 1e-3);
    }
#endif
#ifdef HIDDEN_VISCOUS
    fExt += -(HIDDEN_VISCOUS) * v;
#endif
#ifdef HIDDEN_QUADRATIC_DRAG
    fExt += -(HIDDEN_QUADRATIC_DRAG) * v * fabs(v);
#endif
    double k = r[K];
#ifdef HIDDEN_DRIFTING_STIFFNESS
    k *= 1.0 + (HIDDEN_DRIFTING_STIFFNESS) * m->time / (HIDDEN_DRIFT_TIME);
#endif
#ifdef HIDDEN_PERIODIC_FORCE
    fExt += (HIDDEN_PERIODIC_FORCE) * sin((HIDDEN_PERIODIC_OMEGA) * m->time);
#endif
#ifdef HIDDEN_ONE_SIDED_FRICTION
    fExt += -(HIDDEN_ONE_SIDED_FRICTION) * tanh(v / 1e-3) * 0.5 * (1.0 + tanh(x / 1e-2));
#endif
    double mass = r[MASS];
#ifdef HIDDEN_GROWING_MASS
    mass *= 1.0 + (HIDDEN_GROWING_MASS) * m->time / (HIDDEN_DRIFT_TIME);
#endif
    double force = r[F] + fExt - k * x - r[D] * v;
    r[DER_X] = v;
    r[DER_V] = force / mass;
    return fmi2OK;
}

#include "fmu_framework.c"
