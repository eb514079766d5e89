/* FMI 2.0 co-simulation functions over a Python slave object (fmi2_pybridge.so).
 *
 * Loaded by fmi2_loader.c once Python's symbols are global; compiled against the building
 * Python's headers with its functions left undefined (they resolve against the process's Python).
 * Every exported name carries the prefix spurdiff_bridge_ (defined below: the headers fmpy ships
 * ignore FMI2_FUNCTION_PREFIX), so it never shadows the loader's unprefixed functions.
 *
 * The interpreter: when the process has none running, fmi2Instantiate starts the FMU's own (the
 * loader made its libpython global) with the home and module path of resources/python_runtime.cfg,
 * resolved in the FMU's resources folder (isolated: the host's environment variables are not
 * read, no site-packages of any installation, UTF-8 mode, no bytecode written, no signal handlers)
 * and never finalizes it: a process that exits with extension modules loaded must not run Python's
 * finalization after its libraries' destructors (with numpy loaded, that corrupted the heap at exit
 * under pythonfmu's wrapper). In a process that already runs Python (of the runtime's version: the
 * loader checked), that interpreter is used and its module path is left alone.
 *
 * The FMU's package (resources/<package>/) is imported under a private name per extraction
 * folder and build (see BOOT_SOURCE), never as `spurdiff` from sys.path: two FMUs, two builds, or
 * an FMU beside a host that imported spurdiff itself never share a module, and an extraction
 * folder deleted after its last instance is freed leaves nothing behind that a later FMU reuses.
 *
 * The slave protocol (see spurdiff/fmi/adapter.py): the class from the cfg is called with
 * instance_name, resources, visible, logging_on; each FMI function calls one method named
 * fmi2_<function> whose return value is the status (None = fmi2OK) or, for getters, the values.
 * Getters and setters get the value references as a tuple (the same tuple object while the host
 * passes one of the last few vectors again: a master's step loop makes no new objects for them)
 * and setters the values as a tuple; a getter returns any sequence of numbers (converted here).
 * While the slave steps, fmi2GetReal and fmi2SetReal read and store its value table here instead
 * (the fast Real get/set below: the slave's fmi2_real_plan once per vector, its `phase` at every
 * call).
 * The native step: a model whose whole communication step is compiled (the slave's
 * fmi2_native_enter gives its plan: a C function over one array of doubles, the value-table names
 * of its slots) steps here without Python: fmi2DoStep calls the function, fmi2SetReal and
 * fmi2GetReal store and read the array. Any other call into the slave first hands the state back
 * (fmi2_native_leave), so the slave never sees a stale model; a step the function does not take
 * (an input it refuses, a non-finite result, a time the adapter would refuse) runs as the slave's
 * fmi2_do_step, which takes it or says why not (see the native section below).
 * A Python exception becomes fmi2Error with the exception logged; the instance stays usable.
 * After each call the slave's `log_queue` (pythonfmu LogMsg objects) is passed to the host's
 * logger (see emit: '%' escaped, so the slave's text is never taken as a format).
 */
#include "fmi2_pybridge.h"

const char *const METHOD_NAMES[N_METHODS] = {
    "fmi2_set_debug_logging", "fmi2_setup_experiment", "fmi2_enter_initialization_mode",
    "fmi2_exit_initialization_mode", "fmi2_terminate",
    "fmi2_get_real", "fmi2_get_integer", "fmi2_get_boolean", "fmi2_get_string",
    "fmi2_set_real", "fmi2_set_integer", "fmi2_set_boolean", "fmi2_set_string",
    "fmi2_get_state", "fmi2_set_state", "fmi2_serialize_state", "fmi2_deserialize_state",
    "fmi2_do_step", "fmi2_cancel_step", "fmi2_get_status",
};

static pthread_mutex_t init_lock = PTHREAD_MUTEX_INITIALIZER;
/* ------------------------------------------------------------------------------ interpreter */
/* Python's start writes its path configuration (some 20 lines) to the C stderr when it fails: that
 * text goes to a memory file while the interpreter starts, so the host sees the one clean reason
 * (logged by the caller); what a successful start wrote is passed on to stderr. */
#ifndef _WIN32
#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>
static int stderr_hold(int *saved)
{
    fflush(stderr);
    int mfd = memfd_create("spurdiff-python-start", MFD_CLOEXEC);
    if (mfd < 0) return -1;
    *saved = fcntl(2, F_DUPFD_CLOEXEC, 3);
    if (*saved < 0 || dup2(mfd, 2) < 0) {
        if (*saved >= 0) close(*saved);
        close(mfd);
        return -1;
    }
    return mfd;
}
static void stderr_release(int mfd, int saved, int pass_on)
{
    if (mfd < 0) return;
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    char buf[4096];
    ssize_t n;
    if (pass_on && lseek(mfd, 0, SEEK_SET) == 0)
        while ((n = read(mfd, buf, sizeof buf)) > 0 && write(2, buf, (size_t)n) == n) {}
    close(mfd);
}
#else
static int stderr_hold(int *saved) { *saved = -1; return -1; }
static void stderr_release(int mfd, int saved, int pass_on) { (void)mfd; (void)saved; (void)pass_on; }
/* The standard streams the loader started python3X.dll's C runtime on (win_stdio.h): given here
 * by the loader after it loaded the bridge (exported like every function here: mingw-w64 exports
 * all when none is marked dllexport), reconnected to the host's once Python has started. */
