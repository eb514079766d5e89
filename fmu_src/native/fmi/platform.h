/* What the loader, the bridge and the runtime description need from the operating system, for
 * Linux (the POSIX calls the linux64 binaries always used, unchanged) and for 64-bit Windows
 * (binaries/win64, cross-built with mingw-w64). Header-only, static functions.
 *
 * Every path handled here is UTF-8 (what cfg_uri_to_path decodes from the resource URI); on
 * Windows it is converted to UTF-16 for each call into the Win32 API, so folders with non-ASCII
 * characters work whatever the host's code page. Windows accepts '/' as the separator, so the
 * relative paths of the runtime description are joined with '/' on both systems.
 *   plat_open_library(path, global)  dlopen(RTLD_NOW | RTLD_GLOBAL or RTLD_LOCAL) /
 *                                    LoadLibraryExW(LOAD_WITH_ALTERED_SEARCH_PATH: the library's
 *                                    own dependencies are found in its folder first)
 *   plat_symbol(lib, name)           dlsym / GetProcAddress
 *   plat_library_error(buf, size)    dlerror() / the text of GetLastError()
 *   plat_process_symbol(name)        a symbol of the Python the process already runs, or NULL:
 *                                    dlsym(RTLD_DEFAULT) / GetProcAddress on a loaded python3X.dll
 *   plat_own_dir(addr, out, size)    the folder of the binary holding `addr`
 *   plat_is_dir(path)                a folder that exists
 *   plat_open_read(path)             a read-only file descriptor (never blocking on a FIFO)
 *   plat_path_utf8(path, size)       a decoded resource path in the ANSI code page made UTF-8 (Windows)
 */
#ifndef SPURDIFF_PLATFORM_H
#define SPURDIFF_PLATFORM_H

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <fcntl.h>
#include <io.h>
#include <sys/stat.h>
#include <windows.h>
#include <wchar.h>

/* Windows' PATH_MAX (260) counts UTF-16 units; a UTF-8 path of as many characters can be 3 times
 * longer: the buffers are sized for that */
#undef PATH_MAX
#define PATH_MAX 4096
#define PLAT_FN static __attribute__((unused))
typedef HMODULE PlatLibrary;

/* UTF-8 -> newly allocated UTF-16 (free()), NULL when not valid UTF-8 or out of memory. */
PLAT_FN wchar_t *plat_wide(const char *s)
{
    int n = MultiByteToWideChar(CP_UTF8, MB_ERR_INVALID_CHARS, s, -1, NULL, 0);
    wchar_t *w = n > 0 ? (wchar_t *)malloc((size_t)n * sizeof *w) : NULL;
    if (w && MultiByteToWideChar(CP_UTF8, MB_ERR_INVALID_CHARS, s, -1, w, n) != n) {
        free(w);
        w = NULL;
    }
    return w;
}

PLAT_FN PlatLibrary plat_open_library(const char *path, int global)
{
    (void)global;   /* a Windows DLL's exports are reached by name from any module */
    wchar_t *w = plat_wide(path);
    PlatLibrary h = NULL;
    if (w) {
        for (wchar_t *p = w; *p; p++)   /* LOAD_WITH_ALTERED_SEARCH_PATH needs backslashes */
            if (*p == L'/') *p = L'\\';
        h = LoadLibraryExW(w, NULL, LOAD_WITH_ALTERED_SEARCH_PATH);
    } else {
        SetLastError(ERROR_INVALID_NAME);
    }
    free(w);
    return h;
}

PLAT_FN void *plat_symbol(PlatLibrary lib, const char *name)
{
    FARPROC f = GetProcAddress(lib, name);
    void *p;
    memcpy(&p, &f, sizeof p);
    return p;
}

PLAT_FN const char *plat_library_error(char *buf, size_t size)
{
    DWORD code = GetLastError();
    wchar_t w[512];
    DWORD n = FormatMessageW(FORMAT_MESSAGE_FROM_SYSTEM | FORMAT_MESSAGE_IGNORE_INSERTS, NULL, code, 0, w,
                             (DWORD)(sizeof w / sizeof *w), NULL);
    while (n && (w[n - 1] == L'\r' || w[n - 1] == L'\n' || w[n - 1] == L' ' || w[n - 1] == L'.')) w[--n] = 0;
    char text[1024] = "";
    if (n) WideCharToMultiByte(CP_UTF8, 0, w, -1, text, (int)sizeof text, NULL, NULL);
    snprintf(buf, size, "Windows error %lu%s%s", (unsigned long)code, text[0] ? ": " : "", text);
    return buf;
}

