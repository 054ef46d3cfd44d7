#define _GNU_SOURCE
#include <dlfcn.h>
#include <string.h>
#include <stddef.h>
/* dlopen that refuses every GL library: what a machine without one sees. */
static int gl(const char *f) {
    return f && (strstr(f, "libGL") || strstr(f, "libEGL") || strstr(f, "libOpenGL")
                 || strstr(f, "libgbm") || strstr(f, "GLES"));
}
void *dlopen(const char *f, int flags) {
    static void *(*real)(const char *, int);
    if (!real) real = dlsym(RTLD_NEXT, "dlopen");
    if (gl(f)) return NULL;
    return real(f, flags);
}
void *dlmopen(Lmid_t lm, const char *f, int flags) {
    static void *(*real)(Lmid_t, const char *, int);
    if (!real) real = dlsym(RTLD_NEXT, "dlmopen");
    if (gl(f)) return NULL;
    return real(lm, f, flags);
}
