/* A minimal non-Python FMI 3.0 co-simulation host (any FMU with Float64 variables): loads the
 * binary with dlopen, instantiates with eventModeUsed and earlyReturnAllowed false, sets the given
 * Float64 values in Initialization Mode, steps with a fixed step to the stop time, then prints each
 * requested Float64 and the independent variable's value, terminates and frees.
 * Compiled against the FMI 3.0 standard headers (fmpy ships them).
 * Usage: fmi3_host BINARY.so TOKEN RESOURCE_DIR STOP STEP [set:VR=VALUE]... [get:VR]...
 * Prints "log[status] message" per logged line, "step status S at t" for a refused step,
 * "get VR VALUE" per requested value, "time T", "status S", "freed"; exits with the worst status.
 * Cross-built for Windows with mingw-w64 (-municode): the arguments are read as UTF-16 (wmain) and
 * passed on as UTF-8, the binary (BINARY.dll) is loaded with LoadLibraryW, RESOURCE_DIR is a
 * native path (C:\...\resources\). Loading and wmain: host_common.h. */
#include "fmi3FunctionTypes.h"
#include "host_common.h"

static void log_message(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message)
{
    (void)env; (void)category;
    printf("log[%d] %s\n", (int)status, message);
}

#define SYM(type, name)                                                                            \
    type *name;                                                                                    \
    HOST_SYM(name, h, #name);

static int run(int argc, char **argv)
{
    if (argc < 6) { printf("usage: fmi3_host BINARY.so TOKEN RESOURCE_DIR STOP STEP [set:VR=VALUE]... [get:VR]...\n"); return 1; }
    host_library h = load_binary(argv[1]);
    if (!h) return 2;
    SYM(fmi3InstantiateCoSimulationTYPE, fmi3InstantiateCoSimulation)
    SYM(fmi3EnterInitializationModeTYPE, fmi3EnterInitializationMode)
    SYM(fmi3ExitInitializationModeTYPE, fmi3ExitInitializationMode)
    SYM(fmi3DoStepTYPE, fmi3DoStep)
    SYM(fmi3GetFloat64TYPE, fmi3GetFloat64)
    SYM(fmi3SetFloat64TYPE, fmi3SetFloat64)
    SYM(fmi3TerminateTYPE, fmi3Terminate)
    SYM(fmi3FreeInstanceTYPE, fmi3FreeInstance)
    double stop = atof(argv[4]), step = atof(argv[5]);
    fmi3ValueReference set_vr[64], get_vr[64];
    double set_v[64], got[64];
    size_t n_set = 0, n_get = 0;
    for (int i = 6; i < argc; i++) {
        if (!strncmp(argv[i], "set:", 4) && n_set < 64 && strchr(argv[i], '=')) {
            set_vr[n_set] = (fmi3ValueReference)strtoul(argv[i] + 4, NULL, 10);
            set_v[n_set++] = atof(strchr(argv[i], '=') + 1);
        } else if (!strncmp(argv[i], "get:", 4) && n_get < 64) {
            get_vr[n_get++] = (fmi3ValueReference)strtoul(argv[i] + 4, NULL, 10);
        } else {
            printf("bad argument %s\n", argv[i]);
            return 1;
        }
    }
    fmi3Instance c = fmi3InstantiateCoSimulation("c_host", argv[2], argv[3], fmi3False, fmi3True, fmi3False, fmi3False,
                                                 NULL, 0, NULL, log_message, NULL);
    if (!c) { printf("instantiate failed\n"); return 4; }
    fmi3Status worst = fmi3OK, s;
#define CALL(x) do { s = (x); if (s > worst) worst = s; } while (0)
    CALL(fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3True, stop));
    if (n_set) CALL(fmi3SetFloat64(c, set_vr, n_set, set_v, n_set));
    CALL(fmi3ExitInitializationMode(c));
    long n_steps = (long)(stop / step + 0.5);
    double t = 0.0;
    for (long k = 0; k < n_steps && worst <= fmi3Warning; k++) {
        fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
        double last = 0.0;
        CALL(fmi3DoStep(c, k * step, step, fmi3True, &event, &terminate, &early, &last));
        if (s > fmi3Warning) printf("step status %d at %.9g: lastSuccessfulTime %.9g terminateSimulation %d\n",
                                    (int)s, k * step, last, (int)terminate);
        t = last;
    }
    if (n_get) CALL(fmi3GetFloat64(c, get_vr, n_get, got, n_get));
    for (size_t i = 0; i < n_get; i++) printf("get %u %.17g\n", get_vr[i], got[i]);
    printf("time %.17g\n", t);
    printf("status %d\n", (int)worst);
    fmi3Terminate(c);
    fmi3FreeInstance(c);
    printf("freed\n");
    fflush(stdout);
    return (int)worst;
}
