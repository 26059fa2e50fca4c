/* FMI 3.0 entry points of fmucal's example models (compiled with FMUCAL_FMI3); see
 * fmu_framework.h. Written from the FMI 3.0 specification. One binary offers:
 *   - Model Exchange: the model hooks, as in fmu_framework2.c;
 *   - Co-Simulation without Event Mode: fmi3DoStep integrates with fmu_cosim.c (the 2.0 build's
 *     integrator) and handles events inside the step, so fmi3InstantiateCoSimulation refuses
 *     eventModeUsed = true; it never returns early.
 * What the descriptions declare absent answers fmi3Error with a logged message, as an exporting
 * tool's FMU does: Scheduled Execution, FMU states, directional and adjoint derivatives,
 * variable dependencies, configuration mode, clocks, output derivatives, and getters/setters of
 * types the model has no variables of (called with no value references they succeed).
 *
 * Value references (fmu_framework.h): Float64 k is m->r[k] (arrays: FMI3_FLOAT64_SIZE), Int32
 * and Boolean follow after the Reals, then time, then the event indicators, then the optional
 * UInt64, String and Binary variables (N_UINT64, N_STRING, N_BINARY). */

#ifndef FMI3_FLOAT64_SIZE
#define FMI3_FLOAT64_SIZE(vr) 1
#endif

#define VR3_INT32 ((fmi3ValueReference)N_REAL)
#define VR3_BOOLEAN ((fmi3ValueReference)(N_REAL + N_INTEGER))
#define VR3_TIME ((fmi3ValueReference)(N_REAL + N_INTEGER + N_BOOLEAN))
#define VR3_INDICATOR ((fmi3ValueReference)(N_REAL + N_INTEGER + N_BOOLEAN + 1))
#ifdef N_UINT64
#define N_UINT64_COUNT N_UINT64
#else
#define N_UINT64_COUNT 0
#endif
#ifdef N_STRING
#define N_STRING_COUNT N_STRING
#else
#define N_STRING_COUNT 0
#endif
#define VR3_UINT64 ((fmi3ValueReference)(VR3_INDICATOR + NZ))
#define VR3_STRING ((fmi3ValueReference)(VR3_UINT64 + N_UINT64_COUNT))
#define VR3_BINARY ((fmi3ValueReference)(VR3_STRING + N_STRING_COUNT))

static void fmu_log(Model *m, fmi2Status status, const char *category, const char *fmt, ...) {
    if (!m || !m->logMessage) return;
    if (!m->loggingOn && status == fmi2OK) return;
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    m->logMessage(m->instanceEnvironment, status == fmi2Pending ? fmi3Error : (fmi3Status)status, category, buf);
}

/* The hooks' status as FMI 3.0's (the same numbers; fmi2Pending does not exist in 3.0). */
static fmi3Status status3(fmi2Status s) { return s == fmi2Pending ? fmi3Error : (fmi3Status)s; }

/* `return FAIL(m, ...)`: logs an error (whatever loggingOn says, as the 2.0 skeleton does) and
 * answers fmi3Error. */
#define FAIL(m, ...) (fmu_log((m), fmi2Error, "logStatusError", __VA_ARGS__), fmi3Error)

/* An instance of the expected interface, or NULL after logging why not. */
static Model *as_model(fmi3Instance instance, const char *fn, int needME, int needCS) {
    Model *m = (Model *)instance;
    if (!m) return NULL;
    if ((needME && m->type != fmi2ModelExchange) || (needCS && m->type != fmi2CoSimulation)) {
        fmu_log(m, fmi2Error, "logStatusError", "%s: only for %s instances", fn,
                needME ? "Model Exchange" : "Co-Simulation");
        return NULL;
    }
    return m;
}

#define INSTANCE(fn) Model *m = as_model(instance, fn, 0, 0); if (!m) return fmi3Error
#define ME_INSTANCE(fn) Model *m = as_model(instance, fn, 1, 0); if (!m) return fmi3Error
#define CS_INSTANCE(fn) Model *m = as_model(instance, fn, 0, 1); if (!m) return fmi3Error

/* FMI 3.0 keeps 2.0's rule (section 3.2.3 there): discrete variables change only at events, so
 * they cannot be set in Continuous-Time Mode. */
static int discrete_settable(Model *m, const char *fn, fmi3ValueReference vr) {
    if (m->mode == MODE_CONTINUOUS) {
        fmu_log(m, fmi2Error, "logStatusError",
                "%s: discrete variable %u can only be set after instantiation, in initialization mode or event "
                "mode", fn, vr);
        return 0;
    }
    return 1;
}