#include "win_stdio.h"
static HANDLE std_nul[3];
void spurdiff_bridge_winStdioHeld(const HANDLE nul[3])
{
    memcpy(std_nul, nul, sizeof std_nul);
}
#endif

/* Start the FMU's Python when the process has none (GIL released on return). */
static int start_python(const RuntimeCfg *cfg, const char *resources, char *err, size_t errsize)
{
    if (Py_IsInitialized()) return 0;   /* a Python host, or another FMU started it: the loader checked the version */
    char root[CFG_MAX_LINE];   /* where the runtime's files are: resources/, or the archives unpacked */
    if (cfg_runtime_root(resources, cfg, root, sizeof root, err, errsize) != 0) return -1;
    char file[CFG_MAX_LINE];
    PyStatus status;
    PyPreConfig pre;
    PyPreConfig_InitIsolatedConfig(&pre);
    pre.utf8_mode = 1;                    /* file names and messages are UTF-8 whatever the host's locale */
    status = Py_PreInitialize(&pre);
    if (PyStatus_Exception(status)) {
        snprintf(err, errsize, "cannot pre-initialize the FMU's Python %s: %s", cfg->version,
                 status.err_msg ? status.err_msg : "unknown error");
        return -1;
    }
    PyConfig config;
    PyConfig_InitIsolatedConfig(&config);
    config.install_signal_handlers = 0;   /* the host owns its signals */
    config.site_import = 0;               /* the runtime's path is complete; no installation's site-packages */
    config.write_bytecode = 0;            /* the runtime carries its bytecode; never write into the FMU */
    config.parse_argv = 0;
    status = PyConfig_SetBytesString(&config, &config.program_name, "spurdiff-fmu");
    if (!PyStatus_Exception(status)) {
        if (cfg_join(root, cfg->home, file, sizeof file) != 0) status = PyStatus_Error("resources path too long");
        else status = PyConfig_SetBytesString(&config, &config.home, file);
    }
    for (int i = 0; i < cfg->n_path && !PyStatus_Exception(status); i++) {
        if (cfg_join(root, cfg->path[i], file, sizeof file) != 0) { status = PyStatus_Error("resources path too long"); break; }
        wchar_t *w = Py_DecodeLocale(file, NULL);
        if (!w) { status = PyStatus_NoMemory(); break; }
        status = PyWideStringList_Append(&config.module_search_paths, w);
        PyMem_RawFree(w);
    }
    config.module_search_paths_set = 1;
    if (!PyStatus_Exception(status)) {
        int saved, held = stderr_hold(&saved);
        status = Py_InitializeFromConfig(&config);
        stderr_release(held, saved, !PyStatus_Exception(status));
#ifdef _WIN32
        if (!PyStatus_Exception(status)) winstd_reconnect(std_nul);
#endif
    }
    PyConfig_Clear(&config);
    if (PyStatus_Exception(status)) {
        snprintf(err, errsize, "cannot start the FMU's Python %s (home %s/%s): %s%s%s", cfg->version, root,
                 cfg->home, status.func ? status.func : "", status.func ? ": " : "",
                 status.err_msg ? status.err_msg : "unknown error");
        return -1;
    }
    PyEval_SaveThread();   /* release the GIL: every call takes it with PyGILState_Ensure */
    return 0;
}

/* ------------------------------------------------------------------------------ the FMU's package
 * One module per process (whichever FMU's bridge came first; the name carries the protocol
 * version): load() imports the package as `_spurdiff_fmu_<digest of the folder and the GUID>` and
 * returns (that name, the slave class). The package is the archive resources/<package>.zip (one
 * member a host's unzip writes where the package's folder held some 200 files; zipimport reads its
 * modules, and the package reads its data through its loader; its compiled kernels stay files in
 * resources/<package>/), or the folder resources/<package>/ without one (a staged copy at build time).
 * release() counts the instances down. An alias with no instance left whose folder is gone, or
 * whose archive is not the file it was imported from (another build extracted there), is dropped
 * from sys.modules at the next load; a new alias reads its archive afresh (zipimport keeps an
 * archive's directory by its path). The package needs nothing beyond the standard library, so a
 * Python host's module path is left as it is. */
