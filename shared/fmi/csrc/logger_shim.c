/* fmucal's FMI 1.0 and 2.0 logger shim. The FMI logger callback is variadic, which stable Rust
 * cannot define; these C functions format the message with vsnprintf and forward the finished
 * text to a Rust sink registered once at start-up. It also provides calloc/free as the memory callbacks. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

typedef void (*fmucal_log_sink)(void *env, const char *instance, int status, const char *category,
                                const char *message);

static fmucal_log_sink g_sink = 0;

void fmucal_set_log_sink(fmucal_log_sink sink) { g_sink = sink; }

/* Formats the message and hands it to the sink with `env`. */
static void forward(void *env, const char *instance, int status, const char *category, const char *fmt, va_list ap) {
    char buf[8192];
    if (fmt) {
        vsnprintf(buf, sizeof buf, fmt, ap);
    } else {
        buf[0] = 0;
    }
    if (g_sink) g_sink(env, instance, status, category, buf);
}

void fmucal_logger(void *env, const char *instance, int status, const char *category, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    forward(env, instance, status, category, fmt, ap);
    va_end(ap);
}

/* FMI 1.0's logger has the same arguments, but its first is the fmiComponent, not an
 * environment pointer of fmucal's: it is not passed on (the Rust side knows the instance
 * it is calling into). */
void fmucal_logger_fmi1(void *component, const char *instance, int status, const char *category, const char *fmt,
                        ...) {
    va_list ap;
    (void)component;
    va_start(ap, fmt);
    forward(0, instance, status, category, fmt, ap);
    va_end(ap);
}

void *fmucal_calloc(size_t n, size_t size) { return calloc(n == 0 ? 1 : n, size == 0 ? 1 : size); }

void fmucal_free(void *p) { free(p); }
