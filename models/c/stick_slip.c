/* Stick-slip friction oscillator driven by a continuous input force: a mass on a spring with
 * viscous damping, Coulomb friction and stiction (static friction above sliding friction), as
 * exported friction models behave. While the body sticks its states stand still and only the
 * input force moves the force-balance event indicator towards breakaway, so an integrator that
 * steps past the input's samples can miss the breakaway altogether.
 *   sliding (mode = +1 or -1): x' = v, m v' = F - k x - d v - mode Fc
 *   stuck   (mode = 0):        x' = 0, v' = 0, until |F - k x| exceeds Fs
 * Event indicators: z0 on the velocity while sliding (mode v + V_EPS, positive right after a
 * breakaway, where v = 0), z1 on the force balance while stuck (Fs - |F - k x|). When a sliding
 * body stops, it sticks if |F - k x| <= Fs and slides back otherwise. */
#define MODEL_IDENTIFIER "StickSlip"
#define MODEL_GUID "{6a1f3c2e-3b44-4d1c-9a43-f0a1c0de0006}"
#define N_REAL 11
#define N_INTEGER 1
#define N_BOOLEAN 1
#define NX 2
#define NZ 2
#define CS_STEP 1e-3
#define CS_IMPLICIT 0
#include "fmu_framework.h"

enum { X, DER_X, V, DER_V, F, MASS, K, FS, FC, D, FRICTION };
enum { MODE };
enum { STUCK };
static const fmi2ValueReference STATE_VR[NX] = {X, V};
static const fmi2ValueReference DER_VR[NX] = {DER_X, DER_V};

/* Velocity offset of the sliding indicator [m/s]: the body counts as stopped at mode v = -V_EPS. */
#define V_EPS 1e-8

static void model_defaults(Model *m) {
    m->r[X] = 0.0;
    m->r[V] = 0.0;
    m->r[F] = 0.0;
    m->r[MASS] = 1.0;
    m->r[K] = 1.0;
    m->r[FS] = 1.0;
    m->r[FC] = 0.6;
    m->r[D] = 0.1;
    m->i[MODE] = 0;
    m->b[STUCK] = 1;
}

static fmi2Status model_instantiated(Model *m) { (void)m; return fmi2OK; }

static double force_balance(Model *m) { return m->r[F] - m->r[K] * m->r[X]; }

/* Whether the net force breaks a stuck body loose (with a round-off margin: the root finder
 * stops within a few ulps of the crossing). */
static int breaks_away(Model *m, double fnet) { return fabs(fnet) > m->r[FS] - 1e-12 * fmax(1.0, m->r[FS]); }

static fmi2Status model_initialize(Model *m) {
    if (!(m->r[MASS] > 0) || m->r[FS] < m->r[FC] || m->r[FC] < 0) {
        fmu_log(m, fmi2Error, "logStatusError", "need mass > 0 and Fs >= Fc >= 0 (mass=%g, Fs=%g, Fc=%g)",
                m->r[MASS], m->r[FS], m->r[FC]);
        return fmi2Error;
    }
    double fnet = force_balance(m);
    if (m->r[V] != 0.0) m->i[MODE] = m->r[V] > 0 ? 1 : -1;
    else if (breaks_away(m, fnet)) m->i[MODE] = fnet > 0 ? 1 : -1;
    else m->i[MODE] = 0;
    m->b[STUCK] = m->i[MODE] == 0;
    return fmi2OK;
}

static double model_nominal(int k) { (void)k; return 1.0; }

static fmi2Status model_derivatives(Model *m) {
    double fnet = force_balance(m);
    int mode = m->i[MODE];
    if (mode == 0) {
        m->r[DER_X] = 0.0;
        m->r[DER_V] = 0.0;
        m->r[FRICTION] = -fnet;
    } else {
        m->r[FRICTION] = -m->r[D] * m->r[V] - mode * m->r[FC];
        m->r[DER_X] = m->r[V];
        m->r[DER_V] = (fnet + m->r[FRICTION]) / m->r[MASS];
    }
    m->b[STUCK] = mode == 0;
    return fmi2OK;
}

static void model_event_indicators(Model *m, double *z) {
    int mode = m->i[MODE];
    z[0] = mode == 0 ? 1.0 : mode * m->r[V] + V_EPS;
    z[1] = mode == 0 ? m->r[FS] - fabs(force_balance(m)) : 1.0;
}

static void model_event_update(Model *m) {
    double fnet = force_balance(m);
    int mode = m->i[MODE];
    if (mode == 0) {
        if (breaks_away(m, fnet)) m->i[MODE] = fnet > 0 ? 1 : -1;
    } else if (mode * m->r[V] <= -0.5 * V_EPS) {
        m->r[V] = 0.0;
        m->valuesChanged = 1;
        m->i[MODE] = breaks_away(m, fnet) ? (fnet > 0 ? 1 : -1) : 0;
    }
    m->b[STUCK] = m->i[MODE] == 0;
}

#include "fmu_framework.c"