static const char *BOOT_SOURCE =
"import importlib, importlib.util, os, sys\n"
"try:   # the interpreter's own SHA-256 (3.11: _sha256): hashlib would load OpenSSL's libcrypto into the host\n"
"    from _sha256 import sha256 as _sha256\n"
"except ImportError:\n"
"    from hashlib import sha256 as _sha256\n"
"_live = {}   # alias -> [instances, folder, archive or None, the archive's (inode, size, mtime) when imported]\n"
"def _drop(alias):\n"
"    for name in [n for n in list(sys.modules) if n == alias or n.startswith(alias + '.')]:\n"
"        del sys.modules[name]\n"
"def _stamp(path):\n"
"    try:\n"
"        st = os.stat(path)\n"
"    except OSError:\n"
"        return None\n"
"    return (st.st_ino, st.st_size, st.st_mtime_ns)\n"
"def _forget(archive):   # zipimport keeps an archive's directory by its path: read it afresh\n"
"    import zipimport\n"
"    for k in [k for k in list(sys.path_importer_cache) if k == archive or k.startswith(archive + os.sep)]:\n"
"        del sys.path_importer_cache[k]\n"
"    getattr(zipimport, '_zip_directory_cache', {}).pop(archive, None)\n"
"def load(resources, package, module, klass, guid):\n"
"    res = os.path.realpath(resources)\n"
"    for a, (count, folder, archive, stamp) in list(_live.items()):\n"
"        if count <= 0 and (not os.path.isdir(folder) or (archive and _stamp(archive) != stamp)):\n"
"            _drop(a)\n"
"            del _live[a]\n"
"    key = _sha256(os.fsencode(res) + b'\\0' + guid.encode()).hexdigest()[:16]\n"
"    alias = '_spurdiff_fmu_' + key\n"
"    root = os.path.join(res, package)\n"
"    archive = root + '.zip' if os.path.isfile(root + '.zip') else None\n"
"    stamp = None\n"
"    if alias not in sys.modules:\n"
"        code = None\n"
"        if archive:\n"
"            import zipimport\n"
"            _forget(archive)\n"
"            stamp = _stamp(archive)\n"
"            inner = os.path.join(archive, package)\n"
"            top = zipimport.zipimporter(archive)\n"
"            code = top.get_code(package)\n"
"            spec = importlib.util.spec_from_loader(alias, top, origin=os.path.join(inner, '__init__.py'),\n"
"                                                   is_package=True)\n"
"            spec.submodule_search_locations = [inner]\n"
"            spec.has_location = True\n"
"        else:\n"
"            spec = importlib.util.spec_from_file_location(alias, os.path.join(root, '__init__.py'),\n"
"                                                          submodule_search_locations=[root])\n"
"        if spec is None:\n"
"            raise ImportError('the FMU has no package ' + root)\n"
"        mod = importlib.util.module_from_spec(spec)\n"
"        sys.modules[alias] = mod\n"
"        try:\n"
"            if code is None:\n"
"                spec.loader.exec_module(mod)\n"
"            else:\n"
"                exec(code, mod.__dict__)\n"
"        except BaseException:\n"
"            _drop(alias)\n"
"            raise\n"
"    try:\n"
"        cls = getattr(importlib.import_module(alias + '.' + module), klass)\n"
"    except BaseException:\n"
"        if alias not in _live:\n"
"            _drop(alias)\n"
"        raise\n"
"    _live.setdefault(alias, [0, res, archive, stamp])[0] += 1\n"
"    return alias, cls\n"
"def release(alias):\n"
"    if alias in _live:\n"
"        _live[alias][0] -= 1\n";

/* The boot module (borrowed), NULL with an error set. */
static PyObject *boot_module(void)
{
    static const char *NAME = "_spurdiff_fmu_boot_4";
    PyObject *modules = PyImport_GetModuleDict();   /* borrowed */
    PyObject *mod = PyDict_GetItemString(modules, NAME);   /* borrowed */
    if (mod) return mod;
    PyObject *m = PyModule_New(NAME);
    if (!m) return NULL;
    PyObject *globals = PyModule_GetDict(m);   /* borrowed */
    if (PyDict_SetItemString(globals, "__builtins__", PyEval_GetBuiltins()) != 0) { Py_DECREF(m); return NULL; }
    PyObject *r = PyRun_String(BOOT_SOURCE, Py_file_input, globals, globals);
    if (!r) { Py_DECREF(m); return NULL; }
    Py_DECREF(r);
    if (PyDict_SetItemString(modules, NAME, m) != 0) { Py_DECREF(m); return NULL; }
    Py_DECREF(m);
    return m;
}

/* ------------------------------------------------------------------------------ instances */
BRIDGE_INTERNAL Instance *valid(fmi2Component c)
{
    Instance *I = (Instance *)c;
    return (I && I->magic == INSTANCE_MAGIC) ? I : NULL;
}

static void drop_methods(Instance *I)
{
    for (int i = 0; i < N_METHODS; i++) Py_CLEAR(I->methods[i]);
    Py_CLEAR(I->log_queue);
    Py_CLEAR(I->slave);
}

/* Create the slave object and bind its methods (GIL held). 0, or -1 with a Python error set. */
static int make_slave(Instance *I)
{
    PyObject *kw = Py_BuildValue("{s:s,s:s,s:O,s:O}", "instance_name", I->name, "resources", I->resources,
                                 "visible", I->visible ? Py_True : Py_False,
                                 "logging_on", I->logging_on ? Py_True : Py_False);
    if (!kw) return -1;
    PyObject *args = PyTuple_New(0);
    PyObject *slave = args ? PyObject_Call(I->klass, args, kw) : NULL;
    Py_XDECREF(args);
    Py_DECREF(kw);
    if (!slave) return -1;
    PyObject *methods[N_METHODS] = {0};
    PyObject *queue = PyObject_GetAttrString(slave, "log_queue");
    int ok = queue != NULL;
    for (int i = 0; ok && i < N_METHODS; i++) ok = (methods[i] = PyObject_GetAttrString(slave, METHOD_NAMES[i])) != NULL;
    if (!ok) {
        for (int i = 0; i < N_METHODS; i++) Py_XDECREF(methods[i]);
        Py_XDECREF(queue);
        Py_DECREF(slave);
        return -1;
    }
    drop_methods(I);
    I->slave = slave;
    I->log_queue = queue;
    memcpy(I->methods, methods, sizeof methods);
    return 0;
}

