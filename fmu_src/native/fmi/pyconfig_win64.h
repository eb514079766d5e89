/* pyconfig.h for compiling fmi2_pybridge.c with mingw-w64 against the Windows x64 build of CPython
 * (python3XY.dll of the embeddable distribution the FMU carries).
 *
 * The rest of CPython's headers are the same on every platform, so the build takes them from the
 * building interpreter (the win64 runtime is of its major.minor: harness/runtime_win64.py fetches
 * that version) and only this file, which the embeddable distribution does not ship, is ours: the
 * configuration of the official 64-bit Windows build as far as the public headers read it (type
 * sizes of the LLP64 model, the DLL import of every API symbol, Windows threads; no debug build).
 * harness/runtime_win64.py copies the interpreter's include folder and writes this file over its
 * pyconfig.h (Python.h includes "pyconfig.h" from its own folder first).
 */
#ifndef Py_CONFIG_H
#define Py_CONFIG_H

#ifndef _WIN64
#error "this pyconfig.h is for 64-bit Windows builds (mingw-w64 x86_64)"
#endif

#define MS_WIN32
#define MS_WIN64
#define MS_WINDOWS
#define NT_THREADS
#define WITH_THREAD

/* the API comes from python3XY.dll: PyAPI_FUNC/PyAPI_DATA are __declspec(dllimport) */
#define Py_ENABLE_SHARED 1
#define HAVE_DECLSPEC_DLL

/* LLP64 */
#define SIZEOF_SHORT 2
#define SIZEOF_INT 4
#define SIZEOF_LONG 4
#define SIZEOF_LONG_LONG 8
#define SIZEOF_DOUBLE 8
#define SIZEOF_FLOAT 4
#define SIZEOF_VOID_P 8
#define SIZEOF_SIZE_T 8
#define SIZEOF_TIME_T 8
#define SIZEOF_OFF_T 4
#define SIZEOF_FPOS_T 8
#define SIZEOF_WCHAR_T 2
#define SIZEOF__BOOL 1
#define SIZEOF_HKEY 8
#define ALIGNOF_SIZE_T 8
#define ALIGNOF_MAX_ALIGN_T 8
#define HAVE_LONG_LONG 1
#define PY_LONG_LONG long long

#define HAVE_STDDEF_H 1
#define HAVE_WCHAR_H 1
#define HAVE_SYS_STAT_H 1
#define HAVE_USABLE_WCHAR_T 1
#define WORD_BIT 32

#endif
