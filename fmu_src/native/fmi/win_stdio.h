/* The standard streams of the FMU's own Python on Windows (binaries/win64): used by the loader
 * (fmi2_inproc.c, around loading python3X.dll) and the bridge (fmi2_pybridge.c, once Python runs).
 * Header-only, static functions, Windows only.
 *
 * CPython makes sys.stdin, sys.stdout and sys.stderr from its C runtime's (ucrtbase's) descriptors
 * 0, 1 and 2, and io.FileIO refuses a descriptor whose handle is a disk file that
 * GetFileInformationByHandle calls invalid (ERROR_INVALID_HANDLE): Python's start then stops in
 * init_sys_streams ("OSError: [WinError 6]"). Wine (8.0) answers so for every standard handle of a
 * process started with a regular file as stdin, stdout or stderr: the handle it makes for the
 * inherited Unix descriptor has no name, and NtQueryInformationFile(FileAllInformation), which
 * GetFileInformationByHandle asks, returns STATUS_OBJECT_TYPE_MISMATCH (GetFileType says disk;
 * FileBasicInformation, reading and writing work). Windows never answers so for a valid handle,
 * so on Windows these functions find nothing to do.
 *
 * ucrtbase fills its descriptors 0-2 from the standard handles when it is loaded, which
 * python3X.dll does in a host that does not use ucrtbase itself (a mingw-w64 host: msvcrt).
 * winstd_hold makes each such standard handle NUL while the loader loads python3X.dll, and
 * winstd_release gives the host its handles back (its own C runtime never sees NUL); once Python
 * has made its streams, winstd_reconnect points each descriptor that got NUL at a duplicate of the
 * host's handle, so what the FMU's Python writes still goes where the host's output goes. A host
 * that runs ucrtbase already keeps its descriptors (they are its own): nothing is changed there.
 */
#ifndef SPURDIFF_WIN_STDIO_H
#define SPURDIFF_WIN_STDIO_H
#ifdef _WIN32
#include <fcntl.h>
#include <stdint.h>
#include <string.h>
#include <windows.h>

#define WINSTD_FN static __attribute__((unused))
static const DWORD WINSTD_WHICH[3] = {STD_INPUT_HANDLE, STD_OUTPUT_HANDLE, STD_ERROR_HANDLE};

/* A disk file whose information Windows calls an invalid handle (what io.FileIO refuses). */
WINSTD_FN int winstd_unqueryable(HANDLE h)
{
    BY_HANDLE_FILE_INFORMATION info;
    if (h == NULL || h == INVALID_HANDLE_VALUE || GetFileType(h) != FILE_TYPE_DISK) return 0;
    if (GetFileInformationByHandle(h, &info)) return 0;
    return GetLastError() == ERROR_INVALID_HANDLE;
}

/* Before python3X.dll is loaded: NUL as each unqueryable standard handle when ucrtbase is not
 * loaded yet. saved[i] is the host's handle, nul[i] the NUL handle (both NULL: unchanged). */
WINSTD_FN void winstd_hold(HANDLE saved[3], HANDLE nul[3])
{
    for (int i = 0; i < 3; i++) saved[i] = nul[i] = NULL;
    if (GetModuleHandleW(L"ucrtbase.dll")) return;
    for (int i = 0; i < 3; i++) {
        HANDLE h = GetStdHandle(WINSTD_WHICH[i]);
        if (!winstd_unqueryable(h)) continue;
        HANDLE n = CreateFileW(L"NUL", GENERIC_READ | GENERIC_WRITE, FILE_SHARE_READ | FILE_SHARE_WRITE, NULL,
                               OPEN_EXISTING, 0, NULL);
        if (n == INVALID_HANDLE_VALUE) continue;
        if (!SetStdHandle(WINSTD_WHICH[i], n)) {
            CloseHandle(n);
            continue;
        }
        saved[i] = h;
        nul[i] = n;
    }
}

/* After the load: the host's standard handles back. ucrtbase, when the load brought it, keeps its
 * descriptors on NUL; otherwise the NUL handles are closed (and nul[] cleared). */
WINSTD_FN void winstd_release(const HANDLE saved[3], HANDLE nul[3])
{
    int taken = GetModuleHandleW(L"ucrtbase.dll") != NULL;
    for (int i = 0; i < 3; i++) {
        if (!saved[i]) continue;
        SetStdHandle(WINSTD_WHICH[i], saved[i]);
        if (!taken) {
            CloseHandle(nul[i]);
            nul[i] = NULL;
        }
    }
}

/* Once Python has made sys.std*: each ucrtbase descriptor 0-2 still on its NUL handle from
 * winstd_hold gets a duplicate of the host's standard handle, in the translation mode (text or
 * binary) Python's start left it in. */
WINSTD_FN void winstd_reconnect(const HANDLE nul[3])
{
    HMODULE u = GetModuleHandleW(L"ucrtbase.dll");
    if (!u || !(nul[0] || nul[1] || nul[2])) return;
    intptr_t (__cdecl *get)(int);
    int (__cdecl *open_os)(intptr_t, int), (__cdecl *dup2_)(int, int), (__cdecl *close_)(int);
    int (__cdecl *setmode_)(int, int);
    FARPROC f[5] = {GetProcAddress(u, "_get_osfhandle"), GetProcAddress(u, "_open_osfhandle"),
                    GetProcAddress(u, "_dup2"), GetProcAddress(u, "_close"), GetProcAddress(u, "_setmode")};
    if (!f[0] || !f[1] || !f[2] || !f[3] || !f[4]) return;
    memcpy(&get, &f[0], sizeof get);
    memcpy(&open_os, &f[1], sizeof open_os);
    memcpy(&dup2_, &f[2], sizeof dup2_);
    memcpy(&close_, &f[3], sizeof close_);
    memcpy(&setmode_, &f[4], sizeof setmode_);
    HANDLE self = GetCurrentProcess(), d;
    for (int i = 0; i < 3; i++) {
        if (!nul[i] || get(i) != (intptr_t)nul[i]) continue;
        if (!DuplicateHandle(self, GetStdHandle(WINSTD_WHICH[i]), self, &d, 0, FALSE, DUPLICATE_SAME_ACCESS)) continue;
        int fd = open_os((intptr_t)d, 0);
        if (fd < 0) {
            CloseHandle(d);
            continue;
        }
        int mode = setmode_(i, _O_BINARY);   /* the mode it had (set back below) */
        if (dup2_(fd, i) == 0 && mode != -1) setmode_(i, mode);   /* the NUL handle closed, i on a duplicate of d */
        close_(fd);
    }
}

#endif
#endif
