/* FMI 2.0 entry points shared by fmucal's example models; see fmu_framework.h.
 * Model Exchange delegates to the model hooks; Co-Simulation integrates them with a
 * fixed internal step (RK4, or SDIRK2 for stiff models) and locates state events by
 * bisection on the event indicators. */

#define STATE(k) (m->r[STATE_VR[(k)]])
#define DERIV(k) (m->r[DER_VR[(k)]])

static void fmu_log(Model *m, fmi2Status status, const char *category, const char *fmt, ...) {
    if (!m || !m->cb.logger) return;
    if (!m->loggingOn && status == fmi2OK) return;
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    m->cb.logger(m->cb.componentEnvironment, m->instanceName, status, category, "%s", buf);
}

static void decode_resource_location(const char *uri, char *out, size_t cap) {
    out[0] = 0;
    if (!uri) return;
    const char *p = uri;
    if (strncmp(p, "file://", 7) == 0) p += 7;
    else if (strncmp(p, "file:", 5) == 0) p += 5;
    size_t n = 0;
    while (*p && n + 1 < cap) {
        if (p[0] == '%' && p[1] && p[2]) {
            char hex[3] = {p[1], p[2], 0};
            out[n++] = (char)strtol(hex, NULL, 16);
            p += 3;
        } else {
            out[n++] = *p++;
        }
    }
    out[n] = 0;
}

static int check_vr(Model *m, const char *fn, fmi2ValueReference vr, int count) {
    if ((int)vr >= count) {
        fmu_log(m, fmi2Error, "logStatusError", "%s: value reference %u out of range", fn, vr);
        return 0;
    }
    return 1;
}

/* FMI 2.0 section 3.2.3: discrete variables (all Integer and Boolean ones, and Real ones of
 * variability "discrete") may change only at events, so they cannot be set in Continuous-Time
 * Mode. Exported FMUs enforce this; so do these. */
static int check_discrete_settable(Model *m, const char *fn, fmi2ValueReference vr) {
    if (m->mode == MODE_CONTINUOUS) {
        fmu_log(m, fmi2Error, "logStatusError",
                "%s: discrete variable %u can only be set after instantiation, in initialization mode "
                "or event mode", fn, vr);
        return 0;
    }
    return 1;
}

FMI2_EXPORT const char *fmi2GetTypesPlatform(void) { return "default"; }
FMI2_EXPORT const char *fmi2GetVersion(void) { return "2.0"; }

FMI2_EXPORT fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t n, const fmi2String cats[]) {
    (void)n; (void)cats;
    if (!c) return fmi2Error;
    ((Model *)c)->loggingOn = loggingOn;
    return fmi2OK;
}

FMI2_EXPORT fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String guid,
                                          fmi2String resourceLocation, const fmi2CallbackFunctions *functions,
                                          fmi2Boolean visible, fmi2Boolean loggingOn) {
    (void)visible;
    if (!functions) return NULL;
    Model *m = (Model *)calloc(1, sizeof(Model));
    if (!m) return NULL;
    m->cb = *functions;
    snprintf(m->instanceName, sizeof m->instanceName, "%s", instanceName ? instanceName : "instance");
    m->loggingOn = loggingOn;
    m->type = fmuType;
    if (!guid || strcmp(guid, MODEL_GUID) != 0) {
        fmu_log(m, fmi2Error, "logStatusError", "wrong GUID %s, expected %s", guid ? guid : "(null)", MODEL_GUID);
        free(m);
        return NULL;
    }
    decode_resource_location(resourceLocation, m->resourceDir, sizeof m->resourceDir);
    model_defaults(m);
    if (model_instantiated(m) > fmi2Warning) {
        free(m);
        return NULL;
    }
    m->mode = MODE_INSTANTIATED;
    return m;
}

FMI2_EXPORT void fmi2FreeInstance(fmi2Component c) { free(c); }