/* A getter or setter of a type the model has no variables of. */
static fmi3Status no_variables(fmi3Instance instance, const char *fn, const char *type,
                               const fmi3ValueReference vr[], size_t nvr) {
    Model *m = (Model *)instance;
    if (!m) return fmi3Error;
    if (nvr == 0) return fmi3OK;
    return FAIL(m, "%s: value reference %u names no %s variable (the model has none)", fn, vr[0], type);
}

/* A function of a capability the descriptions do not declare. */
static fmi3Status not_provided(fmi3Instance instance, const char *fn, const char *why) {
    Model *m = (Model *)instance;
    if (!m) return fmi3Error;
    return FAIL(m, "%s is not supported: %s", fn, why);
}

FMI3_EXPORT const char *fmi3GetVersion(void) { return "3.0"; }

FMI3_EXPORT fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                                           const fmi3String categories[]) {
    (void)nCategories; (void)categories;
    INSTANCE("fmi3SetDebugLogging");
    m->loggingOn = loggingOn;
    return fmi3OK;
}

/* ---- instances ------------------------------------------------------------ */

static Model *instantiate(fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
                          fmi3Boolean loggingOn, fmi2Type type, fmi3InstanceEnvironment environment,
                          fmi3LogMessageCallback logMessage) {
    Model *m = (Model *)calloc(1, sizeof(Model));
    if (!m) return NULL;
    m->instanceEnvironment = environment;
    m->logMessage = logMessage;
    snprintf(m->instanceName, sizeof m->instanceName, "%s", instanceName ? instanceName : "instance");
    m->loggingOn = loggingOn;
    m->type = type;
    if (!instantiationToken || strcmp(instantiationToken, MODEL_GUID) != 0) {
        fmu_log(m, fmi2Error, "logStatusError", "wrong instantiationToken %s, expected %s",
                instantiationToken ? instantiationToken : "(null)", MODEL_GUID);
        free(m);
        return NULL;
    }
    /* FMI 3.0 passes a file system path (2.0 passed a URI), usually ending in a separator; stored
     * without it, as the 2.0 skeleton stores the decoded URI. */
    if (resourcePath) {
        snprintf(m->resourceDir, sizeof m->resourceDir, "%s", resourcePath);
        size_t n = strlen(m->resourceDir);
        while (n > 1 && m->resourceDir[n - 1] == '/') m->resourceDir[--n] = 0;
    }
    model_defaults(m);
    if (model_instantiated(m) > fmi2Warning) {
        free(m);
        return NULL;
    }
    m->mode = MODE_INSTANTIATED;
    return m;
}

FMI3_EXPORT fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                                      fmi3String resourcePath, fmi3Boolean visible,
                                                      fmi3Boolean loggingOn,
                                                      fmi3InstanceEnvironment instanceEnvironment,
                                                      fmi3LogMessageCallback logMessage) {
    (void)visible;
    return instantiate(instanceName, instantiationToken, resourcePath, loggingOn, fmi2ModelExchange,
                       instanceEnvironment, logMessage);
}

FMI3_EXPORT fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                                     fmi3String resourcePath, fmi3Boolean visible,
                                                     fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
                                                     fmi3Boolean earlyReturnAllowed,
                                                     const fmi3ValueReference requiredIntermediateVariables[],
                                                     size_t nRequiredIntermediateVariables,
                                                     fmi3InstanceEnvironment instanceEnvironment,
                                                     fmi3LogMessageCallback logMessage,
                                                     fmi3IntermediateUpdateCallback intermediateUpdate) {
    /* providesIntermediateUpdate="false": no intermediate variables, the callback is never called. */
    (void)visible; (void)requiredIntermediateVariables; (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    if (eventModeUsed) {
        /* hasEventMode="false": events are handled inside fmi3DoStep. */
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "fmi3InstantiateCoSimulation: eventModeUsed = true, but this FMU has no Event Mode in "
                       "Co-Simulation (hasEventMode=\"false\"); it handles events inside fmi3DoStep");
        return NULL;
    }
    Model *m = instantiate(instanceName, instantiationToken, resourcePath, loggingOn, fmi2CoSimulation,
                           instanceEnvironment, logMessage);
    if (m) m->earlyReturnAllowed = earlyReturnAllowed;
    return m;
}