/* (GIL held) */
static void drop_entry(VrEntry *e)
{
    Py_CLEAR(e->tuple);
    Py_CLEAR(e->names);
    free(e->vr);
    free(e->lo);
    free(e->hi);
    free(e->pos);
    e->vr = NULL;
    e->lo = e->hi = NULL;
    e->pos = NULL;
    e->pos_state = 0;
    e->pos_plan = 0;
    e->n = 0;
}

static void drop_vr_caches(Instance *I)
{
    for (int i = 0; i < N_METHODS; i++)
        for (int k = 0; k < VR_SLOTS; k++) drop_entry(&I->vrc[i].e[k]);
}

/* The instance no longer uses its package alias (GIL held). */
static void release_alias(Instance *I)
{
    if (!I || !I->alias) return;
    PyObject *boot = boot_module();
    PyObject *r = boot ? PyObject_CallMethod(boot, "release", "O", I->alias) : NULL;
    Py_XDECREF(r);
    if (PyErr_Occurred()) PyErr_Clear();
    Py_CLEAR(I->alias);
}

static void free_instance(Instance *I)
{
    if (!I) return;
    I->magic = 0;
    free(I->name);
    free(I->resources);
    free(I);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String resources /* a decoded path: the loader converted the URI */,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn)
{
    RuntimeCfg cfg;
    char err[8192];
    if (cfg_read(resources, &cfg, err, sizeof err) != 0) {
        emitf(functions, instanceName, fmi2Error, "fmi2Instantiate: %s", err);
        return NULL;
    }
    Instance *I = NULL;
    if (fmuType != fmi2CoSimulation) {
        emitf(functions, instanceName, fmi2Error, "fmi2Instantiate: this FMU implements co-simulation only "
              "(fmuType %d requested)", (int)fmuType);
        goto fail;
    }
    if (!fmuGUID || strcmp(fmuGUID, cfg.guid) != 0) {
        emitf(functions, instanceName, fmi2Error, "fmi2Instantiate: GUID '%.200s' does not match this FMU's "
              "modelDescription.xml ('%s')", fmuGUID ? fmuGUID : "(null)", cfg.guid);
        goto fail;
    }
    pthread_mutex_lock(&init_lock);
    int rc = start_python(&cfg, resources, err, sizeof err);
    pthread_mutex_unlock(&init_lock);
    if (rc != 0) {
        emitf(functions, instanceName, fmi2Error, "fmi2Instantiate: %s", err);
        goto fail;
    }
    I = (Instance *)calloc(1, sizeof *I);
    if (!I) goto fail;
    I->magic = INSTANCE_MAGIC;
    I->name = cfg_strdup(instanceName);
    I->resources = cfg_strdup(resources);
    if (functions) I->cb = *functions;
    I->logging_on = loggingOn ? 1 : 0;
    I->visible = visible ? 1 : 0;

    PyGILState_STATE g = PyGILState_Ensure();
    const char *stage = "loading the FMU's package";
    PyObject *r = NULL;
    PyObject *boot = boot_module();
    PyObject *res = boot ? PyUnicode_DecodeFSDefault(resources) : NULL;
    if (res)
        r = PyObject_CallMethod(boot, "load", "Ossss", res, cfg.package, cfg.module, cfg.klass, cfg.guid);
    Py_XDECREF(res);
    if (!r) goto pyfail;
    if (!PyTuple_Check(r) || PyTuple_GET_SIZE(r) != 2) {
        Py_DECREF(r);
        PyErr_SetString(PyExc_TypeError, "the boot module's load() did not return (alias, class)");
        goto pyfail;
    }
    I->alias = PyTuple_GET_ITEM(r, 0);
    I->klass = PyTuple_GET_ITEM(r, 1);
    Py_INCREF(I->alias);
    Py_INCREF(I->klass);
    Py_DECREF(r);
    if (make_slave(I) != 0) { stage = "creating the slave"; goto pyfail; }
    flush_log(I);
    PyGILState_Release(g);
    cfg_free(&cfg);
    return I;

pyfail:
    {
        char text[4096];
        exception_text(text, sizeof text);
        emitf(functions, instanceName, fmi2Error, "fmi2Instantiate: %s failed: %s", stage, text);
    }
    release_alias(I);
    Py_CLEAR(I->klass);
    drop_methods(I);
    PyGILState_Release(g);
fail:
    free_instance(I);
    cfg_free(&cfg);
    return NULL;
}

void fmi2FreeInstance(fmi2Component c)
{
    Instance *I = valid(c);
    if (!I) return;
    PyGILState_STATE g = PyGILState_Ensure();
    flush_log(I);
    drop_methods(I);
    drop_vr_caches(I);
    native_drop(I);
    Py_CLEAR(I->klass);
    Py_CLEAR(I->strings);
    release_alias(I);
    PyGILState_Release(g);
    free_instance(I);
}

