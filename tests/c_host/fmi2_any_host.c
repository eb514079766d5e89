/* A small FMI 2.0 co-simulation host in C for any of our FMUs, built for Linux (gcc, -ldl) and for
 * 64-bit Windows (mingw-w64, run under wine in tests/harness/test_win64.py).
 *
 *   fmi2_any_host BINARY GUID RESOURCE_URI STEPS STEP RUNS [VR=VALUE ...] get VR[,VR...]
 *       RUNS times in this process: instantiate, set the start values (Initialization Mode),
 *       STEPS steps of STEP seconds, print the outputs VR... (%.17g), free. Exit 0 when every call
 *       returned fmi2OK.
 *   fmi2_any_host BINARY GUID RESOURCE_URI STEPS STEP contract IN_VR PARAM_VR BAD_VALUE OUT_VR
 *       The FMI-contract and hostile-input checks a C host can drive, one line "ok NAME" or
 *       "FAIL NAME: why" each; exit 0 when all passed.
 * Compiled against the FMI 2.0 standard headers (fmpy ships them). On Windows the arguments are read
 * as UTF-16 (wmain) and passed on as UTF-8, so folders with non-ASCII characters reach the FMU intact;
 * the binary is loaded with LoadLibraryW (both in host_common.h).
 */
#include <math.h>
#include <stdarg.h>

#define HOST_BUFFERED_STDOUT
#include "fmi2FunctionTypes.h"
#include "host_common.h"

static char last_log[8192];
static int quiet;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String cat, fmi2String msg, ...)
{
    va_list ap;
    va_start(ap, msg);
    vsnprintf(last_log, sizeof last_log, msg, ap);
    va_end(ap);
    (void)env; (void)cat;
    if (!quiet) printf("log[%d] %s: %s\n", (int)status, name ? name : "", last_log);
}

static struct {
    fmi2InstantiateTYPE *Instantiate;
    fmi2SetupExperimentTYPE *SetupExperiment;
    fmi2EnterInitializationModeTYPE *EnterInit;
    fmi2ExitInitializationModeTYPE *ExitInit;
    fmi2TerminateTYPE *Terminate;
    fmi2ResetTYPE *Reset;
    fmi2DoStepTYPE *DoStep;
    fmi2GetRealTYPE *GetReal;
    fmi2SetRealTYPE *SetReal;
    fmi2FreeInstanceTYPE *FreeInstance;
    fmi2GetFMUstateTYPE *GetState;
    fmi2SetFMUstateTYPE *SetState;
    fmi2FreeFMUstateTYPE *FreeState;
    fmi2SerializedFMUstateSizeTYPE *SerSize;
    fmi2SerializeFMUstateTYPE *Serialize;
    fmi2DeSerializeFMUstateTYPE *Deserialize;
} F;

static const char *FMU_GUID, *URI;
static fmi2CallbackFunctions CB = {logger, calloc, free, NULL, NULL};

static int load(const char *binary)
{
    host_library h = load_binary(binary);
    if (!h) return 2;
    HOST_SYM(F.Instantiate, h, "fmi2Instantiate");
    HOST_SYM(F.SetupExperiment, h, "fmi2SetupExperiment");
    HOST_SYM(F.EnterInit, h, "fmi2EnterInitializationMode");
    HOST_SYM(F.ExitInit, h, "fmi2ExitInitializationMode");
    HOST_SYM(F.Terminate, h, "fmi2Terminate");
    HOST_SYM(F.Reset, h, "fmi2Reset");
    HOST_SYM(F.DoStep, h, "fmi2DoStep");
    HOST_SYM(F.GetReal, h, "fmi2GetReal");
    HOST_SYM(F.SetReal, h, "fmi2SetReal");
    HOST_SYM(F.FreeInstance, h, "fmi2FreeInstance");
    HOST_SYM(F.GetState, h, "fmi2GetFMUstate");
    HOST_SYM(F.SetState, h, "fmi2SetFMUstate");
    HOST_SYM(F.FreeState, h, "fmi2FreeFMUstate");
    HOST_SYM(F.SerSize, h, "fmi2SerializedFMUstateSize");
    HOST_SYM(F.Serialize, h, "fmi2SerializeFMUstate");
    HOST_SYM(F.Deserialize, h, "fmi2DeSerializeFMUstate");
    return 0;
}