FMI2_EXPORT fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDefined, fmi2Real tol, fmi2Real startTime,
                                           fmi2Boolean stopDefined, fmi2Real stopTime) {
    (void)tolDefined; (void)tol; (void)stopDefined; (void)stopTime;
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
#ifdef TOLERANCE_VR
    m->r[TOLERANCE_VR] = tolDefined ? tol : 0.0;
#endif
#ifdef WARN_TOLERANCE_IN_ME
    if (tolDefined && m->type == fmi2ModelExchange)
        fmu_log(m, fmi2Warning, "logStatusWarning",
                "fmi2SetupExperiment: the tolerance is ignored in Model Exchange (the importer integrates)");
#endif
    m->time = startTime;
    m->lastSuccessfulTime = startTime;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    m->mode = MODE_INITIALIZATION;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    fmi2Status s = model_initialize(m);
    if (s > fmi2Warning) { m->mode = MODE_ERROR; return s; }
    m->mode = (m->type == fmi2ModelExchange) ? MODE_EVENT : MODE_STEP_COMPLETE;
    return s;
}

FMI2_EXPORT fmi2Status fmi2Terminate(fmi2Component c) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    m->mode = MODE_TERMINATED;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2Reset(fmi2Component c) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
#ifdef FMUCAL_RESET_FAILS /* test fixture: an FMU whose reset always fails */
    fmu_log(m, fmi2Error, "logStatusError", "fmi2Reset is not supported by this build");
    return fmi2Error;
#endif
    int logging = m->loggingOn;
    memset(m->r, 0, sizeof m->r);
    memset(m->i, 0, sizeof m->i);
    memset(m->b, 0, sizeof m->b);
    m->time = 0;
    m->nextEventTimeDefined = 0;
    m->nextEventTime = 0;
    m->terminateSimulation = 0;
    m->valuesChanged = 0;
    m->csTerminated = 0;
    m->lastSuccessfulTime = 0;
    m->loggingOn = logging;
    model_defaults(m);
    m->mode = MODE_INSTANTIATED;
    return fmi2OK;
}

/* ---- get / set ---------------------------------------------------------- */

FMI2_EXPORT fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    if (nvr > 0 && m->mode != MODE_INSTANTIATED) {
        fmi2Status s = model_derivatives(m);
        if (s > fmi2Warning) return s;
    }
    for (size_t k = 0; k < nvr; k++) {
        if (!check_vr(m, "fmi2GetReal", vr[k], N_REAL)) return fmi2Error;
        value[k] = REPORTED_REAL(m, vr[k]);
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    for (size_t k = 0; k < nvr; k++) {
        if (!check_vr(m, "fmi2GetInteger", vr[k], N_INTEGER)) return fmi2Error;
        value[k] = m->i[vr[k]];
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    for (size_t k = 0; k < nvr; k++) {
        if (!check_vr(m, "fmi2GetBoolean", vr[k], N_BOOLEAN)) return fmi2Error;
        value[k] = m->b[vr[k]];
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    (void)vr; (void)value;
    Model *m = (Model *)c;
    if (nvr > 0) { fmu_log(m, fmi2Error, "logStatusError", "model has no String variables"); return fmi2Error; }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    for (size_t k = 0; k < nvr; k++) {
        if (!check_vr(m, "fmi2SetReal", vr[k], N_REAL)) return fmi2Error;
        if (IS_DISCRETE_REAL(vr[k]) && !check_discrete_settable(m, "fmi2SetReal", vr[k])) return fmi2Error;
        m->r[vr[k]] = value[k];
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    for (size_t k = 0; k < nvr; k++) {
        if (!check_vr(m, "fmi2SetInteger", vr[k], N_INTEGER)) return fmi2Error;
        if (!check_discrete_settable(m, "fmi2SetInteger", vr[k])) return fmi2Error;
        m->i[vr[k]] = value[k];
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    for (size_t k = 0; k < nvr; k++) {
        if (!check_vr(m, "fmi2SetBoolean", vr[k], N_BOOLEAN)) return fmi2Error;
        if (!check_discrete_settable(m, "fmi2SetBoolean", vr[k])) return fmi2Error;
        m->b[vr[k]] = value[k] ? 1 : 0;
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    (void)vr; (void)value;
    Model *m = (Model *)c;
    if (nvr > 0) { fmu_log(m, fmi2Error, "logStatusError", "model has no String variables"); return fmi2Error; }
    return fmi2OK;
}

/* ---- FMU state (not supported: canGetAndSetFMUstate="false") ------------ */

FMI2_EXPORT fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; (void)s; return fmi2Error; }
FMI2_EXPORT fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { (void)c; (void)s; return fmi2Error; }
FMI2_EXPORT fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c; (void)s; return fmi2Error; }
FMI2_EXPORT fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) { (void)c; (void)s; (void)n; return fmi2Error; }
FMI2_EXPORT fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) { (void)c; (void)s; (void)b; (void)n; return fmi2Error; }
FMI2_EXPORT fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) { (void)c; (void)b; (void)n; (void)s; return fmi2Error; }
FMI2_EXPORT fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                                    const fmi2ValueReference z[], size_t nz, const fmi2Real du[], fmi2Real dz[]) {
    (void)c; (void)u; (void)nu; (void)z; (void)nz; (void)du; (void)dz;
    return fmi2Error;
}

