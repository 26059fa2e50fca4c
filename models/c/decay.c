/* Exponential decay x' = -k * f * x^power, x(0) = 1, where f is read from resources/decay.txt
 * at instantiation (so x = exp(-t) with the defaults). It exercises what exported FMUs carry:
 * a resource file, declared types, an alias, Integer/Boolean/Enumeration parameters, a time
 * event (kickTime adds kickAmount to x), terminateSimulation at terminateTime, a wall-time `delay`
 * (seconds slept at initialisation, for benchmarks), and a configurable failure (crashMode from crashTime:
 * 2 returns fmi2Error, 3 calls abort(), 4 dereferences a null pointer, 5 never returns). */
#define _POSIX_C_SOURCE 200809L /* nanosleep under -std=c99 */
#define MODEL_IDENTIFIER "Decay"
#define MODEL_GUID "{6a1f3c2e-3b44-4d1c-9a43-f0a1c0de0003}"
#define N_REAL 9
#define N_INTEGER 3
#define N_BOOLEAN 1
#define NX 1
#define NZ 0
#define CS_STEP 1e-3
#define CS_IMPLICIT 0
#include "fmu_framework.h"
#include <signal.h>
#include <time.h>

enum { X, DER_X, K, KICK_TIME, KICK_AMOUNT, CRASH_TIME, RESOURCE_FACTOR, TERMINATE_TIME, DELAY };
enum { POWER, CRASH_MODE, KICKED };
enum { ENABLED };
enum { CRASH_NONE = 1, CRASH_ERROR = 2, CRASH_ABORT = 3, CRASH_SEGFAULT = 4, CRASH_HANG = 5 };
static const fmi2ValueReference STATE_VR[NX] = {X};
static const fmi2ValueReference DER_VR[NX] = {DER_X};

static double g_resource_factor = 1.0;

static void model_defaults(Model *m) {
    m->r[X] = 1.0;
    m->r[K] = 1.0;
    m->r[KICK_TIME] = 1e9;
    m->r[KICK_AMOUNT] = 0.0;
    m->r[CRASH_TIME] = 0.0;
    m->r[TERMINATE_TIME] = 1e9;
    m->r[DELAY] = 0.0;
    m->r[RESOURCE_FACTOR] = g_resource_factor;
    m->i[POWER] = 1;
    m->i[CRASH_MODE] = CRASH_NONE;
    m->i[KICKED] = 0;
    m->b[ENABLED] = 1;
}

static fmi2Status model_instantiated(Model *m) {
    char path[4200];
    snprintf(path, sizeof path, "%s/decay.txt", m->resourceDir);
    FILE *f = fopen(path, "r");
    if (!f) {
        fmu_log(m, fmi2Error, "logStatusError", "cannot open resource %s", path);
        return fmi2Error;
    }
    double factor = 0;
    int ok = fscanf(f, "factor = %lf", &factor) == 1;
    fclose(f);
    if (!ok || !(factor > 0)) {
        fmu_log(m, fmi2Error, "logStatusError", "resource %s has no positive 'factor = <number>' line", path);
        return fmi2Error;
    }
    g_resource_factor = factor;
    m->r[RESOURCE_FACTOR] = factor;
    return fmi2OK;
}

/* The next pending time event: the kick (once) or termination. */
static void schedule(Model *m) {
    double next = m->r[TERMINATE_TIME];
    if (!m->i[KICKED] && m->r[KICK_TIME] < next) next = m->r[KICK_TIME];
    m->nextEventTimeDefined = next > m->time - 1e-12 && next < 1e9;
    m->nextEventTime = next;
}

static fmi2Status model_initialize(Model *m) {
    m->i[KICKED] = 0;
    schedule(m);
    if (m->r[DELAY] > 0) { /* stand-in for an expensive model: wall time without CPU */
        struct timespec ts = {(time_t)m->r[DELAY], (long)((m->r[DELAY] - (double)(time_t)m->r[DELAY]) * 1e9)};
        nanosleep(&ts, NULL);
    }
    return fmi2OK;
}

static double model_nominal(int k) { (void)k; return 1.0; }
static void model_event_indicators(Model *m, double *z) { (void)m; (void)z; }

static fmi2Status model_derivatives(Model *m) {
    if (m->i[CRASH_MODE] != CRASH_NONE && m->time >= m->r[CRASH_TIME]) {
        switch (m->i[CRASH_MODE]) {
        case CRASH_ERROR:
            fmu_log(m, fmi2Error, "logStatusError", "crashMode=error reached at t=%g", m->time);
            return fmi2Error;
        case CRASH_ABORT:
            abort();
        case CRASH_SEGFAULT:
            raise(SIGSEGV);
            return fmi2Fatal;
        case CRASH_HANG: /* a model stuck in a loop that never ends (sleeping, so it costs no CPU) */
            for (;;) {
                struct timespec ts = {1, 0};
                nanosleep(&ts, NULL);
            }
        default:
            break;
        }
    }
    double x = m->r[X];
    double xp = x;
    for (int p = 1; p < m->i[POWER]; p++) xp *= x;
    m->r[DER_X] = m->b[ENABLED] ? -m->r[K] * m->r[RESOURCE_FACTOR] * xp : 0.0;
    return fmi2OK;
}

static void model_event_update(Model *m) {
    if (!m->i[KICKED] && m->time >= m->r[KICK_TIME] - 1e-12) {
        m->i[KICKED] = 1;
        m->r[X] += m->r[KICK_AMOUNT];
        m->valuesChanged = 1;
    }
    if (m->time >= m->r[TERMINATE_TIME] - 1e-12) {
        m->terminateSimulation = 1;
        m->nextEventTimeDefined = 0;
        return;
    }
    schedule(m);
}

#include "fmu_framework.c"
