/* A minimal non-Python FMI 2.0 co-simulation host: loads an FMU binary with dlopen, runs
 * SpurDifferential's straight-line case for 10 steps and prints the carrier torque.
 * Usage: fmi2_host BINARY.so GUID RESOURCE_URI VR_W_REF VR_LEFT_TAU VR_RIGHT_TAU VR_TAU_DRIVE */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

typedef void *fmi2Component;
typedef struct {
    void (*logger)(void *, const char *, int, const char *, const char *, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void *stepFinished;
    void *componentEnvironment;
} fmi2CallbackFunctions;

static void logger(void *env, const char *name, int status, const char *cat, const char *msg, ...) {
    va_list ap;
    va_start(ap, msg);
    printf("log[%d]: ", status);
    vprintf(msg, ap);
    printf("\n");
    va_end(ap);
}

typedef fmi2Component (*instantiate_t)(const char *, int, const char *, const char *, const fmi2CallbackFunctions *, int, int);
typedef int (*setup_t)(fmi2Component, int, double, double, int, double);
typedef int (*call_t)(fmi2Component);
typedef int (*step_t)(fmi2Component, double, double, int);
typedef int (*getreal_t)(fmi2Component, const unsigned *, size_t, double *);
typedef int (*setreal_t)(fmi2Component, const unsigned *, size_t, const double *);
typedef void (*free_t)(fmi2Component);

#define SYM(type, name) type name = (type)dlsym(h, #name); if (!name) { printf("missing %s\n", #name); return 3; }

int main(int argc, char **argv) {
    if (argc != 8) { printf("usage\n"); return 1; }
    void *h = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!h) { printf("dlopen failed: %s\n", dlerror()); return 2; }
    SYM(instantiate_t, fmi2Instantiate)
    SYM(setup_t, fmi2SetupExperiment)
    SYM(call_t, fmi2EnterInitializationMode)
    SYM(call_t, fmi2ExitInitializationMode)
    SYM(step_t, fmi2DoStep)
    SYM(getreal_t, fmi2GetReal)
    SYM(setreal_t, fmi2SetReal)
    SYM(call_t, fmi2Terminate)
    SYM(free_t, fmi2FreeInstance)
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate("c_host", 1, argv[2], argv[3], &cb, 0, 1);
    if (!c) { printf("instantiate failed\n"); return 4; }
    unsigned in[3] = {atoi(argv[4]), atoi(argv[5]), atoi(argv[6])};
    double u[3] = {1.389, -1050.0, -1050.0};
    unsigned out = atoi(argv[7]);
    double y = 0.0;
    int s = fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
    s |= fmi2EnterInitializationMode(c);
    s |= fmi2SetReal(c, in, 3, u);
    s |= fmi2ExitInitializationMode(c);
    for (int k = 0; k < 10 && s == 0; k++) s |= fmi2DoStep(c, k * 1e-3, 1e-3, 1);
    s |= fmi2GetReal(c, &out, 1, &y);
    printf("status %d tauDrive %.6f\n", s, y);
    fmi2Terminate(c);
    fmi2FreeInstance(c);
    printf("freed\n");
    fflush(stdout);
    return s;
}
