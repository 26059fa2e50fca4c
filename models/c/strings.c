/* String and Binary variables beside a numeric state, after the Modelica Reference FMUs'
 * Feedthrough (its String_parameter with <Start value="Set me!"/>, its Binary_input with
 * <Start value="666f6f"/> and its Binary_output): a decay x' = -x, x(0) = 1, whose output
 * y = len(String_parameter) x makes the String parameter observable; Binary_output echoes
 * Binary_input and the Float64 output Binary_length counts its bytes (FMI 3.0 build only, as
 * FMI 2.0 has no Binary type); String_output echoes String_parameter. With the starts
 * ("Set me!", 7 bytes; 66 6f 6f, 3 bytes): y = 7 e^(-t), Binary_length = 3.
 * Descriptions: xml/Strings.xml (FMI 2.0) and xml/fmi3/Strings.xml (FMI 3.0). */
#define MODEL_IDENTIFIER "Strings"
#define FMI1_PREFIX Strings /* FMI 1.0 builds: the exported names' prefix */
#define MODEL_GUID "{6a1f3c2e-3b44-4d1c-9a43-f0a1c0de000b}"
#define N_REAL 4
#define N_INTEGER 1
#define N_BOOLEAN 1
#define N_STRING 2
#ifdef FMUCAL_FMI3
#define N_BINARY 2
#endif
#define NX 1
#define NZ 0
#define CS_STEP 1e-3
#define CS_IMPLICIT 0
#include "fmu_framework.h"

enum { X, DER_X, Y, BINARY_LENGTH };
enum { STRING_PARAMETER, STRING_OUTPUT };
enum { BINARY_INPUT, BINARY_OUTPUT };
static const fmi2ValueReference STATE_VR[NX] = {X};
static const fmi2ValueReference DER_VR[NX] = {DER_X};

static void model_defaults(Model *m) {
    m->r[X] = 1.0;
    snprintf(m->s[STRING_PARAMETER], STRING_CAP, "%s", "Set me!");
#ifdef N_BINARY
    static const unsigned char foo[] = {0x66, 0x6f, 0x6f};
    memcpy(m->bin[BINARY_INPUT], foo, sizeof foo);
    m->binSize[BINARY_INPUT] = sizeof foo;
#endif
}

static fmi2Status model_instantiated(Model *m) { (void)m; return fmi2OK; }
static fmi2Status model_initialize(Model *m) { (void)m; return fmi2OK; }
static double model_nominal(int k) { (void)k; return 1.0; }
static void model_event_indicators(Model *m, double *z) { (void)m; (void)z; }
static void model_event_update(Model *m) { (void)m; }

static fmi2Status model_derivatives(Model *m) {
    m->r[DER_X] = -m->r[X];
    m->r[Y] = (double)strlen(m->s[STRING_PARAMETER]) * m->r[X];
    memcpy(m->s[STRING_OUTPUT], m->s[STRING_PARAMETER], STRING_CAP);
#ifdef N_BINARY
    memcpy(m->bin[BINARY_OUTPUT], m->bin[BINARY_INPUT], m->binSize[BINARY_INPUT]);
    m->binSize[BINARY_OUTPUT] = m->binSize[BINARY_INPUT];
    m->r[BINARY_LENGTH] = (double)m->binSize[BINARY_INPUT];
#endif
    return fmi2OK;
}

#include "fmu_framework.c"