/* ------------------------------------------------------------------------------ calls (ENTER, LEAVE: fmi2_pybridge.h) */
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[])
{
    ENTER
    PyObject *cats = PyList_New(0);
    for (size_t i = 0; cats && i < n; i++) {
        PyObject *x = PyUnicode_FromString(cat && cat[i] ? cat[i] : "");
        if (!x || PyList_Append(cats, x) != 0) Py_CLEAR(cats);
        Py_XDECREF(x);
    }
    s = cats ? status_of(I, PyObject_CallFunction(I->methods[M_SET_DEBUG_LOGGING], "OO", on ? Py_True : Py_False, cats),
                         "fmi2SetDebugLogging")
             : status_of(I, NULL, "fmi2SetDebugLogging");
    Py_XDECREF(cats);
    if (s <= fmi2Warning) I->logging_on = on ? 1 : 0;
    LEAVE
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean td, fmi2Real tol, fmi2Real t0, fmi2Boolean sd, fmi2Real t1)
{
    ENTER
    s = status_of(I, PyObject_CallFunction(I->methods[M_SETUP_EXPERIMENT], "OddOd", td ? Py_True : Py_False, tol, t0,
                                           sd ? Py_True : Py_False, t1), "fmi2SetupExperiment");
    LEAVE
}

