/* host_common.h: what our C test hosts (fmi2_any_host.c for FMI 2.0, fmi3_host.c for FMI 3.0) share:
 * loading an FMU's binary (dlopen; on Windows LoadLibraryW of the UTF-8 path), looking up its functions,
 * and the program's entry: on Windows (mingw-w64, -municode) wmain reads the arguments as UTF-16 and
 * passes them on as UTF-8, so folders with non-ASCII characters reach the FMU intact.
 * The including host defines static int run(int argc, char **argv). The user-facing recipe
 * (harness/interop/recipes/fmi2_host.c) stays one self-contained file on purpose. */
#ifndef HOST_COMMON_H
#define HOST_COMMON_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _WIN32
#include <windows.h>
typedef HMODULE host_library;
#else
#include <dlfcn.h>
typedef void *host_library;
#endif

static int run(int argc, char **argv);

/* the binary at ``path`` (UTF-8), or NULL with the reason printed ("cannot load PATH: ...") */
static host_library load_binary(const char *path)
{
#ifdef _WIN32
    int n = MultiByteToWideChar(CP_UTF8, 0, path, -1, NULL, 0);
    wchar_t *w = (wchar_t *)malloc((size_t)n * sizeof *w);
    MultiByteToWideChar(CP_UTF8, 0, path, -1, w, n);
    HMODULE h = LoadLibraryW(w);
    free(w);
    if (!h) printf("cannot load %s: Windows error %lu\n", path, (unsigned long)GetLastError());
#else
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h) printf("cannot load %s: %s\n", path, dlerror());
#endif
    return h;
}

/* the function ``name`` of the binary into the function pointer ``target``; prints "missing NAME" and
   returns 3 from the calling function when the binary has none */
#ifdef _WIN32
#define HOST_LOOK(lib, name) ((void *)GetProcAddress(lib, name))
#else
#define HOST_LOOK(lib, name) dlsym(lib, name)
#endif
#define HOST_SYM(target, lib, name)                                                         \
    do {                                                                                    \
        void *p_ = HOST_LOOK(lib, name);                                                    \
        if (!p_) { printf("missing %s\n", name); return 3; }                                \
        memcpy(&(target), &p_, sizeof p_);                                                  \
    } while (0)

#ifdef _WIN32
int wmain(int argc, wchar_t **wargv)
{
    char **argv = (char **)calloc((size_t)argc + 1, sizeof *argv);
    for (int i = 0; i < argc; i++) {
        int n = WideCharToMultiByte(CP_UTF8, 0, wargv[i], -1, NULL, 0, NULL, NULL);
        argv[i] = (char *)malloc((size_t)n);
        WideCharToMultiByte(CP_UTF8, 0, wargv[i], -1, argv[i], n, NULL, NULL);
    }
#ifdef HOST_BUFFERED_STDOUT
    setvbuf(stdout, NULL, _IOFBF, 1 << 16);
#endif
    return run(argc, argv);
}
#else
int main(int argc, char **argv) { return run(argc, argv); }
#endif

#endif