/* ---- Model Exchange ------------------------------------------------------ */

FMI2_EXPORT fmi2Status fmi2EnterEventMode(fmi2Component c) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    m->mode = MODE_EVENT;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    Model *m = (Model *)c;
    if (!m || !info) return fmi2Error;
    m->valuesChanged = 0;
    fmi2Status s = model_derivatives(m);
    if (s > fmi2Warning) return s;
    model_event_update(m);
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = m->terminateSimulation;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = m->valuesChanged;
    info->nextEventTimeDefined = m->nextEventTimeDefined;
    info->nextEventTime = m->nextEventTime;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    m->mode = MODE_CONTINUOUS;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetPrior, fmi2Boolean *enterEventMode,
                                                   fmi2Boolean *terminateSimulation) {
    (void)noSetPrior;
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    if (enterEventMode) *enterEventMode = fmi2False;
    if (terminateSimulation) *terminateSimulation = m->terminateSimulation;
#ifdef COMPLETED_STEPS_VR
    m->i[COMPLETED_STEPS_VR]++;
#endif
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) {
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    m->time = t;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    Model *m = (Model *)c;
    if (!m || nx != NX) return fmi2Error;
    for (size_t k = 0; k < nx; k++) STATE(k) = x[k];
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    Model *m = (Model *)c;
    if (!m || nx != NX) return fmi2Error;
    for (size_t k = 0; k < nx; k++) x[k] = STATE(k);
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t nx) {
    Model *m = (Model *)c;
    if (!m || nx != NX) return fmi2Error;
    fmi2Status s = model_derivatives(m);
    if (s > fmi2Warning) return s;
    for (size_t k = 0; k < nx; k++) dx[k] = DERIV(k);
    return s;
}

FMI2_EXPORT fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t nz) {
    Model *m = (Model *)c;
    if (!m || nz != NZ) return fmi2Error;
    if (nz > 0) {
        fmi2Status s = model_derivatives(m);
        if (s > fmi2Warning) return s;
        model_event_indicators(m, z);
    }
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real nominals[], size_t nx) {
    Model *m = (Model *)c;
    if (!m || nx != NX) return fmi2Error;
    for (size_t k = 0; k < nx; k++) nominals[k] = model_nominal((int)k);
    return fmi2OK;
}

/* ---- Co-Simulation ------------------------------------------------------- */

static fmi2Status cs_rhs(Model *m, double t, const double *x, double *dx) {
    m->time = t;
    for (int k = 0; k < NX; k++) STATE(k) = x[k];
    fmi2Status s = model_derivatives(m);
    for (int k = 0; k < NX; k++) dx[k] = DERIV(k);
    return s;
}

#if CS_IMPLICIT
/* Solves A y = b in place (Gaussian elimination with partial pivoting). */
static int cs_solve(double A[NX_ALLOC][NX_ALLOC], double *b) {
    for (int col = 0; col < NX; col++) {
        int piv = col;
        for (int r = col + 1; r < NX; r++) if (fabs(A[r][col]) > fabs(A[piv][col])) piv = r;
        if (fabs(A[piv][col]) < 1e-300) return -1;
        if (piv != col) {
            for (int k = 0; k < NX; k++) { double t = A[col][k]; A[col][k] = A[piv][k]; A[piv][k] = t; }
            double t = b[col]; b[col] = b[piv]; b[piv] = t;
        }
        for (int r = col + 1; r < NX; r++) {
            double f = A[r][col] / A[col][col];
            for (int k = col; k < NX; k++) A[r][k] -= f * A[col][k];
            b[r] -= f * b[col];
        }
    }
    for (int r = NX - 1; r >= 0; r--) {
        for (int k = r + 1; k < NX; k++) b[r] -= A[r][k] * b[k];
        b[r] /= A[r][r];
    }
    return 0;
}

