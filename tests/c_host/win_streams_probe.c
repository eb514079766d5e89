/* A test probe for 64-bit Windows (mingw-w64, -municode; run under wine by
 * tests/harness/test_win64_uri.py): where the standard streams of the FMU's own Python go.
 *
 *   win_streams_probe BINARY GUID RESOURCE_URI CODE
 *       loads BINARY, fmi2Instantiate (co-simulation; the FMU starts its Python), then runs the
 *       Python source CODE in that interpreter (PyRun_SimpleString of the python3X.dll the FMU
 *       loaded, under its GIL) and exits 0 when the instance was made and CODE raised nothing.
 * Not a host of the FMI standard: it reaches into the FMU's interpreter, which only a test may do.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <wchar.h>
#include <windows.h>

#include "fmi2FunctionTypes.h"   /* the standard's types (-I fmpy's c-code folder, as the tests build it) */

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String cat,
                   fmi2String msg, ...)
{
    (void)env;
    (void)cat;
    printf("log[%d] %s: %s\n", (int)status, name, msg);   /* the message as it is: enough for a test */
}

static char *utf8(const wchar_t *w)
{
    int n = WideCharToMultiByte(CP_UTF8, 0, w, -1, NULL, 0, NULL, NULL);
    char *s = n > 0 ? malloc((size_t)n) : NULL;
    if (s) WideCharToMultiByte(CP_UTF8, 0, w, -1, s, n, NULL, NULL);
    return s;
}

static void *symbol(HMODULE lib, const char *name)
{
    FARPROC f = lib ? GetProcAddress(lib, name) : NULL;
    void *p;
    memcpy(&p, &f, sizeof p);
    return p;
}

int wmain(int argc, wchar_t **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: win_streams_probe BINARY GUID RESOURCE_URI CODE\n");
        return 2;
    }
    HMODULE fmu = LoadLibraryW(argv[1]);
    fmi2InstantiateTYPE *instantiate;
    void *sym = symbol(fmu, "fmi2Instantiate");
    if (!sym) {
        printf("cannot load the FMU's fmi2Instantiate (Windows error %lu)\n", (unsigned long)GetLastError());
        return 3;
    }
    memcpy(&instantiate, &sym, sizeof sym);
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    char *guid = utf8(argv[2]), *uri = utf8(argv[3]), *code = utf8(argv[4]);
    if (!instantiate("probe", fmi2CoSimulation, guid, uri, &cb, fmi2False, fmi2False)) {
        printf("fmi2Instantiate returned NULL\n");
        return 4;
    }
    HMODULE py = NULL;
    for (int minor = 0; minor < 40 && !py; minor++) {
        wchar_t dll[32];
        swprintf(dll, sizeof dll / sizeof *dll, L"python3%d.dll", minor);
        py = GetModuleHandleW(dll);
    }
    int (*ensure)(void), (*run)(const char *);
    void (*release)(int);
    void *e = symbol(py, "PyGILState_Ensure"), *r = symbol(py, "PyRun_SimpleString"), *l = symbol(py, "PyGILState_Release");
    if (!e || !r || !l) {
        printf("no python3X.dll with PyRun_SimpleString in the process\n");
        return 5;
    }
    memcpy(&ensure, &e, sizeof e);
    memcpy(&run, &r, sizeof r);
    memcpy(&release, &l, sizeof l);
    int gil = ensure();
    int rc = run(code);
    release(gil);
    printf("code %s\n", rc == 0 ? "ran" : "raised");
    fflush(stdout);
    return rc == 0 ? 0 : 6;
}
