/* FMI 1.0 entry points of fmucal's example models (compiled with FMUCAL_FMI1); see
 * fmu_framework.h. Written from the FMI 1.0 specifications (Model Exchange 1.0 and
 * Co-Simulation 1.0). FMI 1.0's two interfaces are separate FMUs, so one binary offers one:
 *   - FMUCAL_FMI1 = 1, Model Exchange: the model hooks, as in fmu_framework2.c; fmiInitialize
 *     makes the first event iteration (FMI 2.0's first fmi2NewDiscreteStates) and fmiEventUpdate
 *     the others, each converging in one pass;
 *   - FMUCAL_FMI1 = 2, Co-Simulation (CoSimulation_StandAlone): fmiDoStep integrates with
 *     fmu_cosim.c (the 2.0 build's integrator) and handles events inside the step.
 * Every function is exported as "<modelIdentifier>_fmiXxx" (fmi1.h adds the prefix FMI1_PREFIX;
 * with FMUCAL_FMI1_UNPREFIXED the names are plain, a broken fixture). Value references are the
 * 2.0 build's: per type, Real k is m->r[k], Integer k m->i[k], Boolean k m->b[k], String k
 * m->s[k] (models that define N_STRING).
 *
 * FMI 1.0 has no Continuous-Time Mode, so discrete variables may be set whenever a value may be
 * (IS_DISCRETE_REAL is not enforced here). What the descriptions do not declare (input
 * interpolation, output derivatives, cancelling or repeating a step, String variables of a
 * model without N_STRING) answers fmiError with a logged message. */

#define FMI1_STR2(x) #x
#define FMI1_STR(x) FMI1_STR2(x)

/* The hooks' status as FMI 1.0's (the same numbers; fmiPending only in Co-Simulation). */
static fmiStatus status1(fmi2Status s) {
#if FMUCAL_FMI1 == 1
    if (s == fmi2Pending) return fmiError;
#endif
    return (fmiStatus)s;
}

static void fmu_log(Model *m, fmi2Status status, const char *category, const char *fmt, ...) {
    if (!m || !m->logger) return;
    if (!m->loggingOn && status == fmi2OK) return;
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    /* FMI 1.0's message is a printf format. It is passed with every '%' doubled and no
     * arguments, so an importer that formats it reads the text, and one that prints it as it
     * is reads it too (but for doubled percent signs). */
    char msg[2 * sizeof buf];
    size_t n = 0;
    for (const char *p = buf; *p && n + 2 < sizeof msg; p++) {
        if (*p == '%') msg[n++] = '%';
        msg[n++] = *p;
    }
    msg[n] = 0;
    m->logger((fmiComponent)m, m->instanceName, status1(status), category, msg);
}

/* `return FAIL(m, ...)`: logs an error (whatever loggingOn says) and answers fmiError. */
#define FAIL(m, ...) (fmu_log((m), fmi2Error, "logStatusError", __VA_ARGS__), fmiError)

#define INSTANCE(fn) Model *m = (Model *)c; if (!m) return fmiError; (void)(fn)

static int vr_in_range(Model *m, const char *fn, fmiValueReference vr, int count, const char *type) {
    if ((int)vr >= count) {
        fmu_log(m, fmi2Error, "logStatusError", "%s: value reference %u names no %s variable", fn, vr, type);
        return 0;
    }
    return 1;
}

FMI1_EXPORT const char *fmiGetVersion(void) { return "1.0"; }

FMI1_EXPORT fmiStatus fmiSetDebugLogging(fmiComponent c, fmiBoolean loggingOn) {
    INSTANCE("fmiSetDebugLogging");
    m->loggingOn = loggingOn != fmiFalse;
    return fmiOK;
}

/* ---- instances ------------------------------------------------------------ */