FMI3_EXPORT fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                                           fmi3String resourcePath, fmi3Boolean visible,
                                                           fmi3Boolean loggingOn,
                                                           fmi3InstanceEnvironment instanceEnvironment,
                                                           fmi3LogMessageCallback logMessage,
                                                           fmi3ClockUpdateCallback clockUpdate,
                                                           fmi3LockPreemptionCallback lockPreemption,
                                                           fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "fmi3InstantiateScheduledExecution: this FMU offers Model Exchange and Co-Simulation only");
    return NULL;
}

FMI3_EXPORT void fmi3FreeInstance(fmi3Instance instance) { free(instance); }

FMI3_EXPORT fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                                   fmi3Float64 tolerance, fmi3Float64 startTime,
                                                   fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    INSTANCE("fmi3EnterInitializationMode");
    if (m->mode != MODE_INSTANTIATED)
        return FAIL(m, "fmi3EnterInitializationMode: the instance is not in the Instantiated state");
#ifdef TOLERANCE_VR
    m->r[TOLERANCE_VR] = toleranceDefined ? tolerance : 0.0;
#endif
#ifdef WARN_TOLERANCE_IN_ME
    if (toleranceDefined && m->type == fmi2ModelExchange)
        fmu_log(m, fmi2Warning, "logStatusWarning",
                "fmi3EnterInitializationMode: the tolerance is ignored in Model Exchange (the importer integrates)");
#endif
    m->time = startTime;
    m->lastSuccessfulTime = startTime;
    m->mode = MODE_INITIALIZATION;
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    INSTANCE("fmi3ExitInitializationMode");
    if (m->mode != MODE_INITIALIZATION)
        return FAIL(m, "fmi3ExitInitializationMode: the instance is not in Initialization Mode");
    fmi2Status s = model_initialize(m);
    if (s > fmi2Warning) { m->mode = MODE_ERROR; return status3(s); }
    /* Model Exchange goes to Event Mode; Co-Simulation without Event Mode to Step Mode. */
    m->mode = (m->type == fmi2ModelExchange) ? MODE_EVENT : MODE_STEP_COMPLETE;
    return status3(s);
}

FMI3_EXPORT fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    ME_INSTANCE("fmi3EnterEventMode");
    m->mode = MODE_EVENT;
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3Terminate(fmi3Instance instance) {
    INSTANCE("fmi3Terminate");
    m->mode = MODE_TERMINATED;
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3Reset(fmi3Instance instance) {
    INSTANCE("fmi3Reset");
#ifdef FMUCAL_RESET_FAILS /* test fixture: an FMU whose reset always fails */
    return FAIL(m, "fmi3Reset is not supported by this build");
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
    return fmi3OK;
}

/* ---- get / set ------------------------------------------------------------ */

/* Number of values of the Float64 variable vr (0: no such variable). */
static size_t float64_size(fmi3ValueReference vr) {
    if (vr < VR3_INT32) return (size_t)(FMI3_FLOAT64_SIZE(vr));
    if (vr == VR3_TIME || (vr >= VR3_INDICATOR && vr < VR3_INDICATOR + NZ)) return 1;
    return 0;
}

/* Checks that vr[] names nvr Float64 variables with nValues values in all. */
static int float64_count(Model *m, const char *fn, const fmi3ValueReference vr[], size_t nvr, size_t nValues) {
    size_t total = 0;
    for (size_t k = 0; k < nvr; k++) {
        size_t n = float64_size(vr[k]);
        if (n == 0) {
            fmu_log(m, fmi2Error, "logStatusError", "%s: value reference %u names no Float64 variable", fn, vr[k]);
            return 0;
        }
        total += n;
    }
    if (total != nValues) {
        fmu_log(m, fmi2Error, "logStatusError", "%s: nValues is %zu, but the %zu variables have %zu values", fn,
                nValues, nvr, total);
        return 0;
    }
    return 1;
}

FMI3_EXPORT fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                      fmi3Float64 values[], size_t nValues) {
    INSTANCE("fmi3GetFloat64");
    if (!float64_count(m, "fmi3GetFloat64", vr, nvr, nValues)) return fmi3Error;
    if (nvr > 0 && m->mode != MODE_INSTANTIATED) {
        fmi2Status s = model_derivatives(m);
        if (s > fmi2Warning) return status3(s);
    }
    double z[NZ_ALLOC] = {0};
    int haveIndicators = 0;
    size_t at = 0;
    for (size_t k = 0; k < nvr; k++) {
        fmi3ValueReference v = vr[k];
        if (v < VR3_INT32) {
            for (size_t e = 0; e < float64_size(v); e++) values[at++] = REPORTED_REAL(m, v + e);
        } else if (v == VR3_TIME) {
            values[at++] = m->time;
        } else {
            if (!haveIndicators) { model_event_indicators(m, z); haveIndicators = 1; }
            values[at++] = z[v - VR3_INDICATOR];
        }
    }
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                      const fmi3Float64 values[], size_t nValues) {
    INSTANCE("fmi3SetFloat64");
    if (!float64_count(m, "fmi3SetFloat64", vr, nvr, nValues)) return fmi3Error;
    size_t at = 0;
    for (size_t k = 0; k < nvr; k++) {
        fmi3ValueReference v = vr[k];
        if (v == VR3_TIME)
            return FAIL(m, "fmi3SetFloat64: time (value reference %u) is the independent variable; it moves with "
                           "fmi3SetTime or fmi3DoStep", v);
        if (v >= VR3_INT32)
            return FAIL(m, "fmi3SetFloat64: value reference %u is an event indicator, calculated by the model", v);
        for (size_t e = 0; e < float64_size(v); e++) {
            if (IS_DISCRETE_REAL(v + e) && !discrete_settable(m, "fmi3SetFloat64", v)) return fmi3Error;
            m->r[v + e] = values[at++];
        }
    }
    return fmi3OK;
}