/* ------------------------------------------------------------------------------ simulate */
static int simulate(int steps, double h, int nset, unsigned *svr, double *sval, int nget, unsigned *gvr, int run)
{
    fmi2Component c = F.Instantiate("any_host", 1, FMU_GUID, URI, &CB, 0, 0);
    if (!c) { printf("run %d: instantiate failed\n", run); return 4; }
    int s = F.SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
    s |= F.EnterInit(c);
    if (nset) s |= F.SetReal(c, svr, (size_t)nset, sval);
    s |= F.ExitInit(c);
    for (int k = 0; k < steps && s == 0; k++) s |= F.DoStep(c, k * h, h, 1);
    double y[64];
    s |= F.GetReal(c, gvr, (size_t)nget, y);
    printf("run %d status %d", run, s);
    for (int i = 0; i < nget; i++) printf(" %u=%.17g", gvr[i], y[i]);
    printf("\n");
    s |= F.Terminate(c);
    F.FreeInstance(c);
    return s;
}

/* ------------------------------------------------------------------------------ contract */
static int failures;
static void check(int ok, const char *name, const char *fmt, ...)
{
    if (ok) { printf("ok %s\n", name); return; }
    char why[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why, sizeof why, fmt, ap);
    va_end(ap);
    printf("FAIL %s: %s\n", name, why);
    failures++;
}

static fmi2Component ready(int steps, double h, unsigned pvr, double pval, int set_param)
{
    fmi2Component c = F.Instantiate("contract", 1, FMU_GUID, URI, &CB, 0, 0);
    if (!c) return NULL;
    F.SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
    F.EnterInit(c);
    if (set_param) F.SetReal(c, &pvr, 1, &pval);
    if (F.ExitInit(c) != 0) { F.FreeInstance(c); return NULL; }
    for (int k = 0; k < steps; k++) F.DoStep(c, k * h, h, 1);
    return c;
}