/* A Python DLL already in the process (python3.dll is the stable-ABI forwarder: skipped). */
PLAT_FN void *plat_process_symbol(const char *name)
{
    for (int minor = 0; minor < 40; minor++) {
        wchar_t dll[32];
        swprintf(dll, sizeof dll / sizeof *dll, L"python3%d.dll", minor);
        HMODULE h = GetModuleHandleW(dll);
        if (h) return plat_symbol(h, name);
    }
    return NULL;
}

PLAT_FN int plat_own_dir(const void *addr, char *out, size_t size)
{
    HMODULE self = NULL;
    wchar_t w[32768];
    if (!GetModuleHandleExW(GET_MODULE_HANDLE_EX_FLAG_FROM_ADDRESS | GET_MODULE_HANDLE_EX_FLAG_UNCHANGED_REFCOUNT,
                            (LPCWSTR)addr, &self))
        return -1;
    DWORD n = GetModuleFileNameW(self, w, (DWORD)(sizeof w / sizeof *w));
    if (n == 0 || n >= sizeof w / sizeof *w) return -1;
    if (!WideCharToMultiByte(CP_UTF8, 0, w, -1, out, (int)size, NULL, NULL)) return -1;
    char *slash = strrchr(out, '\\'), *fwd = strrchr(out, '/');
    if (fwd > slash) slash = fwd;
    if (!slash) return -1;
    *slash = 0;
    return 0;
}

PLAT_FN int plat_is_dir(const char *path)
{
    wchar_t *w = plat_wide(path);
    DWORD a = w ? GetFileAttributesW(w) : INVALID_FILE_ATTRIBUTES;
    free(w);
    return a != INVALID_FILE_ATTRIBUTES && (a & FILE_ATTRIBUTE_DIRECTORY);
}

/* A path decoded from a resource URI that is not UTF-8 was written in the ANSI code page (many
 * Windows hosts pass 'ü' so, percent-encoded or not): converted from that code page to UTF-8 in
 * place. 0, or -1 when it does not convert or fit. */
PLAT_FN int plat_path_utf8(char *path, size_t size)
{
    if (MultiByteToWideChar(CP_UTF8, MB_ERR_INVALID_CHARS, path, -1, NULL, 0) > 0)
        return 0;                                      /* UTF-8 already (ASCII too) */
    wchar_t w[PATH_MAX];
    if (!MultiByteToWideChar(CP_ACP, 0, path, -1, w, PATH_MAX))
        return -1;
    return WideCharToMultiByte(CP_UTF8, 0, w, -1, path, (int)size, NULL, NULL) > 0 ? 0 : -1;
}

PLAT_FN int plat_open_read(const char *path)
{
    wchar_t *w = plat_wide(path);
    int fd = w ? _wopen(w, _O_RDONLY | _O_BINARY | _O_NOINHERIT) : -1;
    if (!w) errno = EINVAL;
    free(w);
    return fd;
}

#else /* POSIX */
#include <dlfcn.h>
#include <fcntl.h>
#include <sys/stat.h>

#define PLAT_FN static __attribute__((unused))
typedef void *PlatLibrary;

PLAT_FN PlatLibrary plat_open_library(const char *path, int global)
{
    return dlopen(path, RTLD_NOW | (global ? RTLD_GLOBAL : RTLD_LOCAL));
}

PLAT_FN void *plat_symbol(PlatLibrary lib, const char *name) { return dlsym(lib, name); }

PLAT_FN const char *plat_library_error(char *buf, size_t size)
{
    const char *e = dlerror();
    snprintf(buf, size, "%s", e ? e : "unknown error");
    return buf;
}

PLAT_FN void *plat_process_symbol(const char *name) { return dlsym(RTLD_DEFAULT, name); }

PLAT_FN int plat_own_dir(const void *addr, char *out, size_t size)
{
    Dl_info info;
    if (!dladdr(addr, &info) || !info.dli_fname) return -1;
    if (snprintf(out, size, "%s", info.dli_fname) >= (int)size) return -1;
    char *slash = strrchr(out, '/');
    if (!slash) return -1;
    *slash = 0;
    return 0;
}

PLAT_FN int plat_is_dir(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

/* paths are bytes here: a resource URI's path is taken as it decodes */
PLAT_FN int plat_path_utf8(char *path, size_t size) { (void)path; (void)size; return 0; }

/* O_NONBLOCK: a FIFO planted in its place must not block the open (the caller refuses it) */
PLAT_FN int plat_open_read(const char *path) { return open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC); }
#endif

#endif
