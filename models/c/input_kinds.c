/* One input of every FMI 2.0 kind, integrated into one state so that each input's timing shows:
 *   x' = uc + ud + n + (b ? 1 : 0)
 * with uc a continuous Real input, ud a discrete Real input, n an Integer input and b a Boolean
 * input; yd, yn and yb echo the discrete ones. It behaves as exported FMUs do where the standard
 * is strict: setting a discrete input in Continuous-Time Mode is an error (FMI 2.0 section
 * 3.2.3), a Model Exchange instance given a tolerance warns that it ignores it, and an input
 * beyond ucMax logs the same warning at every evaluation. experimentTolerance shows the
 * tolerance fmi2SetupExperiment received (0 if none); completedSteps counts the calls of
 * fmi2CompletedIntegratorStep. */
#define MODEL_IDENTIFIER "InputKinds"
#define MODEL_GUID "{6a1f3c2e-3b44-4d1c-9a43-f0a1c0de0007}"
#define N_REAL 7
#define N_INTEGER 3
#define N_BOOLEAN 2
#define NX 1
#define NZ 0
#define CS_STEP 1e-3
#define CS_IMPLICIT 0
enum { X, DER_X, UC, UD, YD, UC_MAX, TOL };
enum { N, YN, COMPLETED_STEPS };
enum { B, YB };
#define IS_DISCRETE_REAL(vr) ((vr) == UD)
#define TOLERANCE_VR TOL
#define WARN_TOLERANCE_IN_ME
#define COMPLETED_STEPS_VR COMPLETED_STEPS
#include "fmu_framework.h"

static const fmi2ValueReference STATE_VR[NX] = {X};
static const fmi2ValueReference DER_VR[NX] = {DER_X};

static void model_defaults(Model *m) {
    m->r[X] = 0.0;
    m->r[UC] = 0.0;
    m->r[UD] = 0.0;
    m->r[UC_MAX] = 1e9;
    m->i[N] = 0;
    m->b[B] = 0;
}

static fmi2Status model_instantiated(Model *m) { (void)m; return fmi2OK; }
static fmi2Status model_initialize(Model *m) { (void)m; return fmi2OK; }
static double model_nominal(int k) { (void)k; return 1.0; }

static fmi2Status model_derivatives(Model *m) {
    if (fabs(m->r[UC]) > m->r[UC_MAX])
        fmu_log(m, fmi2Warning, "logStatusWarning", "input uc is outside [-ucMax, ucMax]: the model extrapolates");
    m->r[DER_X] = m->r[UC] + m->r[UD] + m->i[N] + (m->b[B] ? 1.0 : 0.0);
    m->r[YD] = m->r[UD];
    m->i[YN] = m->i[N];
    m->b[YB] = m->b[B];
    return fmi2OK;
}

static void model_event_indicators(Model *m, double *z) { (void)m; (void)z; }
static void model_event_update(Model *m) { (void)m; }

#include "fmu_framework.c"