static Model *instantiate(fmiString instanceName, fmiString guid, fmiCallbackLogger logger, fmiBoolean loggingOn,
                          fmi2Type type) {
    Model *m = (Model *)calloc(1, sizeof(Model));
    if (!m) return NULL;
    m->logger = logger;
    snprintf(m->instanceName, sizeof m->instanceName, "%s", instanceName ? instanceName : "instance");
    m->loggingOn = loggingOn != fmiFalse;
    m->type = type;
#if defined(FMI1_PREFIX)
    /* The exported names carry FMI1_PREFIX; the description's modelIdentifier is MODEL_IDENTIFIER. */
    if (strcmp(FMI1_STR(FMI1_PREFIX), MODEL_IDENTIFIER) != 0) {
        fmu_log(m, fmi2Error, "logStatusError", "built with the prefix %s, but the model identifier is %s",
                FMI1_STR(FMI1_PREFIX), MODEL_IDENTIFIER);
        free(m);
        return NULL;
    }
#endif
    if (!guid || strcmp(guid, MODEL_GUID) != 0) {
        fmu_log(m, fmi2Error, "logStatusError", "wrong GUID %s, expected %s", guid ? guid : "(null)", MODEL_GUID);
        free(m);
        return NULL;
    }
    model_defaults(m);
    return m;
}

/* ---- get / set ------------------------------------------------------------ */