static int scalar_count(Model *m, const char *fn, const char *type, const fmi3ValueReference vr[], size_t nvr,
                        size_t nValues, fmi3ValueReference first, int count) {
    for (size_t k = 0; k < nvr; k++) {
        if (vr[k] < first || vr[k] >= first + (fmi3ValueReference)count) {
            fmu_log(m, fmi2Error, "logStatusError", "%s: value reference %u names no %s variable", fn, vr[k], type);
            return 0;
        }
    }
    if (nValues != nvr) {
        fmu_log(m, fmi2Error, "logStatusError", "%s: nValues is %zu for %zu scalar variables", fn, nValues, nvr);
        return 0;
    }
    return 1;
}

FMI3_EXPORT fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                    fmi3Int32 values[], size_t nValues) {
    INSTANCE("fmi3GetInt32");
    if (!scalar_count(m, "fmi3GetInt32", "Int32", vr, nvr, nValues, VR3_INT32, N_INTEGER)) return fmi3Error;
    for (size_t k = 0; k < nvr; k++) values[k] = m->i[vr[k] - VR3_INT32];
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Int32 values[], size_t nValues) {
    INSTANCE("fmi3SetInt32");
    if (!scalar_count(m, "fmi3SetInt32", "Int32", vr, nvr, nValues, VR3_INT32, N_INTEGER)) return fmi3Error;
    for (size_t k = 0; k < nvr; k++) {
        if (!discrete_settable(m, "fmi3SetInt32", vr[k])) return fmi3Error;
        m->i[vr[k] - VR3_INT32] = values[k];
    }
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                      fmi3Boolean values[], size_t nValues) {
    INSTANCE("fmi3GetBoolean");
    if (!scalar_count(m, "fmi3GetBoolean", "Boolean", vr, nvr, nValues, VR3_BOOLEAN, N_BOOLEAN)) return fmi3Error;
    for (size_t k = 0; k < nvr; k++) values[k] = m->b[vr[k] - VR3_BOOLEAN] != 0;
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                      const fmi3Boolean values[], size_t nValues) {
    INSTANCE("fmi3SetBoolean");
    if (!scalar_count(m, "fmi3SetBoolean", "Boolean", vr, nvr, nValues, VR3_BOOLEAN, N_BOOLEAN)) return fmi3Error;
    for (size_t k = 0; k < nvr; k++) {
        if (!discrete_settable(m, "fmi3SetBoolean", vr[k])) return fmi3Error;
        m->b[vr[k] - VR3_BOOLEAN] = values[k] ? 1 : 0;
    }
    return fmi3OK;
}

