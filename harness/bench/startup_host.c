/* The start-up bench's C host (harness/bench/startup.py): one FMI 2.0 co-simulation run of an
 * extracted FMU, as a host that loads a system once would: dlopen the binary, fmi2Instantiate,
 * fmi2SetupExperiment, Initialization Mode, one fmi2DoStep of STEP seconds, fmi2Terminate,
 * fmi2FreeInstance. Exit 0 when every call answered fmi2OK (or fmi2Warning), else the failing
 * call's number. Usage: startup_host BINARY IDENTIFIER GUID RESOURCE_URI STEP */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef void *Comp;
typedef struct {
    void (*logger)(void *, const char *, int, const char *, const char *, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void *stepFinished;
    void *componentEnvironment;
} Callbacks;

static void logger(void *env, const char *name, int status, const char *cat, const char *msg, ...)
{
    (void)env; (void)name; (void)cat;
    if (status < 2) return;      /* errors only: the bench times the run, not the messages */
    va_list ap;
    va_start(ap, msg);
    vfprintf(stderr, msg, ap);
    fputc('\n', stderr);
    va_end(ap);
}

static void *sym(void *lib, const char *id, const char *fn)   /* the function, or exit 10 */
{
    char name[256];
    snprintf(name, sizeof name, "%s", fn);
    void *f = dlsym(lib, name);
    (void)id;
    if (!f) { fprintf(stderr, "no %s\n", fn); exit(10); }
    return f;
}

int main(int argc, char **argv)
{
    if (argc != 6) { fprintf(stderr, "usage: startup_host BINARY IDENTIFIER GUID RESOURCE_URI STEP\n"); return 2; }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 3; }
    Comp (*inst)(const char *, int, const char *, const char *, const Callbacks *, int, int) =
        (Comp (*)(const char *, int, const char *, const char *, const Callbacks *, int, int))sym(lib, argv[2], "fmi2Instantiate");
    int (*setup)(Comp, int, double, double, int, double) = (int (*)(Comp, int, double, double, int, double))sym(lib, argv[2], "fmi2SetupExperiment");
    int (*enter)(Comp) = (int (*)(Comp))sym(lib, argv[2], "fmi2EnterInitializationMode");
    int (*leave)(Comp) = (int (*)(Comp))sym(lib, argv[2], "fmi2ExitInitializationMode");
    int (*step)(Comp, double, double, int) = (int (*)(Comp, double, double, int))sym(lib, argv[2], "fmi2DoStep");
    int (*term)(Comp) = (int (*)(Comp))sym(lib, argv[2], "fmi2Terminate");
    void (*freei)(Comp) = (void (*)(Comp))sym(lib, argv[2], "fmi2FreeInstance");
    Callbacks cb = {logger, calloc, free, NULL, NULL};
    Comp c = inst("bench", 1, argv[3], argv[4], &cb, 0, 0);
    if (!c) return 4;
    double h = atof(argv[5]);
    if (setup(c, 0, 0.0, 0.0, 0, 0.0) > 1) return 5;
    if (enter(c) > 1) return 6;
    if (leave(c) > 1) return 7;
    if (step(c, 0.0, h, 1) > 1) return 8;
    if (term(c) > 1) return 9;
    freei(c);
    return 0;
}