/* One stage of SDIRK: solve Y = base + h*gamma*f(t, Y) by Newton with a finite-difference Jacobian. */
static fmi2Status cs_stage(Model *m, double t, double hg, const double *base, double *Y) {
    double f[NX_ALLOC], fp[NX_ALLOC], J[NX_ALLOC][NX_ALLOC], res[NX_ALLOC];
    for (int it = 0; it < 20; it++) {
        fmi2Status s = cs_rhs(m, t, Y, f);
        if (s > fmi2Warning) return s;
        double norm = 0;
        for (int k = 0; k < NX; k++) {
            res[k] = -(Y[k] - base[k] - hg * f[k]);
            norm = fmax(norm, fabs(res[k]) / (1e-10 + 1e-10 * fabs(Y[k]) + 1e-12 * model_nominal(k)));
        }
        if (norm < 1.0 && it > 0) return fmi2OK;
        for (int j = 0; j < NX; j++) {
            double save = Y[j];
            double d = 1e-8 * fmax(fabs(save), model_nominal(j));
            Y[j] = save + d;
            s = cs_rhs(m, t, Y, fp);
            Y[j] = save;
            if (s > fmi2Warning) return s;
            for (int k = 0; k < NX; k++) J[k][j] = (k == j ? 1.0 : 0.0) - hg * (fp[k] - f[k]) / d;
        }
        if (cs_solve(J, res) != 0) return fmi2Error;
        for (int k = 0; k < NX; k++) Y[k] += res[k];
    }
    return fmi2OK;
}

/* L-stable two-stage SDIRK of order 2 (gamma = 1 - 1/sqrt(2)). */
static fmi2Status cs_step(Model *m, double t, double h, const double *x0, double *x1) {
    const double g = 1.0 - 1.0 / sqrt(2.0);
    double Y1[NX_ALLOC], Y2[NX_ALLOC], k1[NX_ALLOC], base[NX_ALLOC];
    memcpy(Y1, x0, sizeof(double) * NX);
    fmi2Status s = cs_stage(m, t + g * h, h * g, x0, Y1);
    if (s > fmi2Warning) return s;
    s = cs_rhs(m, t + g * h, Y1, k1);
    if (s > fmi2Warning) return s;
    for (int k = 0; k < NX; k++) { base[k] = x0[k] + h * (1.0 - g) * k1[k]; Y2[k] = Y1[k]; }
    s = cs_stage(m, t + h, h * g, base, Y2);
    if (s > fmi2Warning) return s;
    memcpy(x1, Y2, sizeof(double) * NX);
    return fmi2OK;
}
#else
/* Classic fourth-order Runge-Kutta step. */
static fmi2Status cs_step(Model *m, double t, double h, const double *x0, double *x1) {
    double k1[NX_ALLOC], k2[NX_ALLOC], k3[NX_ALLOC], k4[NX_ALLOC], tmp[NX_ALLOC];
    fmi2Status s;
    if ((s = cs_rhs(m, t, x0, k1)) > fmi2Warning) return s;
    for (int k = 0; k < NX; k++) tmp[k] = x0[k] + 0.5 * h * k1[k];
    if ((s = cs_rhs(m, t + 0.5 * h, tmp, k2)) > fmi2Warning) return s;
    for (int k = 0; k < NX; k++) tmp[k] = x0[k] + 0.5 * h * k2[k];
    if ((s = cs_rhs(m, t + 0.5 * h, tmp, k3)) > fmi2Warning) return s;
    for (int k = 0; k < NX; k++) tmp[k] = x0[k] + h * k3[k];
    if ((s = cs_rhs(m, t + h, tmp, k4)) > fmi2Warning) return s;
    for (int k = 0; k < NX; k++) x1[k] = x0[k] + h / 6.0 * (k1[k] + 2 * k2[k] + 2 * k3[k] + k4[k]);
    return fmi2OK;
}
#endif

static int crossed(const double *z0, const double *z1) {
    for (int k = 0; k < NZ; k++)
        if ((z0[k] > 0 && z1[k] <= 0) || (z0[k] < 0 && z1[k] >= 0)) return 1;
    return 0;
}

/* Advances by h from (t, x0) into the model's states; returns the status of the step. */
static fmi2Status cs_advance_to(Model *m, double t, double h, const double *x0) {
    double x1[NX_ALLOC];
    fmi2Status s = cs_step(m, t, h, x0, x1);
    if (s > fmi2Warning) return s;
    m->time = t + h;
    for (int k = 0; k < NX; k++) STATE(k) = x1[k];
    return model_derivatives(m);
}