/* Types the models have no variables of. */
#define NO_VARIABLES_OF(Name, Type)                                                                         \
    FMI3_EXPORT fmi3Status fmi3Get##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                                         Type values[], size_t nValues) {                                  \
        (void)values; (void)nValues;                                                                       \
        return no_variables(instance, "fmi3Get" #Name, #Name, vr, nvr);                                    \
    }                                                                                                      \
    FMI3_EXPORT fmi3Status fmi3Set##Name(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr, \
                                         const Type values[], size_t nValues) {                            \
        (void)values; (void)nValues;                                                                       \
        return no_variables(instance, "fmi3Set" #Name, #Name, vr, nvr);                                    \
    }
NO_VARIABLES_OF(Float32, fmi3Float32)
NO_VARIABLES_OF(Int8, fmi3Int8)
NO_VARIABLES_OF(UInt8, fmi3UInt8)
NO_VARIABLES_OF(Int16, fmi3Int16)
NO_VARIABLES_OF(UInt16, fmi3UInt16)
NO_VARIABLES_OF(UInt32, fmi3UInt32)
NO_VARIABLES_OF(Int64, fmi3Int64)
#ifndef N_UINT64
NO_VARIABLES_OF(UInt64, fmi3UInt64)
#endif
#ifndef N_STRING
NO_VARIABLES_OF(String, fmi3String)
#endif
#undef NO_VARIABLES_OF

#ifdef N_UINT64
FMI3_EXPORT fmi3Status fmi3GetUInt64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                     fmi3UInt64 values[], size_t nValues) {
    INSTANCE("fmi3GetUInt64");
    if (!scalar_count(m, "fmi3GetUInt64", "UInt64", vr, nvr, nValues, VR3_UINT64, N_UINT64)) return fmi3Error;
    for (size_t k = 0; k < nvr; k++) values[k] = m->u64[vr[k] - VR3_UINT64];
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3SetUInt64(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                     const fmi3UInt64 values[], size_t nValues) {
    INSTANCE("fmi3SetUInt64");
    if (!scalar_count(m, "fmi3SetUInt64", "UInt64", vr, nvr, nValues, VR3_UINT64, N_UINT64)) return fmi3Error;
    for (size_t k = 0; k < nvr; k++) {
        if (!discrete_settable(m, "fmi3SetUInt64", vr[k])) return fmi3Error;
        m->u64[vr[k] - VR3_UINT64] = values[k];
    }
    return fmi3OK;
}
#endif

#ifdef N_STRING
/* The pointers stay valid until the next call on this instance (FMI 3.0 section 2.2.6.2). */
FMI3_EXPORT fmi3Status fmi3GetString(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                     fmi3String values[], size_t nValues) {
    INSTANCE("fmi3GetString");
    if (!scalar_count(m, "fmi3GetString", "String", vr, nvr, nValues, VR3_STRING, N_STRING)) return fmi3Error;
    if (nvr > 0 && m->mode != MODE_INSTANTIATED) {
        fmi2Status s = model_derivatives(m);
        if (s > fmi2Warning) return status3(s);
    }
    for (size_t k = 0; k < nvr; k++) values[k] = m->s[vr[k] - VR3_STRING];
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3SetString(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                     const fmi3String values[], size_t nValues) {
    INSTANCE("fmi3SetString");
    if (!scalar_count(m, "fmi3SetString", "String", vr, nvr, nValues, VR3_STRING, N_STRING)) return fmi3Error;
    for (size_t k = 0; k < nvr; k++) {
        if (!discrete_settable(m, "fmi3SetString", vr[k])) return fmi3Error;
        const char *v = values[k] ? values[k] : "";
        size_t n = strlen(v);
        if (n >= STRING_CAP)
            return FAIL(m, "fmi3SetString: value reference %u: %zu bytes, at most %d", vr[k], n, STRING_CAP - 1);
        memcpy(m->s[vr[k] - VR3_STRING], v, n + 1);
    }
    return fmi3OK;
}
#endif

#ifdef N_BINARY
FMI3_EXPORT fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                     size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    INSTANCE("fmi3GetBinary");
    if (!scalar_count(m, "fmi3GetBinary", "Binary", vr, nvr, nValues, VR3_BINARY, N_BINARY)) return fmi3Error;
    if (nvr > 0 && m->mode != MODE_INSTANTIATED) {
        fmi2Status s = model_derivatives(m);
        if (s > fmi2Warning) return status3(s);
    }
    for (size_t k = 0; k < nvr; k++) {
        values[k] = m->bin[vr[k] - VR3_BINARY];
        valueSizes[k] = m->binSize[vr[k] - VR3_BINARY];
    }
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                     const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    INSTANCE("fmi3SetBinary");
    if (!scalar_count(m, "fmi3SetBinary", "Binary", vr, nvr, nValues, VR3_BINARY, N_BINARY)) return fmi3Error;
    for (size_t k = 0; k < nvr; k++) {
        if (!discrete_settable(m, "fmi3SetBinary", vr[k])) return fmi3Error;
        if (valueSizes[k] > BINARY_CAP)
            return FAIL(m, "fmi3SetBinary: value reference %u: %zu bytes, at most %d", vr[k], valueSizes[k],
                        BINARY_CAP);
        if (valueSizes[k] > 0 && !values[k])
            return FAIL(m, "fmi3SetBinary: value reference %u: %zu bytes at NULL", vr[k], valueSizes[k]);
        if (valueSizes[k] > 0) memcpy(m->bin[vr[k] - VR3_BINARY], values[k], valueSizes[k]);
        m->binSize[vr[k] - VR3_BINARY] = valueSizes[k];
    }
    return fmi3OK;
}
#else
FMI3_EXPORT fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                     size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    (void)valueSizes; (void)values; (void)nValues;
    return no_variables(instance, "fmi3GetBinary", "Binary", vr, nvr);
}