static int contract(int steps, double h, unsigned in_vr, unsigned p_vr, double bad, unsigned out_vr)
{
    char uri[8192];
    quiet = 1;
    /* instantiation refusals, each with a logged reason */
    last_log[0] = 0;
    check(!F.Instantiate(NULL, 1, FMU_GUID, URI, &CB, 0, 0) && strstr(last_log, "instanceName"), "null-instance-name",
          "log '%s'", last_log);
    last_log[0] = 0;
    check(!F.Instantiate("x", 1, "{not-the-guid}", URI, &CB, 0, 0) && strstr(last_log, "GUID"), "wrong-guid",
          "log '%s'", last_log);
    snprintf(uri, sizeof uri, "%s/no-such-folder", URI);
    last_log[0] = 0;
    check(!F.Instantiate("x", 1, FMU_GUID, uri, &CB, 0, 0) && strstr(last_log, "does not exist"), "missing-resources",
          "log '%s'", last_log);
    last_log[0] = 0;
    check(!F.Instantiate("x", 1, FMU_GUID, "http://example.invalid/r", &CB, 0, 0) && strstr(last_log, "example.invalid")
          && strstr(last_log, "not a local file URI"), "remote-uri", "log '%s'", last_log);
    last_log[0] = 0;
    check(!F.Instantiate("x", 1, FMU_GUID, NULL, &CB, 0, 0) && last_log[0], "null-uri", "log '%s'", last_log);

    /* calls out of order, NULL arrays, unknown references */
    fmi2Component c = F.Instantiate("contract", 1, FMU_GUID, URI, &CB, 0, 0);
    if (!c) { printf("FAIL instantiate: %s\n", last_log); return 1; }
    check(F.DoStep(c, 0.0, h, 1) >= 3, "step-before-initialization", "doStep accepted");
    F.SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
    F.EnterInit(c);
    F.ExitInit(c);
    double y = 0.0;
    unsigned bogus = 987654321u;
    check(F.GetReal(c, NULL, 1, &y) == 3, "get-real-null-vr", "not fmi2Error");
    check(F.SetReal(c, &in_vr, 1, NULL) == 3, "set-real-null-value", "not fmi2Error");
    check(F.GetReal(c, &bogus, 1, &y) >= 3 && F.GetReal(c, &out_vr, 1, &y) == 0, "unknown-value-reference",
          "not an error, or the instance unusable after it");
    check(F.DoStep(c, 1.0, h, 1) >= 2, "wrong-communication-point", "a step from t = 1 at t = 0 was accepted");
    check(F.EnterInit(c) >= 3, "initialization-again", "accepted");
    F.FreeInstance(c);
    F.FreeInstance(NULL);   /* must not crash */

    /* a parameter out of range: refused, named */
    last_log[0] = 0;
    c = F.Instantiate("contract", 1, FMU_GUID, URI, &CB, 0, 0);
    F.SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
    F.EnterInit(c);
    int sp = F.SetReal(c, &p_vr, 1, &bad);
    int se = F.ExitInit(c);
    int ss = F.DoStep(c, 0.0, h, 1);
    check((sp >= 3 || se >= 3) && ss >= 3 && last_log[0], "bad-parameter",
          "set %d exit %d step %d log '%s'", sp, se, ss, last_log);
    printf("  bad-parameter says: %s\n", last_log);
    F.FreeInstance(c);

    /* NaN input: the step is not OK, the variable is named, the state is kept */
    c = ready(steps, h, 0, 0, 0);
    if (!c) { printf("FAIL instantiate: %s\n", last_log); return 1; }
    double before = 0.0, after = 0.0, nan = NAN, u0 = 0.0;
    F.GetReal(c, &out_vr, 1, &before);
    F.GetReal(c, &in_vr, 1, &u0);
    last_log[0] = 0;
    F.SetReal(c, &in_vr, 1, &nan);
    int sn = F.DoStep(c, steps * h, h, 1);
    F.GetReal(c, &out_vr, 1, &after);
    check(sn >= 2 && last_log[0] && memcmp(&before, &after, sizeof before) == 0, "nan-input",
          "status %d log '%s' output %.17g -> %.17g", sn, last_log, before, after);
    printf("  nan-input says: %s\n", last_log);
    F.FreeInstance(c);

    /* FMU state: get/set and serialize/deserialize reproduce the continuation bit for bit */
    c = ready(steps, h, 0, 0, 0);
    fmi2FMUstate st = NULL, st2 = NULL;
    double y1 = 0, y2 = 0, y3 = 0;
    int sg = F.GetState(c, &st);
    for (int k = 0; k < steps; k++) F.DoStep(c, (steps + k) * h, h, 1);
    F.GetReal(c, &out_vr, 1, &y1);
    int ss2 = F.SetState(c, st);
    for (int k = 0; k < steps; k++) F.DoStep(c, (steps + k) * h, h, 1);
    F.GetReal(c, &out_vr, 1, &y2);
    check(sg == 0 && ss2 == 0 && memcmp(&y1, &y2, sizeof y1) == 0, "get-set-state", "%.17g vs %.17g", y1, y2);
    size_t n = 0;
    int sz = F.SerSize(c, st, &n);
    char *buf = (char *)malloc(n ? n : 1);
    int sr = F.Serialize(c, st, buf, n);
    int sd = F.Deserialize(c, buf, n, &st2);
    int sst = F.SetState(c, st2);
    for (int k = 0; k < steps; k++) F.DoStep(c, (steps + k) * h, h, 1);
    F.GetReal(c, &out_vr, 1, &y3);
    check(sz == 0 && sr == 0 && sd == 0 && sst == 0 && memcmp(&y1, &y3, sizeof y1) == 0, "serialize-state",
          "%d %d %d %d, %.17g vs %.17g (%zu bytes)", sz, sr, sd, sst, y1, y3, n);
    /* garbage: a state of nobody, and bytes that are no state */
    struct { unsigned magic; void *owner; } fake = {0x53544154u, NULL};
    check(F.SetState(c, (fmi2FMUstate)&fake) >= 3, "foreign-state", "accepted");
    fmi2FMUstate st3 = NULL;
    memset(buf, 0x5a, n);
    check(F.Deserialize(c, buf, n, &st3) >= 3 && st3 == NULL, "garbage-state-bytes", "accepted");
    double y4 = 0;
    check(F.DoStep(c, 2 * steps * h, h, 1) == 0 && F.GetReal(c, &out_vr, 1, &y4) == 0, "usable-after-refusals",
          "the instance no longer steps");
    free(buf);
    F.FreeState(c, &st);
    F.FreeState(c, &st2);
    check(st == NULL && F.FreeState(c, &st) == 0, "free-state", "state not cleared, or freeing NULL failed");
    /* reset: the same run again */
    double r1 = 0, r2 = 0;
    F.Reset(c);
    F.SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0);
    F.EnterInit(c);
    F.ExitInit(c);
    for (int k = 0; k < steps; k++) F.DoStep(c, k * h, h, 1);
    F.GetReal(c, &out_vr, 1, &r1);
    fmi2Component d = ready(steps, h, 0, 0, 0);
    F.GetReal(d, &out_vr, 1, &r2);
    check(memcmp(&r1, &r2, sizeof r1) == 0, "reset", "%.17g vs a fresh instance's %.17g", r1, r2);
    /* two instances side by side, stepped interleaved, agree */
    double a = 0, b = 0;
    for (int k = 0; k < steps; k++) { F.DoStep(c, (steps + k) * h, h, 1); F.DoStep(d, (steps + k) * h, h, 1); }
    F.GetReal(c, &out_vr, 1, &a);
    F.GetReal(d, &out_vr, 1, &b);
    check(memcmp(&a, &b, sizeof a) == 0, "two-instances", "%.17g vs %.17g", a, b);
    F.Terminate(c);
    F.FreeInstance(c);
    F.Terminate(d);
    F.FreeInstance(d);
    printf("%d failed\n", failures);
    return failures ? 1 : 0;
}