FMI1_EXPORT fmiStatus fmiGetReal(fmiComponent c, const fmiValueReference vr[], size_t nvr, fmiReal value[]) {
    INSTANCE("fmiGetReal");
    if (nvr > 0 && m->mode != MODE_INSTANTIATED) {
        fmi2Status s = model_derivatives(m);
        if (s > fmi2Warning) return status1(s);
    }
    for (size_t k = 0; k < nvr; k++) {
        if (!vr_in_range(m, "fmiGetReal", vr[k], N_REAL, "Real")) return fmiError;
        value[k] = REPORTED_REAL(m, vr[k]);
    }
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiGetInteger(fmiComponent c, const fmiValueReference vr[], size_t nvr, fmiInteger value[]) {
    INSTANCE("fmiGetInteger");
    for (size_t k = 0; k < nvr; k++) {
        if (!vr_in_range(m, "fmiGetInteger", vr[k], N_INTEGER, "Integer")) return fmiError;
        value[k] = m->i[vr[k]];
    }
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiGetBoolean(fmiComponent c, const fmiValueReference vr[], size_t nvr, fmiBoolean value[]) {
    INSTANCE("fmiGetBoolean");
    for (size_t k = 0; k < nvr; k++) {
        if (!vr_in_range(m, "fmiGetBoolean", vr[k], N_BOOLEAN, "Boolean")) return fmiError;
        value[k] = m->b[vr[k]] ? fmiTrue : fmiFalse;
    }
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiGetString(fmiComponent c, const fmiValueReference vr[], size_t nvr, fmiString value[]) {
    INSTANCE("fmiGetString");
#ifdef N_STRING
    if (nvr > 0 && m->mode != MODE_INSTANTIATED) {
        fmi2Status s = model_derivatives(m);
        if (s > fmi2Warning) return status1(s);
    }
    for (size_t k = 0; k < nvr; k++) {
        if (!vr_in_range(m, "fmiGetString", vr[k], N_STRING, "String")) return fmiError;
        value[k] = m->s[vr[k]];
    }
    return fmiOK;
#else
    (void)vr; (void)value;
    if (nvr > 0) return FAIL(m, "fmiGetString: the model has no String variables");
    return fmiOK;
#endif
}

FMI1_EXPORT fmiStatus fmiSetReal(fmiComponent c, const fmiValueReference vr[], size_t nvr, const fmiReal value[]) {
    INSTANCE("fmiSetReal");
    for (size_t k = 0; k < nvr; k++) {
        if (!vr_in_range(m, "fmiSetReal", vr[k], N_REAL, "Real")) return fmiError;
        m->r[vr[k]] = value[k];
    }
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiSetInteger(fmiComponent c, const fmiValueReference vr[], size_t nvr,
                                    const fmiInteger value[]) {
    INSTANCE("fmiSetInteger");
    for (size_t k = 0; k < nvr; k++) {
        if (!vr_in_range(m, "fmiSetInteger", vr[k], N_INTEGER, "Integer")) return fmiError;
        m->i[vr[k]] = value[k];
    }
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiSetBoolean(fmiComponent c, const fmiValueReference vr[], size_t nvr,
                                    const fmiBoolean value[]) {
    INSTANCE("fmiSetBoolean");
    for (size_t k = 0; k < nvr; k++) {
        if (!vr_in_range(m, "fmiSetBoolean", vr[k], N_BOOLEAN, "Boolean")) return fmiError;
        m->b[vr[k]] = value[k] != fmiFalse;
    }
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiSetString(fmiComponent c, const fmiValueReference vr[], size_t nvr,
                                   const fmiString value[]) {
    INSTANCE("fmiSetString");
#ifdef N_STRING
    for (size_t k = 0; k < nvr; k++) {
        if (!vr_in_range(m, "fmiSetString", vr[k], N_STRING, "String")) return fmiError;
        const char *v = value[k] ? value[k] : "";
        if (strlen(v) >= STRING_CAP)
            return FAIL(m, "fmiSetString: value reference %u: %zu bytes, at most %d", vr[k], strlen(v), STRING_CAP - 1);
        memcpy(m->s[vr[k]], v, strlen(v) + 1);
    }
    return fmiOK;
#else
    (void)vr; (void)value;
    if (nvr > 0) return FAIL(m, "fmiSetString: the model has no String variables");
    return fmiOK;
#endif
}

#if FMUCAL_FMI1 == 1
/* ---- Model Exchange ------------------------------------------------------- */

FMI1_EXPORT const char *fmiGetModelTypesPlatform(void) { return "standard32"; }

FMI1_EXPORT fmiComponent fmiInstantiateModel(fmiString instanceName, fmiString GUID,
                                             fmiMECallbackFunctions functions, fmiBoolean loggingOn) {
    Model *m = instantiate(instanceName, GUID, functions.logger, loggingOn, fmi2ModelExchange);
    if (!m) return NULL;
    /* Model Exchange 1.0 passes no resource location. */
    if (model_instantiated(m) > fmi2Warning) {
        free(m);
        return NULL;
    }
    m->mode = MODE_INSTANTIATED;
    return m;
}

FMI1_EXPORT void fmiFreeModelInstance(fmiComponent c) { free(c); }

FMI1_EXPORT fmiStatus fmiSetTime(fmiComponent c, fmiReal time) {
    INSTANCE("fmiSetTime");
    m->time = time;
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiSetContinuousStates(fmiComponent c, const fmiReal x[], size_t nx) {
    INSTANCE("fmiSetContinuousStates");
    if (nx != NX) return FAIL(m, "fmiSetContinuousStates: %zu states given, the model has %d", nx, NX);
    for (size_t k = 0; k < nx; k++) STATE(k) = x[k];
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiCompletedIntegratorStep(fmiComponent c, fmiBoolean *callEventUpdate) {
    INSTANCE("fmiCompletedIntegratorStep");
    if (callEventUpdate) *callEventUpdate = fmiFalse;
#ifdef COMPLETED_STEPS_VR
    m->i[COMPLETED_STEPS_VR]++;
#endif
    return fmiOK;
}

/* One pass of the model's event handling, reported as converged. */
static fmiStatus event_iteration(Model *m, fmiEventInfo *info) {
    m->valuesChanged = 0;
    fmi2Status s = model_derivatives(m);
    if (s > fmi2Warning) return status1(s);
    model_event_update(m);
    info->iterationConverged = fmiTrue;
    info->stateValueReferencesChanged = fmiFalse;
    info->stateValuesChanged = m->valuesChanged ? fmiTrue : fmiFalse;
    info->terminateSimulation = m->terminateSimulation ? fmiTrue : fmiFalse;
    info->upcomingTimeEvent = m->nextEventTimeDefined ? fmiTrue : fmiFalse;
    info->nextEventTime = m->nextEventTime;
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiInitialize(fmiComponent c, fmiBoolean toleranceControlled, fmiReal relativeTolerance,
                                    fmiEventInfo *eventInfo) {
    INSTANCE("fmiInitialize");
    if (!eventInfo) return FAIL(m, "fmiInitialize: eventInfo is NULL");
    if (m->mode != MODE_INSTANTIATED) return FAIL(m, "fmiInitialize: the model is initialized already");
#ifdef TOLERANCE_VR
    m->r[TOLERANCE_VR] = toleranceControlled ? relativeTolerance : 0.0;
#endif
#ifdef WARN_TOLERANCE_IN_ME
    if (toleranceControlled)
        fmu_log(m, fmi2Warning, "logStatusWarning",
                "fmiInitialize: the tolerance is ignored in Model Exchange (the importer integrates)");
#endif
    (void)toleranceControlled; (void)relativeTolerance;
    fmi2Status s = model_initialize(m);
    if (s > fmi2Warning) { m->mode = MODE_ERROR; return status1(s); }
    m->mode = MODE_EVENT;
    fmiStatus e = event_iteration(m, eventInfo);
    if (e > fmiWarning) { m->mode = MODE_ERROR; return e; }
    m->mode = MODE_CONTINUOUS;
    return s == fmi2Warning ? fmiWarning : e;
}

FMI1_EXPORT fmiStatus fmiEventUpdate(fmiComponent c, fmiBoolean intermediateResults, fmiEventInfo *eventInfo) {
    (void)intermediateResults; /* each iteration converges at once: no intermediate results */
    INSTANCE("fmiEventUpdate");
    if (!eventInfo) return FAIL(m, "fmiEventUpdate: eventInfo is NULL");
    if (m->mode == MODE_INSTANTIATED) return FAIL(m, "fmiEventUpdate before fmiInitialize");
    return event_iteration(m, eventInfo);
}

FMI1_EXPORT fmiStatus fmiGetDerivatives(fmiComponent c, fmiReal derivatives[], size_t nx) {
    INSTANCE("fmiGetDerivatives");
    if (nx != NX) return FAIL(m, "fmiGetDerivatives: %zu derivatives asked for, the model has %d", nx, NX);
    fmi2Status s = model_derivatives(m);
    if (s > fmi2Warning) return status1(s);
    for (size_t k = 0; k < nx; k++) derivatives[k] = DERIV(k);
    return status1(s);
}

FMI1_EXPORT fmiStatus fmiGetEventIndicators(fmiComponent c, fmiReal eventIndicators[], size_t ni) {
    INSTANCE("fmiGetEventIndicators");
    if (ni != NZ) return FAIL(m, "fmiGetEventIndicators: %zu indicators asked for, the model has %d", ni, NZ);
    if (ni > 0) {
        fmi2Status s = model_derivatives(m);
        if (s > fmi2Warning) return status1(s);
        model_event_indicators(m, eventIndicators);
    }
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiGetContinuousStates(fmiComponent c, fmiReal states[], size_t nx) {
    INSTANCE("fmiGetContinuousStates");
    if (nx != NX) return FAIL(m, "fmiGetContinuousStates: %zu states asked for, the model has %d", nx, NX);
    for (size_t k = 0; k < nx; k++) states[k] = STATE(k);
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiGetNominalContinuousStates(fmiComponent c, fmiReal x_nominal[], size_t nx) {
    INSTANCE("fmiGetNominalContinuousStates");
    if (nx != NX) return FAIL(m, "fmiGetNominalContinuousStates: %zu nominals asked for, the model has %d", nx, NX);
    for (size_t k = 0; k < nx; k++) x_nominal[k] = model_nominal((int)k);
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiGetStateValueReferences(fmiComponent c, fmiValueReference vrx[], size_t nx) {
    INSTANCE("fmiGetStateValueReferences");
    if (nx != NX) return FAIL(m, "fmiGetStateValueReferences: %zu asked for, the model has %d states", nx, NX);
    for (size_t k = 0; k < nx; k++) vrx[k] = STATE_VR[k];
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiTerminate(fmiComponent c) {
    INSTANCE("fmiTerminate");
    m->mode = MODE_TERMINATED;
    return fmiOK;
}

#else
/* ---- Co-Simulation (the integrator is fmu_cosim.c) ------------------------ */

/* The folder of an FMU location URI ("file:///tmp/x" or "file:/tmp/x", percent-encoded). */
static void decode_location(const char *uri, char *out, size_t cap) {
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
    while (n > 1 && out[n - 1] == '/') n--;
    out[n] = 0;
}

FMI1_EXPORT const char *fmiGetTypesPlatform(void) { return "standard32"; }

FMI1_EXPORT fmiComponent fmiInstantiateSlave(fmiString instanceName, fmiString fmuGUID, fmiString fmuLocation,
                                             fmiString mimeType, fmiReal timeout, fmiBoolean visible,
                                             fmiBoolean interactive, fmiCSCallbackFunctions functions,
                                             fmiBoolean loggingOn) {
    /* A stand-alone slave: no tool to start, so the MIME type, timeout, visible and interactive
     * do not apply; stepFinished is never called (fmiDoStep never returns fmiPending). */
    (void)mimeType; (void)timeout; (void)visible; (void)interactive;
    (void)model_nominal; /* Co-Simulation needs the nominals only in the implicit integrator */
    Model *m = instantiate(instanceName, fmuGUID, functions.logger, loggingOn, fmi2CoSimulation);
    if (!m) return NULL;
    /* Co-Simulation 1.0 passes the URI of the unzipped FMU; its resources/ are the model's. */
    char dir[sizeof m->resourceDir - 16];
    decode_location(fmuLocation, dir, sizeof dir);
    if (dir[0]) snprintf(m->resourceDir, sizeof m->resourceDir, "%s/resources", dir);
    if (model_instantiated(m) > fmi2Warning) {
        free(m);
        return NULL;
    }
    m->mode = MODE_INSTANTIATED;
    return m;
}

FMI1_EXPORT fmiStatus fmiInitializeSlave(fmiComponent c, fmiReal tStart, fmiBoolean StopTimeDefined, fmiReal tStop) {
    (void)StopTimeDefined; (void)tStop;
    INSTANCE("fmiInitializeSlave");
    if (m->mode != MODE_INSTANTIATED) return FAIL(m, "fmiInitializeSlave: the slave is initialized already");
#ifdef TOLERANCE_VR
    m->r[TOLERANCE_VR] = 0.0; /* Co-Simulation 1.0 passes no tolerance */
#endif
    m->time = tStart;
    m->lastSuccessfulTime = tStart;
    m->mode = MODE_INITIALIZATION;
    fmi2Status s = model_initialize(m);
    if (s > fmi2Warning) { m->mode = MODE_ERROR; return status1(s); }
    m->mode = MODE_STEP_COMPLETE;
    return status1(s);
}

FMI1_EXPORT fmiStatus fmiTerminateSlave(fmiComponent c) {
    INSTANCE("fmiTerminateSlave");
    m->mode = MODE_TERMINATED;
    return fmiOK;
}

/* Back to the state after instantiation (start values), keeping the callbacks and logging. */
static void reset_to_defaults(Model *m) {
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
    model_defaults(m);
    m->mode = MODE_INSTANTIATED;
}

FMI1_EXPORT fmiStatus fmiResetSlave(fmiComponent c) {
    INSTANCE("fmiResetSlave");
#ifdef FMUCAL_RESET_FAILS /* test fixture: an FMU whose reset always fails */
    return FAIL(m, "fmiResetSlave is not supported by this build");
#endif
    reset_to_defaults(m);
    return fmiOK;
}

FMI1_EXPORT void fmiFreeSlaveInstance(fmiComponent c) { free(c); }

FMI1_EXPORT fmiStatus fmiSetRealInputDerivatives(fmiComponent c, const fmiValueReference vr[], size_t nvr,
                                                 const fmiInteger order[], const fmiReal value[]) {
    (void)vr; (void)order; (void)value;
    INSTANCE("fmiSetRealInputDerivatives");
    if (nvr == 0) return fmiOK;
    return FAIL(m, "fmiSetRealInputDerivatives: this slave does not interpolate inputs (canInterpolateInputs=\"false\")");
}

FMI1_EXPORT fmiStatus fmiGetRealOutputDerivatives(fmiComponent c, const fmiValueReference vr[], size_t nvr,
                                                  const fmiInteger order[], fmiReal value[]) {
    (void)vr; (void)order; (void)value;
    INSTANCE("fmiGetRealOutputDerivatives");
    if (nvr == 0) return fmiOK;
    return FAIL(m, "fmiGetRealOutputDerivatives: this slave provides no output derivatives "
                   "(maxOutputDerivativeOrder=\"0\")");
}

/* Integrates from currentCommunicationPoint over the step, events handled inside. A model that
 * requests termination ends the step there with fmiDiscard; fmiGetRealStatus
 * (fmiLastSuccessfulTime) then tells where it stopped, as in the 2.0 build. */
FMI1_EXPORT fmiStatus fmiDoStep(fmiComponent c, fmiReal currentCommunicationPoint, fmiReal communicationStepSize,
                                fmiBoolean newStep) {
    INSTANCE("fmiDoStep");
    double t = currentCommunicationPoint, h = communicationStepSize;
    if (m->csTerminated) return FAIL(m, "fmiDoStep after the model terminated at t=%g", m->time);
    if (m->mode != MODE_STEP_COMPLETE) return FAIL(m, "fmiDoStep: the slave is not initialized");
    if (!newStep) return FAIL(m, "fmiDoStep: newStep = false (repeating a step) is not supported");
    if (!(h >= 0)) return FAIL(m, "fmiDoStep: communicationStepSize %g is negative", h);
    if (fabs(t - m->time) > 1e-9 * fmax(1.0, fabs(t)))
        return FAIL(m, "fmiDoStep: communication point %.17g but model time is %.17g", t, m->time);
    m->time = t;
    fmi2Status s = cs_integrate(m, t + h);
    if (s == fmi2Discard) { /* the model requested termination */
        m->csTerminated = 1;
        m->lastSuccessfulTime = m->time;
        return fmiDiscard;
    }
    if (s > fmi2Warning) {
        m->mode = MODE_ERROR;
        return status1(s);
    }
    m->lastSuccessfulTime = m->time;
    return status1(s);
}

FMI1_EXPORT fmiStatus fmiCancelStep(fmiComponent c) {
    INSTANCE("fmiCancelStep");
    return FAIL(m, "fmiCancelStep: fmiDoStep never returns fmiPending (canRunAsynchronuously=\"false\")");
}

FMI1_EXPORT fmiStatus fmiGetStatus(fmiComponent c, const fmiStatusKind s, fmiStatus *value) {
    INSTANCE("fmiGetStatus");
    if (s != fmiDoStepStatus || !value) return fmiDiscard;
    *value = m->mode == MODE_ERROR ? fmiError : m->csTerminated ? fmiDiscard : fmiOK;
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiGetRealStatus(fmiComponent c, const fmiStatusKind s, fmiReal *value) {
    INSTANCE("fmiGetRealStatus");
    if (s != fmiLastSuccessfulTime || !value) return fmiDiscard;
    *value = m->lastSuccessfulTime;
    return fmiOK;
}

FMI1_EXPORT fmiStatus fmiGetIntegerStatus(fmiComponent c, const fmiStatusKind s, fmiInteger *value) {
    (void)s; (void)value;
    INSTANCE("fmiGetIntegerStatus");
    return fmiDiscard;
}

FMI1_EXPORT fmiStatus fmiGetBooleanStatus(fmiComponent c, const fmiStatusKind s, fmiBoolean *value) {
    (void)s; (void)value;
    INSTANCE("fmiGetBooleanStatus");
    return fmiDiscard;
}

FMI1_EXPORT fmiStatus fmiGetStringStatus(fmiComponent c, const fmiStatusKind s, fmiString *value) {
    (void)s; (void)value;
    INSTANCE("fmiGetStringStatus");
    return fmiDiscard;
}
#endif