FMI3_EXPORT fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                     const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    (void)valueSizes; (void)values; (void)nValues;
    return no_variables(instance, "fmi3SetBinary", "Binary", vr, nvr);
}
#endif

FMI3_EXPORT fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                    fmi3Clock values[]) {
    (void)values;
    return no_variables(instance, "fmi3GetClock", "Clock", vr, nvr);
}

FMI3_EXPORT fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Clock values[]) {
    (void)values;
    return no_variables(instance, "fmi3SetClock", "Clock", vr, nvr);
}

/* ---- capabilities the descriptions do not declare --------------------------- */

FMI3_EXPORT fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                                           size_t *nDependencies) {
    (void)valueReference; (void)nDependencies;
    return not_provided(instance, "fmi3GetNumberOfVariableDependencies", "providesPerElementDependencies=\"false\"");
}

FMI3_EXPORT fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                                   size_t elementIndicesOfDependent[],
                                                   fmi3ValueReference independents[],
                                                   size_t elementIndicesOfIndependents[],
                                                   fmi3DependencyKind dependencyKinds[], size_t nDependencies) {
    (void)dependent; (void)elementIndicesOfDependent; (void)independents; (void)elementIndicesOfIndependents;
    (void)dependencyKinds; (void)nDependencies;
    return not_provided(instance, "fmi3GetVariableDependencies", "providesPerElementDependencies=\"false\"");
}

FMI3_EXPORT fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    (void)FMUState;
    return not_provided(instance, "fmi3GetFMUState", "canGetAndSetFMUState=\"false\"");
}

FMI3_EXPORT fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    (void)FMUState;
    return not_provided(instance, "fmi3SetFMUState", "canGetAndSetFMUState=\"false\"");
}

FMI3_EXPORT fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    (void)FMUState;
    return not_provided(instance, "fmi3FreeFMUState", "canGetAndSetFMUState=\"false\"");
}

FMI3_EXPORT fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    (void)FMUState; (void)size;
    return not_provided(instance, "fmi3SerializedFMUStateSize", "canSerializeFMUState=\"false\"");
}

FMI3_EXPORT fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                             size_t size) {
    (void)FMUState; (void)serializedState; (void)size;
    return not_provided(instance, "fmi3SerializeFMUState", "canSerializeFMUState=\"false\"");
}

FMI3_EXPORT fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                               fmi3FMUState *FMUState) {
    (void)serializedState; (void)size; (void)FMUState;
    return not_provided(instance, "fmi3DeserializeFMUState", "canSerializeFMUState=\"false\"");
}

FMI3_EXPORT fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                                    size_t nUnknowns, const fmi3ValueReference knowns[],
                                                    size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                                    fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    return not_provided(instance, "fmi3GetDirectionalDerivative", "providesDirectionalDerivatives=\"false\"");
}

FMI3_EXPORT fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                                size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns,
                                                const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[],
                                                size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    return not_provided(instance, "fmi3GetAdjointDerivative", "providesAdjointDerivatives=\"false\"");
}

/* Structural parameters (UInt64 variables of some models) are set in the Instantiated state;
 * Configuration Mode, which would change them again, is not offered. */
FMI3_EXPORT fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3EnterConfigurationMode",
                        "structural parameters, if any, are set before fmi3EnterInitializationMode");
}

FMI3_EXPORT fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3ExitConfigurationMode",
                        "structural parameters, if any, are set before fmi3EnterInitializationMode");
}

