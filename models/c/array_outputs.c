/* An array output whose size is a structural parameter, after the Modelica Reference FMUs'
 * StateSpace (its y with <Dimension valueReference="..."/> naming the UInt64 structural
 * parameter r): a decay x' = -x, x(0) = 1, observed through n = 3 outputs y[k] = k x, so
 * y[k](t) = k e^(-t). FMI 3.0 declares y as one Float64 array (value reference Y) sized by the
 * UInt64 structuralParameter n (start 3; this build holds 3 elements, so another n is refused at
 * initialization); FMI 2.0, which has neither, describes the elements as the scalar outputs
 * y[1], y[2], y[3] (value references Y..Y+2). Descriptions: xml/ArrayOutputs.xml (2.0) and
 * xml/fmi3/ArrayOutputs.xml (3.0). */
#define MODEL_IDENTIFIER "ArrayOutputs"
#define MODEL_GUID "{6a1f3c2e-3b44-4d1c-9a43-f0a1c0de000d}"
#define N_REAL 5
#define N_INTEGER 1
#define N_BOOLEAN 1
#define NX 1
#define NZ 0
#define CS_STEP 1e-3
#define CS_IMPLICIT 0
enum { X, DER_X, Y };
enum { N_Y = 3 };
#ifdef FMUCAL_FMI3
#define N_UINT64 1
enum { N_SIZE }; /* m->u64[N_SIZE] is the structural parameter n */
/* y is m->r[Y..Y+2] under the one value reference Y. */
#define FMI3_FLOAT64_SIZE(vr) ((vr) == Y ? N_Y : ((vr) > Y && (vr) < Y + N_Y) ? 0 : 1)
#endif
#include "fmu_framework.h"

static const fmi2ValueReference STATE_VR[NX] = {X};
static const fmi2ValueReference DER_VR[NX] = {DER_X};

static void model_defaults(Model *m) {
    m->r[X] = 1.0;
#ifdef FMUCAL_FMI3
    m->u64[N_SIZE] = N_Y;
#endif
}

static fmi2Status model_instantiated(Model *m) { (void)m; return fmi2OK; }

static fmi2Status model_initialize(Model *m) {
#ifdef FMUCAL_FMI3
    if (m->u64[N_SIZE] != N_Y) {
        fmu_log(m, fmi2Error, "logStatusError", "structural parameter n = %llu: this build's y has %d elements",
                (unsigned long long)m->u64[N_SIZE], N_Y);
        return fmi2Error;
    }
#endif
    (void)m;
    return fmi2OK;
}

static double model_nominal(int k) { (void)k; return 1.0; }
static void model_event_indicators(Model *m, double *z) { (void)m; (void)z; }
static void model_event_update(Model *m) { (void)m; }

static fmi2Status model_derivatives(Model *m) {
    m->r[DER_X] = -m->r[X];
    for (int k = 0; k < N_Y; k++) m->r[Y + k] = (k + 1) * m->r[X];
    return fmi2OK;
}

#include "fmu_framework.c"