static int run(int argc, char **argv)
{
    if (argc < 8) {
        printf("usage: fmi2_any_host BINARY GUID URI STEPS STEP RUNS [VR=VALUE...] get VR[,VR...]\n"
               "       fmi2_any_host BINARY GUID URI STEPS STEP contract IN_VR PARAM_VR BAD_VALUE OUT_VR\n");
        return 1;
    }
    int rc = load(argv[1]);
    if (rc) return rc;
    FMU_GUID = argv[2];
    URI = argv[3];
    int steps = atoi(argv[4]);
    double h = atof(argv[5]);
    if (!strcmp(argv[6], "contract")) {
        if (argc != 11) { printf("contract needs IN_VR PARAM_VR BAD_VALUE OUT_VR\n"); return 1; }
        return contract(steps, h, (unsigned)atol(argv[7]), (unsigned)atol(argv[8]), atof(argv[9]),
                        (unsigned)atol(argv[10]));
    }
    int runs = atoi(argv[6]);
    unsigned svr[64], gvr[64];
    double sval[64];
    int nset = 0, nget = 0, i = 7;
    for (; i < argc && strcmp(argv[i], "get") && nset < 64; i++) {
        char *eq = strchr(argv[i], '=');
        if (!eq) { printf("not VR=VALUE: %s\n", argv[i]); return 1; }
        svr[nset] = (unsigned)atol(argv[i]);
        sval[nset++] = atof(eq + 1);
    }
    if (i + 1 >= argc) { printf("no 'get VR,...'\n"); return 1; }
    for (char *p = argv[i + 1]; *p && nget < 64;) {
        gvr[nget++] = (unsigned)strtoul(p, &p, 10);
        if (*p == ',') p++;
    }
    rc = 0;
    for (int r = 0; r < runs; r++) rc |= simulate(steps, h, nset, svr, sval, nget, gvr, r);
    fflush(stdout);
    return rc;
}