FMI3_EXPORT fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                              fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]) {
    (void)intervals; (void)qualifiers;
    return no_variables(instance, "fmi3GetIntervalDecimal", "Clock", vr, nvr);
}

FMI3_EXPORT fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                               fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                               fmi3IntervalQualifier qualifiers[]) {
    (void)counters; (void)resolutions; (void)qualifiers;
    return no_variables(instance, "fmi3GetIntervalFraction", "Clock", vr, nvr);
}

FMI3_EXPORT fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                           fmi3Float64 shifts[]) {
    (void)shifts;
    return no_variables(instance, "fmi3GetShiftDecimal", "Clock", vr, nvr);
}

FMI3_EXPORT fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                            fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    (void)counters; (void)resolutions;
    return no_variables(instance, "fmi3GetShiftFraction", "Clock", vr, nvr);
}

FMI3_EXPORT fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                              const fmi3Float64 intervals[]) {
    (void)intervals;
    return no_variables(instance, "fmi3SetIntervalDecimal", "Clock", vr, nvr);
}

FMI3_EXPORT fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                               const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)counters; (void)resolutions;
    return no_variables(instance, "fmi3SetIntervalFraction", "Clock", vr, nvr);
}

FMI3_EXPORT fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                           const fmi3Float64 shifts[]) {
    (void)shifts;
    return no_variables(instance, "fmi3SetShiftDecimal", "Clock", vr, nvr);
}

FMI3_EXPORT fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                            const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]) {
    (void)counters; (void)resolutions;
    return no_variables(instance, "fmi3SetShiftFraction", "Clock", vr, nvr);
}

FMI3_EXPORT fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    return not_provided(instance, "fmi3EvaluateDiscreteStates", "providesEvaluateDiscreteStates=\"false\"");
}

FMI3_EXPORT fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference vr[], size_t nvr,
                                                const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues) {
    (void)vr; (void)nvr; (void)orders; (void)values; (void)nValues;
    return not_provided(instance, "fmi3GetOutputDerivatives", "maxOutputDerivativeOrder=\"0\"");
}

FMI3_EXPORT fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    return not_provided(instance, "fmi3EnterStepMode",
                        "Co-Simulation has no Event Mode here (hasEventMode=\"false\"); fmi3ExitInitializationMode "
                        "enters Step Mode");
}

FMI3_EXPORT fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                                  fmi3Float64 activationTime) {
    (void)clockReference; (void)activationTime;
    return not_provided(instance, "fmi3ActivateModelPartition", "no Scheduled Execution");
}

/* ---- Model Exchange ------------------------------------------------------- */

FMI3_EXPORT fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                                fmi3Boolean *terminateSimulation,
                                                fmi3Boolean *nominalsOfContinuousStatesChanged,
                                                fmi3Boolean *valuesOfContinuousStatesChanged,
                                                fmi3Boolean *nextEventTimeDefined, fmi3Float64 *nextEventTime) {
    ME_INSTANCE("fmi3UpdateDiscreteStates");
    if (m->mode != MODE_EVENT) return FAIL(m, "fmi3UpdateDiscreteStates: the instance is not in Event Mode");
    m->valuesChanged = 0;
    fmi2Status s = model_derivatives(m);
    if (s > fmi2Warning) return status3(s);
    model_event_update(m);
    if (discreteStatesNeedUpdate) *discreteStatesNeedUpdate = fmi3False;
    if (terminateSimulation) *terminateSimulation = m->terminateSimulation != 0;
    if (nominalsOfContinuousStatesChanged) *nominalsOfContinuousStatesChanged = fmi3False;
    if (valuesOfContinuousStatesChanged) *valuesOfContinuousStatesChanged = m->valuesChanged != 0;
    if (nextEventTimeDefined) *nextEventTimeDefined = m->nextEventTimeDefined != 0;
    if (nextEventTime) *nextEventTime = m->nextEventTime;
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    ME_INSTANCE("fmi3EnterContinuousTimeMode");
    m->mode = MODE_CONTINUOUS;
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance,
                                                   fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                                   fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint;
    ME_INSTANCE("fmi3CompletedIntegratorStep");
    if (enterEventMode) *enterEventMode = fmi3False;
    if (terminateSimulation) *terminateSimulation = m->terminateSimulation != 0;
#ifdef COMPLETED_STEPS_VR
    m->i[COMPLETED_STEPS_VR]++;
#endif
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    ME_INSTANCE("fmi3SetTime");
    m->time = time;
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 x[], size_t nx) {
    ME_INSTANCE("fmi3SetContinuousStates");
    if (nx != NX) return FAIL(m, "fmi3SetContinuousStates: %zu states given, the model has %d", nx, NX);
    for (size_t k = 0; k < nx; k++) STATE(k) = x[k];
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 x[], size_t nx) {
    ME_INSTANCE("fmi3GetContinuousStates");
    if (nx != NX) return FAIL(m, "fmi3GetContinuousStates: %zu states asked for, the model has %d", nx, NX);
    for (size_t k = 0; k < nx; k++) x[k] = STATE(k);
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 dx[], size_t nx) {
    ME_INSTANCE("fmi3GetContinuousStateDerivatives");
    if (nx != NX)
        return FAIL(m, "fmi3GetContinuousStateDerivatives: %zu derivatives asked for, the model has %d", nx, NX);
    fmi2Status s = model_derivatives(m);
    if (s > fmi2Warning) return status3(s);
    for (size_t k = 0; k < nx; k++) dx[k] = DERIV(k);
    return status3(s);
}