static fmi2Status cs_event(Model *m) {
    for (int iter = 0; iter < 100; iter++) {
        m->valuesChanged = 0;
        fmi2Status s = model_derivatives(m);
        if (s > fmi2Warning) return s;
        model_event_update(m);
        if (!m->valuesChanged) break;
    }
    return model_derivatives(m);
}

static fmi2Status cs_integrate(Model *m, double tEnd) {
    const double eps = 1e-12 * fmax(1.0, fabs(tEnd));
    while (m->time < tEnd - eps) {
        double t0 = m->time;
        double h = fmin(CS_STEP, tEnd - t0);
        int timeEvent = 0;
        if (m->nextEventTimeDefined && m->nextEventTime <= t0 + h + eps) {
            h = m->nextEventTime - t0;
            timeEvent = 1;
        }
        double x0[NX_ALLOC], z0[NZ_ALLOC], z1[NZ_ALLOC];
        for (int k = 0; k < NX; k++) x0[k] = STATE(k);
        fmi2Status s;
        if (h > 0) {
            if (NZ > 0) model_event_indicators(m, z0);
            if ((s = cs_advance_to(m, t0, h, x0)) > fmi2Warning) return s;
            if (NZ > 0) {
                model_event_indicators(m, z1);
                if (crossed(z0, z1)) {
                    double lo = 0, hi = h;
                    for (int it = 0; it < 80 && hi - lo > 1e-15 * fmax(1.0, fabs(t0)); it++) {
                        double mid = 0.5 * (lo + hi);
                        if ((s = cs_advance_to(m, t0, mid, x0)) > fmi2Warning) return s;
                        model_event_indicators(m, z1);
                        if (crossed(z0, z1)) hi = mid; else lo = mid;
                    }
                    if ((s = cs_advance_to(m, t0, hi, x0)) > fmi2Warning) return s;
                    timeEvent = 0;
                    if ((s = cs_event(m)) > fmi2Warning) return s;
                }
            }
        }
        if (timeEvent) {
            m->time = m->nextEventTime;
            m->nextEventTimeDefined = 0;
            if ((s = cs_event(m)) > fmi2Warning) return s;
        }
        if (m->terminateSimulation) return fmi2Discard;
    }
    m->time = tEnd;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                   const fmi2Integer order[], const fmi2Real value[]) {
    (void)c; (void)vr; (void)nvr; (void)order; (void)value;
    return fmi2Error;
}

FMI2_EXPORT fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                                    const fmi2Integer order[], fmi2Real value[]) {
    (void)c; (void)vr; (void)nvr; (void)order; (void)value;
    return fmi2Error;
}

FMI2_EXPORT fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    (void)noSetPrior;
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    if (m->csTerminated) {
        fmu_log(m, fmi2Error, "logStatusError", "fmi2DoStep after the model terminated at t=%g", m->time);
        return fmi2Error;
    }
    if (fabs(t - m->time) > 1e-9 * fmax(1.0, fabs(t))) {
        fmu_log(m, fmi2Error, "logStatusError", "fmi2DoStep: communication point %.17g but model time is %.17g", t, m->time);
        return fmi2Error;
    }
    m->time = t;
    fmi2Status s = cs_integrate(m, t + h);
    if (s == fmi2Discard) {
        m->csTerminated = 1;
        m->lastSuccessfulTime = m->time;
        return fmi2Discard;
    }
    if (s > fmi2Warning) {
        m->mode = MODE_ERROR;
        return s;
    }
    m->lastSuccessfulTime = m->time;
    return s;
}

FMI2_EXPORT fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }

FMI2_EXPORT fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)c; (void)s;
    if (value) *value = fmi2OK;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    Model *m = (Model *)c;
    if (!m || !value || s != fmi2LastSuccessfulTime) return fmi2Discard;
    *value = m->lastSuccessfulTime;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)c; (void)s; (void)value;
    return fmi2Discard;
}

FMI2_EXPORT fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    Model *m = (Model *)c;
    if (!m || !value || s != fmi2Terminated) return fmi2Discard;
    *value = m->csTerminated;
    return fmi2OK;
}

FMI2_EXPORT fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)c; (void)s; (void)value;
    return fmi2Discard;
}
