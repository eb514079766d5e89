/* The start-up bench's C host (harness/measure/bench/startup.py): one FMI 2.0 co-simulation run of an
 * extracted FMU, as a host that loads a system once would: dlopen the binary, fmi2Instantiate,
 * fmi2SetupExperiment, Initialization Mode, one fmi2DoStep of STEP seconds, fmi2Terminate,
 * fmi2FreeInstance. Exit 0 when every call answered fmi2OK (or fmi2Warning), else the failing
 * call's number. Compiled against the FMI 2.0 headers fmpy ships (harness.build.fmu._fmi2_headers).
 * Usage: startup_host BINARY GUID RESOURCE_URI STEP */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

#include "fmi2FunctionTypes.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String cat,
                   fmi2String msg, ...)
{
    (void)env; (void)name; (void)cat;
    if (status < fmi2Discard) return;      /* errors only: the bench times the run, not the messages */
    va_list ap;
    va_start(ap, msg);
    vfprintf(stderr, msg, ap);
    fputc('\n', stderr);
    va_end(ap);
}

static void *sym(void *lib, const char *fn)   /* the function, or exit 10 */
{
    void *f = dlsym(lib, fn);
    if (!f) { fprintf(stderr, "no %s\n", fn); exit(10); }
    return f;
}

int main(int argc, char **argv)
{
    if (argc != 5) { fprintf(stderr, "usage: startup_host BINARY GUID RESOURCE_URI STEP\n"); return 2; }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 3; }
    fmi2InstantiateTYPE *inst = (fmi2InstantiateTYPE *)sym(lib, "fmi2Instantiate");
    fmi2SetupExperimentTYPE *setup = (fmi2SetupExperimentTYPE *)sym(lib, "fmi2SetupExperiment");
    fmi2EnterInitializationModeTYPE *enter = (fmi2EnterInitializationModeTYPE *)sym(lib, "fmi2EnterInitializationMode");
    fmi2ExitInitializationModeTYPE *leave = (fmi2ExitInitializationModeTYPE *)sym(lib, "fmi2ExitInitializationMode");
    fmi2DoStepTYPE *step = (fmi2DoStepTYPE *)sym(lib, "fmi2DoStep");
    fmi2TerminateTYPE *term = (fmi2TerminateTYPE *)sym(lib, "fmi2Terminate");
    fmi2FreeInstanceTYPE *freei = (fmi2FreeInstanceTYPE *)sym(lib, "fmi2FreeInstance");
    const fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = inst("bench", fmi2CoSimulation, argv[2], argv[3], &cb, fmi2False, fmi2False);
    if (!c) return 4;
    if (setup(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) > fmi2Warning) return 5;
    if (enter(c) > fmi2Warning) return 6;
    if (leave(c) > fmi2Warning) return 7;
    if (step(c, 0.0, atof(argv[4]), fmi2True) > fmi2Warning) return 8;
    if (term(c) > fmi2Warning) return 9;
    freei(c);
    return 0;
}