FMI3_EXPORT fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 z[], size_t nz) {
    ME_INSTANCE("fmi3GetEventIndicators");
    if (nz != NZ) return FAIL(m, "fmi3GetEventIndicators: %zu indicators asked for, the model has %d", nz, NZ);
    if (nz > 0) {
        fmi2Status s = model_derivatives(m);
        if (s > fmi2Warning) return status3(s);
        model_event_indicators(m, z);
    }
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nx) {
    ME_INSTANCE("fmi3GetNominalsOfContinuousStates");
    if (nx != NX)
        return FAIL(m, "fmi3GetNominalsOfContinuousStates: %zu nominals asked for, the model has %d", nx, NX);
    for (size_t k = 0; k < nx; k++) nominals[k] = model_nominal((int)k);
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    INSTANCE("fmi3GetNumberOfEventIndicators");
    if (!nEventIndicators) return FAIL(m, "fmi3GetNumberOfEventIndicators: nEventIndicators is NULL");
    *nEventIndicators = NZ;
    return fmi3OK;
}

FMI3_EXPORT fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    INSTANCE("fmi3GetNumberOfContinuousStates");
    if (!nContinuousStates) return FAIL(m, "fmi3GetNumberOfContinuousStates: nContinuousStates is NULL");
    *nContinuousStates = NX;
    return fmi3OK;
}

/* ---- Co-Simulation (the integrator is fmu_cosim.c) ------------------------- */

/* Integrates from currentCommunicationPoint over the step, events handled inside. A model that
 * requests termination ends the step there: fmi3OK with terminateSimulation = true and
 * lastSuccessfulTime = the time it stopped at (the importer then calls fmi3Terminate); the
 * step is reported as returning early only if the importer allowed early return. */
FMI3_EXPORT fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                                  fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                  fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                                  fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    (void)noSetFMUStatePriorToCurrentPoint;
    CS_INSTANCE("fmi3DoStep");
    double t = currentCommunicationPoint, h = communicationStepSize;
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    if (lastSuccessfulTime) *lastSuccessfulTime = m->time;
    if (m->csTerminated) return FAIL(m, "fmi3DoStep after the model terminated at t=%g", m->time);
    if (m->mode != MODE_STEP_COMPLETE) return FAIL(m, "fmi3DoStep: the instance is not in Step Mode");
    if (!(h >= 0)) return FAIL(m, "fmi3DoStep: communicationStepSize %g is negative", h);
    if (fabs(t - m->time) > 1e-9 * fmax(1.0, fabs(t)))
        return FAIL(m, "fmi3DoStep: communication point %.17g but model time is %.17g", t, m->time);
    m->time = t;
    fmi2Status s = cs_integrate(m, t + h);
    if (lastSuccessfulTime) *lastSuccessfulTime = m->time;
    if (s == fmi2Discard) { /* the model requested termination */
        m->csTerminated = 1;
        m->lastSuccessfulTime = m->time;
        if (terminateSimulation) *terminateSimulation = fmi3True;
        if (earlyReturn) *earlyReturn = m->earlyReturnAllowed && m->time < t + h;
        return fmi3OK;
    }
    if (s > fmi2Warning) {
        m->mode = MODE_ERROR;
        return status3(s);
    }
    m->lastSuccessfulTime = m->time;
    return status3(s);
}