#define SIMPLE_CALL(fn, method)                                                                    \
    fmi2Status fn(fmi2Component c)                                                                 \
    {                                                                                              \
        ENTER                                                                                      \
        s = status_of(I, PyObject_CallNoArgs(I->methods[method]), #fn);                            \
        LEAVE                                                                                      \
    }
SIMPLE_CALL(fmi2EnterInitializationMode, M_ENTER_INIT)
SIMPLE_CALL(fmi2ExitInitializationMode, M_EXIT_INIT)
SIMPLE_CALL(fmi2Terminate, M_TERMINATE)
SIMPLE_CALL(fmi2CancelStep, M_CANCEL_STEP)

fmi2Status fmi2Reset(fmi2Component c)
{
    ENTER
    if (make_slave(I) == 0) { drop_vr_caches(I); native_drop(I); s = fmi2OK; }   /* the plans were the old slave's */
    else s = status_of(I, NULL, "fmi2Reset");   /* the old slave stays */
    LEAVE
}

/* The cache entry of the value-reference vector (its tuple made), the cached one when the host
 * passes a vector it passed to this method lately (GIL held); NULL with a Python error set. */
BRIDGE_INTERNAL VrEntry *vr_entry(Instance *I, int method, const fmi2ValueReference vr[], size_t n)
{
    VrCache *c = &I->vrc[method];
    for (int k = 0; k < VR_SLOTS; k++) {
        VrEntry *e = &c->e[k];
        if (e->tuple && e->n == n && (n == 0 || memcmp(e->vr, vr, n * sizeof *vr) == 0)) return e;
    }
    PyObject *t = PyTuple_New((Py_ssize_t)n);
    for (size_t i = 0; t && i < n; i++) {
        PyObject *x = PyLong_FromUnsignedLong(vr[i]);
        if (!x) { Py_CLEAR(t); break; }
        PyTuple_SET_ITEM(t, (Py_ssize_t)i, x);
    }
    if (!t) return NULL;
    fmi2ValueReference *copy = (fmi2ValueReference *)malloc((n ? n : 1) * sizeof *vr);
    if (!copy) { Py_DECREF(t); PyErr_NoMemory(); return NULL; }
    if (n) memcpy(copy, vr, n * sizeof *vr);
    VrEntry *e = &c->e[c->next];
    c->next = (c->next + 1) % VR_SLOTS;
    drop_entry(e);
    e->vr = copy;
    e->n = n;
    e->tuple = t;
    return e;
}

/* The tuple of the value references (new reference), see vr_entry. */
BRIDGE_INTERNAL PyObject *vr_tuple(Instance *I, int method, const fmi2ValueReference vr[], size_t n)
{
    VrEntry *e = vr_entry(I, method, vr, n);
    if (!e) return NULL;
    Py_INCREF(e->tuple);
    return e->tuple;
}

/* Call a getter; on success a sequence of exactly n items is returned (new reference). */
static PyObject *get_values(Instance *I, int method, const fmi2ValueReference vr[], size_t n, const char *fn,
                            fmi2Status *s)
{
    if (n && !vr) { emitf(&I->cb, I->name, fmi2Error, "%s: vr is NULL", fn); *s = fmi2Error; return NULL; }
    PyObject *vrs = vr_tuple(I, method, vr, n);
    PyObject *r = vrs ? PyObject_CallOneArg(I->methods[method], vrs) : NULL;
    Py_XDECREF(vrs);
    if (!r) { *s = status_of(I, NULL, fn); return NULL; }
    PyObject *seq = PySequence_Fast(r, "the slave's getter did not return a sequence");
    Py_DECREF(r);
    if (!seq || (size_t)PySequence_Fast_GET_SIZE(seq) != n) {
        if (seq) emitf(&I->cb, I->name, fmi2Error, "%s: the slave returned %zd values for %zu references", fn,
                       PySequence_Fast_GET_SIZE(seq), n);
        Py_XDECREF(seq);
        *s = seq ? fmi2Error : status_of(I, NULL, fn);
        return NULL;
    }
    *s = fmi2OK;
    return seq;
}

#define GETTER(fn, ctype, method, convert)                                                         \
    fmi2Status fn(fmi2Component c, const fmi2ValueReference vr[], size_t n, ctype v[])             \
    {                                                                                              \
        ENTER                                                                                      \
        PyObject *seq = get_values(I, method, vr, n, #fn, &s);                                     \
        if (seq) {                                                                                 \
            for (size_t i = 0; i < n; i++) {                                                       \
                PyObject *x = PySequence_Fast_GET_ITEM(seq, (Py_ssize_t)i);                        \
                v[i] = convert;                                                                    \
            }                                                                                      \
            if (PyErr_Occurred()) s = status_of(I, NULL, #fn);                                     \
            Py_DECREF(seq);                                                                        \
        }                                                                                          \
        LEAVE                                                                                      \
    }
#undef fmi2GetReal   /* the slave's method, the path of every call the fast one does not take */
#define fmi2GetReal slow_fmi2GetReal
static GETTER(fmi2GetReal, fmi2Real, M_GET_REAL, PyFloat_AsDouble(x))
#undef fmi2GetReal
#define fmi2GetReal spurdiff_bridge_fmi2GetReal
#undef fmi2GetInteger   /* the slave's method, when the native step's array does not hold them all */
#define fmi2GetInteger slow_fmi2GetInteger
static GETTER(fmi2GetInteger, fmi2Integer, M_GET_INTEGER, (fmi2Integer)PyLong_AsLong(x))
#undef fmi2GetInteger
#define fmi2GetInteger spurdiff_bridge_fmi2GetInteger
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
{
    Instance *I = valid(c);
    if (I && I->nat.on && (n == 0 || (vr && v)) && native_get_integer(I, vr, n, v)) return fmi2OK;
    return slow_fmi2GetInteger(c, vr, n, v);
}
GETTER(fmi2GetBoolean, fmi2Boolean, M_GET_BOOLEAN, PyObject_IsTrue(x) > 0 ? fmi2True : fmi2False)

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[])
{
    ENTER
    PyObject *seq = get_values(I, M_GET_STRING, vr, n, "fmi2GetString", &s);
    if (seq) {
        PyObject *keep = PyList_New(0);
        for (size_t i = 0; keep && i < n; i++) {
            PyObject *x = PyObject_Str(PySequence_Fast_GET_ITEM(seq, (Py_ssize_t)i));
            v[i] = x ? PyUnicode_AsUTF8(x) : NULL;
            if (!x || !v[i] || PyList_Append(keep, x) != 0) Py_CLEAR(keep);
            Py_XDECREF(x);
        }
        if (!keep) s = status_of(I, NULL, "fmi2GetString");
        Py_XSETREF(I->strings, keep);   /* the buffers stay valid until the next fmi2GetString */
        Py_DECREF(seq);
    }
    LEAVE
}

#define SETTER(fn, ctype, method, build)                                                           \
    fmi2Status fn(fmi2Component c, const fmi2ValueReference vr[], size_t n, const ctype v[])       \
    {                                                                                              \
        ENTER                                                                                      \
        if (n && (!vr || !v)) {                                                                    \
            emitf(&I->cb, I->name, fmi2Error, "%s: vr or value is NULL", #fn);                     \
            s = fmi2Error;                                                                         \
        } else {                                                                                   \
            PyObject *vrs = vr_tuple(I, method, vr, n), *vals = PyTuple_New((Py_ssize_t)n);        \
            for (size_t i = 0; vals && i < n; i++) {                                               \
                PyObject *x = build;                                                               \
                if (!x) { Py_CLEAR(vals); break; }                                                 \
                PyTuple_SET_ITEM(vals, (Py_ssize_t)i, x);                                          \
            }                                                                                      \
            PyObject *args[2] = {vrs, vals};                                                       \
            s = status_of(I, (vrs && vals) ? PyObject_Vectorcall(I->methods[method], args, 2, NULL) : NULL, #fn); \
            Py_XDECREF(vrs);                                                                       \
            Py_XDECREF(vals);                                                                      \
        }                                                                                          \
        LEAVE                                                                                      \
    }
#undef fmi2SetReal
#define fmi2SetReal slow_fmi2SetReal
static SETTER(fmi2SetReal, fmi2Real, M_SET_REAL, PyFloat_FromDouble(v[i]))
#undef fmi2SetReal
#define fmi2SetReal spurdiff_bridge_fmi2SetReal

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[])
{
    Instance *I = valid(c);
    if (!I) return fmi2Error;
    if (n && (!vr || !v)) return slow_fmi2GetReal(c, vr, n, v);
    if (I->nat.on && native_get_real(I, vr, n, v)) return fmi2OK;
    PyGILState_STATE g = PyGILState_Ensure();
    int done = !I->nat.on && fast_get_real(I, vr, n, v);
    if (done) flush_log(I);
    PyGILState_Release(g);
    return done ? fmi2OK : slow_fmi2GetReal(c, vr, n, v);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[])
{
    Instance *I = valid(c);
    if (!I) return fmi2Error;
    if (n && (!vr || !v)) return slow_fmi2SetReal(c, vr, n, v);
    if (I->nat.on && native_set_real(I, vr, n, v)) return fmi2OK;
    PyGILState_STATE g = PyGILState_Ensure();
    fmi2Status s = fmi2OK;
    int done = !I->nat.on && fast_set_real(I, vr, n, v, &s);
    if (done) flush_log(I);
    PyGILState_Release(g);
    return done ? s : slow_fmi2SetReal(c, vr, n, v);
}
SETTER(fmi2SetInteger, fmi2Integer, M_SET_INTEGER, PyLong_FromLong(v[i]))
SETTER(fmi2SetBoolean, fmi2Boolean, M_SET_BOOLEAN, PyBool_FromLong(v[i]))
SETTER(fmi2SetString, fmi2String, M_SET_STRING, PyUnicode_FromString(v[i] ? v[i] : ""))
/* ------------------------------------------------------------------------------ stepping */
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp)
{
    Instance *I0 = valid(c);
    if (!I0) return fmi2Error;
    if (native_try(I0, t, h, 0)) return fmi2OK;   /* the native step: no Python */
    ENTER   /* (hands a native state back first) */
    PyObject *args[3] = {PyFloat_FromDouble(t), PyFloat_FromDouble(h), nsp ? Py_True : Py_False};
    s = status_of(I, (args[0] && args[1]) ? PyObject_Vectorcall(I->methods[M_DO_STEP], args, 3, NULL) : NULL,
                  "fmi2DoStep");
    Py_XDECREF(args[0]);
    Py_XDECREF(args[1]);
    LEAVE
}

/* fmi2GetXxxStatus: the slave's fmi2_get_status(kind, type) returns (status, value). */
static PyObject *status_value(Instance *I, int kind, const char *type, const char *fn, fmi2Status *s)
{
    PyObject *r = PyObject_CallFunction(I->methods[M_GET_STATUS], "is", kind, type);
    if (!r) { *s = status_of(I, NULL, fn); return NULL; }
    PyObject *st = NULL, *val = NULL;
    if (!PyArg_ParseTuple(r, "OO", &st, &val)) { Py_DECREF(r); *s = status_of(I, NULL, fn); return NULL; }
    Py_INCREF(st);
    Py_INCREF(val);
    Py_DECREF(r);
    *s = status_of(I, st, fn);
    if (*s > fmi2Warning) { Py_DECREF(val); return NULL; }
    return val;
}

#define STATUS_GETTER(fn, ctype, type, convert)                                                    \
    fmi2Status fn(fmi2Component c, const fmi2StatusKind k, ctype *v)                               \
    {                                                                                              \
        ENTER                                                                                      \
        PyObject *x = v ? status_value(I, (int)k, type, #fn, &s) : NULL;                          \
        if (!v) { emitf(&I->cb, I->name, fmi2Error, "%s: value is NULL", #fn); s = fmi2Error; }   \
        if (x) {                                                                                   \
            *v = convert;                                                                          \
            if (PyErr_Occurred()) s = status_of(I, NULL, #fn);                                     \
            Py_DECREF(x);                                                                          \
        }                                                                                          \
        LEAVE                                                                                      \
    }
STATUS_GETTER(fmi2GetStatus, fmi2Status, "status", (fmi2Status)PyLong_AsLong(x))
STATUS_GETTER(fmi2GetRealStatus, fmi2Real, "real", PyFloat_AsDouble(x))
STATUS_GETTER(fmi2GetIntegerStatus, fmi2Integer, "integer", (fmi2Integer)PyLong_AsLong(x))
STATUS_GETTER(fmi2GetBooleanStatus, fmi2Boolean, "boolean", PyObject_IsTrue(x) > 0 ? fmi2True : fmi2False)

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String *v)
{
    ENTER
    PyObject *x = v ? status_value(I, (int)k, "string", "fmi2GetStringStatus", &s) : NULL;
    if (!v) { emitf(&I->cb, I->name, fmi2Error, "fmi2GetStringStatus: value is NULL"); s = fmi2Error; }
    if (x) {
        PyObject *str = PyObject_Str(x);
        Py_DECREF(x);
        if (str) {
            *v = PyUnicode_AsUTF8(str);
            Py_XSETREF(I->strings, str);
        } else {
            s = status_of(I, NULL, "fmi2GetStringStatus");
        }
    }
    LEAVE
}

/* ------------------------------------------------------------------------------ not offered */
#define NOT_OFFERED(fn, params, what)                                                              \
    fmi2Status fn params                                                                           \
    {                                                                                              \
        Instance *I = valid(c);                                                                    \
        if (I) emitf(&I->cb, I->name, fmi2Error, "%s: %s", #fn, what);                            \
        return fmi2Error;                                                                          \
    }
NOT_OFFERED(fmi2GetDirectionalDerivative,
            (fmi2Component c, const fmi2ValueReference u[], size_t nu, const fmi2ValueReference z[], size_t nz,
             const fmi2Real du[], fmi2Real dz[]),
            "not offered (providesDirectionalDerivative is false)")
NOT_OFFERED(fmi2SetRealInputDerivatives,
            (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], const fmi2Real v[]),
            "not offered (canInterpolateInputs is false)")

/* ------------------------------------------------------------------------------ FMI 3.0 extensions */
/* fmi2GetRealOutputDerivatives: the slave's fmi2_get_real_output_derivatives(vrs, orders) returns
 * (status, values). Only the FMI 3.0 binary reaches it (fmi3GetOutputDerivatives): the FMI 2.0
 * loader refuses it itself (maxOutputDerivativeOrder is 0 in the FMI 2.0 modelDescription). */
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer o[], fmi2Real v[])
{
    ENTER
    PyObject *vrs = PyTuple_New((Py_ssize_t)n), *ords = PyTuple_New((Py_ssize_t)n), *r = NULL;
    for (size_t i = 0; vrs && ords && i < n; i++) {
        PyTuple_SET_ITEM(vrs, (Py_ssize_t)i, PyLong_FromUnsignedLong(vr[i]));
        PyTuple_SET_ITEM(ords, (Py_ssize_t)i, PyLong_FromLong(o[i]));
    }
    if (vrs && ords && !PyErr_Occurred())
        r = PyObject_CallMethod(I->slave, "fmi2_get_real_output_derivatives", "OO", vrs, ords);
    Py_XDECREF(vrs);
    Py_XDECREF(ords);
    PyObject *st = NULL, *vals = NULL;
    if (r && PyArg_ParseTuple(r, "OO", &st, &vals)) {
        Py_INCREF(st);
        s = status_of(I, st, "fmi2GetRealOutputDerivatives");
        if (s <= fmi2Warning) {
            PyObject *seq = PySequence_Fast(vals, "the slave's derivatives are not a sequence");
            if (seq && (size_t)PySequence_Fast_GET_SIZE(seq) == n) {
                for (size_t i = 0; i < n; i++) v[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, (Py_ssize_t)i));
                if (PyErr_Occurred()) s = status_of(I, NULL, "fmi2GetRealOutputDerivatives");
            } else {
                if (seq) emitf(&I->cb, I->name, fmi2Error, "fmi2GetRealOutputDerivatives: the slave returned %zd "
                               "values for %zu references", PySequence_Fast_GET_SIZE(seq), n);
                s = seq ? fmi2Error : status_of(I, NULL, "fmi2GetRealOutputDerivatives");
            }
            Py_XDECREF(seq);
        }
    } else {
        s = status_of(I, NULL, "fmi2GetRealOutputDerivatives");
    }
    Py_XDECREF(r);
    LEAVE
}

/* spurdiffFork: the model processes' zygote (fmi2_server.c) forks each one here: os.fork() with the
 * GIL held (Python's own before- and after-fork handling). Before the first fork the objects made
 * so far (the package, imported once in the zygote) are collected and frozen (gc.freeze): the
 * children's collections never visit them, so their pages stay shared. The child's pid in the
 * zygote, 0 in the child, -1 when Python could not fork. */
long spurdiffFork(void)
{
    static int frozen;
    PyGILState_STATE g = PyGILState_Ensure();
    if (!frozen) {
        PyObject *gc = PyImport_ImportModule("gc");
        PyObject *a = gc ? PyObject_CallMethod(gc, "collect", NULL) : NULL;
        PyObject *b = a ? PyObject_CallMethod(gc, "freeze", NULL) : NULL;
        if (!b) PyErr_Clear();
        Py_XDECREF(a);
        Py_XDECREF(b);
        Py_XDECREF(gc);
        frozen = 1;
    }
    PyObject *os = PyImport_ImportModule("os");
    PyObject *r = os ? PyObject_CallMethod(os, "fork", NULL) : NULL;
    long pid = r ? PyLong_AsLong(r) : -1;
    if (!r || pid < 0) PyErr_Clear();
    Py_XDECREF(r);
    Py_XDECREF(os);
    PyGILState_Release(g);
    return pid;
}

/* spurdiffDoStepEarly: fmi2DoStep that may end early at a stick/slip transition (FMI 3.0
 * earlyReturnAllowed): the slave's fmi2_do_step_early(t, h, nsp) returns (status, end time). */
fmi2Status spurdiffDoStepEarly(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp, fmi2Real *end)
{
    Instance *I0 = valid(c);
    if (!I0) return fmi2Error;
    if (native_try(I0, t, h, 1)) {
        if (end) *end = t + h;
        return fmi2OK;
    }
    ENTER   /* (hands a native state back first) */
    PyObject *r = PyObject_CallMethod(I->slave, "fmi2_do_step_early", "ddO", t, h, nsp ? Py_True : Py_False);
    PyObject *st = NULL;
    double e = t;
    if (r && PyArg_ParseTuple(r, "Od", &st, &e)) {
        Py_INCREF(st);
        s = status_of(I, st, "fmi2DoStep");
        if (end) *end = e;
    } else {
        s = status_of(I, NULL, "fmi2DoStep");
    }
    Py_XDECREF(r);
    LEAVE
}
