/* FMI 2.0 entry points shared by fmucal's example models (the default build); see
 * fmu_framework.h. Model Exchange delegates to the model hooks; Co-Simulation integrates them
 * with fmu_cosim.c. */

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
    clear_extra_storage(m);
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
#ifdef N_STRING
    /* The pointers stay valid until the next call on this instance (FMI 2.0 section 2.1.7). */
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    if (nvr > 0 && m->mode != MODE_INSTANTIATED) {
        fmi2Status s = model_derivatives(m);
        if (s > fmi2Warning) return s;
    }
    for (size_t k = 0; k < nvr; k++) {
        if (!check_vr(m, "fmi2GetString", vr[k], N_STRING)) return fmi2Error;
        value[k] = m->s[vr[k]];
    }
    return fmi2OK;
#else
    (void)vr; (void)value;
    Model *m = (Model *)c;
    if (nvr > 0) { fmu_log(m, fmi2Error, "logStatusError", "model has no String variables"); return fmi2Error; }
    return fmi2OK;
#endif
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
#ifdef N_STRING
    Model *m = (Model *)c;
    if (!m) return fmi2Error;
    for (size_t k = 0; k < nvr; k++) {
        if (!check_vr(m, "fmi2SetString", vr[k], N_STRING)) return fmi2Error;
        if (!check_discrete_settable(m, "fmi2SetString", vr[k])) return fmi2Error;
        const char *v = value[k] ? value[k] : "";
        if (strlen(v) >= STRING_CAP) {
            fmu_log(m, fmi2Error, "logStatusError", "fmi2SetString: value reference %u: %zu bytes, at most %d", vr[k],
                    strlen(v), STRING_CAP - 1);
            return fmi2Error;
        }
        memcpy(m->s[vr[k]], v, strlen(v) + 1);
    }
    return fmi2OK;
#else
    (void)vr; (void)value;
    Model *m = (Model *)c;
    if (nvr > 0) { fmu_log(m, fmi2Error, "logStatusError", "model has no String variables"); return fmi2Error; }
    return fmi2OK;
#endif
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

/* ---- Co-Simulation (the integrator is fmu_cosim.c) ---------------------- */

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
