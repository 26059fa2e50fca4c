/* fmucal's FMI 2.0 logger shim. The FMI logger callback is variadic, which stable Rust cannot
 * define; this C function formats the message with vsnprintf and forwards the finished text to
 * a Rust sink registered once at start-up. It also provides calloc/free as the memory callbacks. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

typedef void (*fmucal_log_sink)(void *env, const char *instance, int status, const char *category,
                                const char *message);

static fmucal_log_sink g_sink = 0;

void fmucal_set_log_sink(fmucal_log_sink sink) { g_sink = sink; }

void fmucal_logger(void *env, const char *instance, int status, const char *category, const char *fmt, ...) {
    char buf[8192];
    va_list ap;
    va_start(ap, fmt);
    if (fmt) {
        vsnprintf(buf, sizeof buf, fmt, ap);
    } else {
        buf[0] = 0;
    }
    va_end(ap);
    if (g_sink) g_sink(env, instance, status, category, buf);
}

void *fmucal_calloc(size_t n, size_t size) { return calloc(n == 0 ? 1 : n, size == 0 ? 1 : size); }

void fmucal_free(void *p) { free(p); }
