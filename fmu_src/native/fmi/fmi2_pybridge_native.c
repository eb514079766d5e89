/* The bridge's calls that do not enter the slave's Python (see fmi2_pybridge.c): the fast Real get/set
 * on the slave's value table while it steps, and the native step (a model whose whole communication
 * step is compiled steps here without Python: its plan, entering and leaving it, the step, the
 * getters' and setters' slots). */
#include "fmi2_pybridge.h"

/* ------------------------------------------------------------------------------ fast Real get/set
 * While the slave steps (its `phase` is "stepping"), fmi2GetReal and fmi2SetReal read and store
 * the slave's value table (`values`, a dict) here, by the names its fmi2_real_plan gave once per
 * value-reference vector, as its fmi2_get_real and fmi2_set_real do in that phase (no Python call
 * per value vector). A setter checks each value against its range (an input's declared range)
 * and for one outside it (NaN too) clears the slave's `_inputs_ok`: its next fmi2DoStep then
 * checks every input and refuses naming the bad one. Anything else (another phase, a vector
 * without a plan, a value table that is not a dict) takes the slave's methods. */
static PyObject *S_phase, *S_stepping, *S_values, *S_inputs_ok, *S_plan;

static int fast_strings(void)
{
    if (S_plan) return 0;
    S_phase = PyUnicode_InternFromString("phase");
    S_stepping = PyUnicode_InternFromString("stepping");
    S_values = PyUnicode_InternFromString("values");
    S_inputs_ok = PyUnicode_InternFromString("_inputs_ok");
    PyObject *plan = PyUnicode_InternFromString("fmi2_real_plan");
    if (!S_phase || !S_stepping || !S_values || !S_inputs_ok || !plan) { Py_XDECREF(plan); return -1; }
    S_plan = plan;
    return 0;
}

/* The slave's value table when it steps (new reference), else NULL (no error set). */
static PyObject *stepping_values(Instance *I)
{
    if (fast_strings() != 0) { PyErr_Clear(); return NULL; }
    PyObject *phase = PyObject_GetAttr(I->slave, S_phase);
    int stepping = phase && (phase == S_stepping ||
                             (PyUnicode_CheckExact(phase) && PyUnicode_Compare(phase, S_stepping) == 0));
    Py_XDECREF(phase);
    PyObject *values = stepping ? PyObject_GetAttr(I->slave, S_values) : NULL;
    if (values && !PyDict_CheckExact(values)) Py_CLEAR(values);
    if (PyErr_Occurred()) PyErr_Clear();
    return values;
}

/* Ask the slave for the plan of entry e once: e->names a tuple of n str (and for a setter the
 * ranges filled), or Py_None. 1 when there is a fast path. */
BRIDGE_INTERNAL int plan_of(Instance *I, VrEntry *e, int write)
{
    if (e->names) return e->names != Py_None;
    PyObject *r = fast_strings() == 0 ? PyObject_CallMethodObjArgs(I->slave, S_plan, e->tuple,
                                                                    write ? Py_True : Py_False, NULL) : NULL;
    PyObject *names = NULL;
    size_t n = e->n;
    if (r && PyTuple_Check(r) && PyTuple_GET_SIZE(r) == 3) {
        PyObject *nm = PyTuple_GET_ITEM(r, 0), *lo = PyTuple_GET_ITEM(r, 1), *hi = PyTuple_GET_ITEM(r, 2);
        int ok = PyTuple_CheckExact(nm) && (size_t)PyTuple_GET_SIZE(nm) == n;
        for (size_t i = 0; ok && i < n; i++) ok = PyUnicode_CheckExact(PyTuple_GET_ITEM(nm, (Py_ssize_t)i));
        if (ok && write) {
            ok = PyTuple_Check(lo) && PyTuple_Check(hi) && (size_t)PyTuple_GET_SIZE(lo) == n
                 && (size_t)PyTuple_GET_SIZE(hi) == n;
            double *l = ok ? (double *)malloc((n ? n : 1) * sizeof *l) : NULL;
            double *h = ok ? (double *)malloc((n ? n : 1) * sizeof *h) : NULL;
            ok = l && h;
            for (size_t i = 0; ok && i < n; i++) {
                l[i] = PyFloat_AsDouble(PyTuple_GET_ITEM(lo, (Py_ssize_t)i));
                h[i] = PyFloat_AsDouble(PyTuple_GET_ITEM(hi, (Py_ssize_t)i));
                ok = !PyErr_Occurred();
            }
            if (ok) { free(e->lo); free(e->hi); e->lo = l; e->hi = h; }
            else { free(l); free(h); }
        }
        if (ok) { names = nm; Py_INCREF(names); }
    }
    if (PyErr_Occurred()) PyErr_Clear();   /* an unknown reference: the slave's method reports it */
    Py_XDECREF(r);
    if (!names) { names = Py_None; Py_INCREF(names); }
    e->names = names;
    return names != Py_None;
}

/* fmi2GetReal by the plan: 1 done, 0 take the slave's method (no error set). */
BRIDGE_INTERNAL int fast_get_real(Instance *I, const fmi2ValueReference vr[], size_t n, fmi2Real v[])
{
    PyObject *values = stepping_values(I);
    if (!values) return 0;
    VrEntry *e = vr_entry(I, M_GET_REAL, vr, n);
    int done = e && plan_of(I, e, 0);
    for (size_t i = 0; done && i < n; i++) {
        PyObject *x = PyDict_GetItemWithError(values, PyTuple_GET_ITEM(e->names, (Py_ssize_t)i));   /* borrowed */
        if (!x) { done = 0; break; }
        double d = PyFloat_CheckExact(x) ? PyFloat_AS_DOUBLE(x) : PyFloat_AsDouble(x);
        if (d == -1.0 && PyErr_Occurred()) { done = 0; break; }
        v[i] = d;
    }
    if (PyErr_Occurred()) PyErr_Clear();
    Py_DECREF(values);
    return done;
}

/* fmi2SetReal by the plan: 1 done (status in *s), 0 take the slave's method (nothing stored). */
BRIDGE_INTERNAL int fast_set_real(Instance *I, const fmi2ValueReference vr[], size_t n, const fmi2Real v[], fmi2Status *s)
{
    PyObject *values = stepping_values(I);
    if (!values) return 0;
    VrEntry *e = vr_entry(I, M_SET_REAL, vr, n);
    if (!e || !plan_of(I, e, 1)) {
        if (PyErr_Occurred()) PyErr_Clear();
        Py_DECREF(values);
        return 0;
    }
    int in_range = 1, failed = 0;
    for (size_t i = 0; i < n; i++) {
        PyObject *x = PyFloat_FromDouble(v[i]);
        if (!x || PyDict_SetItem(values, PyTuple_GET_ITEM(e->names, (Py_ssize_t)i), x) != 0) {
            Py_XDECREF(x);
            failed = 1;
            break;
        }
        Py_DECREF(x);
        if (!(e->lo[i] <= v[i] && v[i] <= e->hi[i])) in_range = 0;   /* NaN too */
    }
    Py_DECREF(values);
    if (!failed && !in_range && PyObject_SetAttr(I->slave, S_inputs_ok, Py_False) != 0) failed = 1;
    *s = failed ? status_of(I, NULL, "fmi2SetReal") : fmi2OK;
    return 1;
}

/* ------------------------------------------------------------------------------ native step
 * The slave's fmi2_native_enter() (GIL held) answers False (no native step for this slave: never
 * asked again until fmi2Reset), None (not now: not stepping, inputs unchecked...), or
 * (time, stop, stop_tol, plan, parameters) having written its model's state into the plan's
 * array; plan is (function, constants, array, names, n_in, parameter names, integers, early): the addresses of
 * int64_t function(const double *constants, double *array, double t, double h) (0: the step is
 * taken, its outputs in the array; else nothing but scratch changed) and of the two arrays, the
 * value-table name (or None) of each slot, the first n_in slots the inputs, and the names of the
 * Real parameters, whose values (parameters, a tuple) fmi2GetReal reads here too (a parameter set
 * while stepping goes through the slave: the state is handed back first), and the Integer
 * outputs the array holds as (value reference, slot, ...) pairs (fmi2GetInteger reads them there,
 * each value an integer stored as a double), and whether the model may end a step early (then
 * spurdiffDoStepEarly, FMI 3.0's step with early return allowed, leaves the state to the slave). The same plan object
 * while the slave's model is the same; a new one makes the value-reference slots be looked up
 * again. fmi2_native_leave(time, bad, steps) takes the state back into the slave (its value table,
 * its model, its time; bad: an input outside its range was stored since).
 * While on, fmi2DoStep checks what the adapter checks first (a positive finite step, the FMU's
 * time, the stop time; spurdiff/fmi/adapter.py, fmi2_do_step) and calls the function without the
 * GIL; fmi2SetReal and fmi2GetReal of vectors whose every value has a slot (a setter: an input
 * slot) store and read the array (a setter checks the declared ranges as the fast path above). */
BRIDGE_INTERNAL void native_drop(Instance *I)
{
    Py_CLEAR(I->nat.plan);
    Py_CLEAR(I->nat.names);
    Py_CLEAR(I->nat.cnames);
    free(I->nat.cv);
    free(I->nat.ivr);
    I->nat.cv = NULL;
    I->nat.ivr = NULL;
    I->nat.n_int = 0;
    I->nat.on = I->nat.bad = 0;
    I->nat.never = 0;
    I->nat.fn = NULL;
    I->nat.ctx = NULL;
    I->nat.v = NULL;
}

/* Take the plan tuple (GIL held): 0, or -1 (not usable: the slave's path). */
static int native_take_plan(Instance *I, PyObject *plan)
{
    if (plan == I->nat.plan) return 0;
    unsigned long long fn, ctx, v;
    PyObject *names, *cnames, *ints;
    Py_ssize_t n_in;
    int early;
    if (!PyTuple_Check(plan)
        || !PyArg_ParseTuple(plan, "KKKO!nO!O!p", &fn, &ctx, &v, &PyTuple_Type, &names, &n_in, &PyTuple_Type, &cnames,
                             &PyTuple_Type, &ints, &early)
        || !fn || !v || n_in < 0 || n_in > PyTuple_GET_SIZE(names) || PyTuple_GET_SIZE(ints) % 2) {
        PyErr_Clear();
        return -1;
    }
    Py_ssize_t n_ints = PyTuple_GET_SIZE(ints);
    double *cv = (double *)calloc((size_t)PyTuple_GET_SIZE(cnames) + 1, sizeof *cv);
    unsigned *ivr = (unsigned *)calloc((size_t)n_ints + 1, sizeof *ivr);
    for (Py_ssize_t j = 0; cv && ivr && j < n_ints; j++) ivr[j] = (unsigned)PyLong_AsUnsignedLong(PyTuple_GET_ITEM(ints, j));
    if (!cv || !ivr || PyErr_Occurred()) {
        PyErr_Clear();
        free(cv);
        free(ivr);
        return -1;
    }
    free(I->nat.cv);
    free(I->nat.ivr);
    I->nat.cv = cv;
    I->nat.ivr = ivr;
    I->nat.n_int = n_ints / 2;
    I->nat.early = early;
    Py_INCREF(plan);
    Py_INCREF(names);
    Py_INCREF(cnames);
    Py_XSETREF(I->nat.plan, plan);
    Py_XSETREF(I->nat.names, names);
    I->nat.gen++;
    Py_XSETREF(I->nat.cnames, cnames);
    I->nat.fn = (int64_t (*)(const double *, double *, double, double))(uintptr_t)fn;
    I->nat.ctx = (const double *)(uintptr_t)ctx;
    I->nat.v = (double *)(uintptr_t)v;
    I->nat.n_in = n_in;
    return 0;
}

/* Hand the state to the array (GIL held): 1 on, 0 not (the slave's path; no error set). */
static int native_enter(Instance *I)
{
    if (I->nat.never || !I->slave) return 0;
    PyObject *r = PyObject_CallMethod(I->slave, "fmi2_native_enter", NULL);
    int on = 0;
    if (r == Py_False) {
        I->nat.never = 1;
    } else if (r && r != Py_None) {
        PyObject *plan = NULL, *pv = NULL;
        double t, stop, tol;
        int ok = PyArg_ParseTuple(r, "dddOO!", &t, &stop, &tol, &plan, &PyTuple_Type, &pv) && native_take_plan(I, plan) == 0
                 && PyTuple_GET_SIZE(pv) == PyTuple_GET_SIZE(I->nat.cnames);
        for (Py_ssize_t j = 0; ok && j < PyTuple_GET_SIZE(pv); j++) {
            I->nat.cv[j] = PyFloat_AsDouble(PyTuple_GET_ITEM(pv, j));
            ok = !PyErr_Occurred();
        }
        if (ok) {
            I->nat.time = t;
            I->nat.stop = stop;
            I->nat.stop_tol = tol;
            I->nat.bad = 0;
            I->nat.steps = 0;
            I->nat.on = on = 1;
        } else {
            I->nat.never = 1;   /* a plan the bridge cannot take: the slave's path from now on */
        }
    }
    if (!r || PyErr_Occurred()) {   /* a slave without the method (not ours) or a failure: never */
        PyErr_Clear();
        I->nat.never = 1;
    }
    Py_XDECREF(r);
    return on;
}

/* Take the state back into the slave (GIL held): 0, or -1 (logged; the slave's state is then
 * its own as before the native steps: it reports the failure). */
BRIDGE_INTERNAL int native_leave(Instance *I)
{
    if (!I->nat.on) return 0;
    I->nat.on = 0;
    PyObject *r = PyObject_CallMethod(I->slave, "fmi2_native_leave", "dil", I->nat.time, I->nat.bad, I->nat.steps);
    I->nat.bad = 0;
    if (!r) {
        status_of(I, NULL, "taking the native step's state back");
        return -1;
    }
    Py_DECREF(r);
    return 0;
}

/* The step by the function (no GIL needed: the array only): 1 taken, 0 not (nothing changed). */
static int native_step(Instance *I, double t, double h)
{
    if (I->nat.bad || !(h > 0.0 && h < INFINITY)) return 0;
    double at = t >= 0.0 ? t : -t;
    if (!(fabs(t - I->nat.time) <= 1e-9 * (at > 1.0 ? at : 1.0) + 1e-6 * h) || at == INFINITY) return 0;
    if (t + h > I->nat.stop + (I->nat.stop_tol + 1e-6 * h)) return 0;
    if (I->nat.fn(I->nat.ctx, I->nat.v, t, h) != 0) return 0;
    I->nat.time = t + h;
    I->nat.steps++;
    return 1;
}

/* The step natively, the native step entered first if the instance has none yet (and may have one):
 * 1 taken, 0 not (the slave's path). ``early``: the host allows the step to end early (FMI 3.0), and a
 * model that may end a step early then steps in Python, so that none is skipped (the plan says which). */
BRIDGE_INTERNAL int native_try(Instance *I, double t, double h, int early)
{
    if (I->nat.on) return !(early && I->nat.early) && native_step(I, t, h);
    if (I->nat.never) return 0;
    PyGILState_STATE g = PyGILState_Ensure();
    int taken = native_enter(I) && !(early && I->nat.early) && native_step(I, t, h);
    flush_log(I);
    PyGILState_Release(g);
    return taken;
}

/* The slots of the entry's values (GIL held for a new entry): the entry, or NULL (the slave's
 * path). A setter's values must all be inputs. */
static VrEntry *native_slots(Instance *I, int method, const fmi2ValueReference vr[], size_t n)
{
    VrCache *c = &I->vrc[method];
    for (int k = 0; k < VR_SLOTS; k++) {   /* the hot path: a vector seen before, no Python */
        VrEntry *e = &c->e[k];
        if (e->tuple && e->n == n && e->pos_plan == I->nat.gen && (n == 0 || memcmp(e->vr, vr, n * sizeof *vr) == 0))
            return e->pos_state == 1 ? e : NULL;
    }
    PyGILState_STATE g = PyGILState_Ensure();
    int write = method == M_SET_REAL;
    VrEntry *e = vr_entry(I, method, vr, n);
    if (e && plan_of(I, e, write)) {
        int *pos = (int *)malloc((n ? n : 1) * sizeof *pos);
        Py_ssize_t slots = write ? I->nat.n_in : PyTuple_GET_SIZE(I->nat.names);
        Py_ssize_t consts = write ? 0 : PyTuple_GET_SIZE(I->nat.cnames);
        int ok = pos != NULL;
        for (size_t i = 0; ok && i < n; i++) {
            PyObject *name = PyTuple_GET_ITEM(e->names, (Py_ssize_t)i);
            pos[i] = -1;   /* a slot j as j, a parameter j as -2 - j */
            for (Py_ssize_t j = 0; j < slots; j++) {
                PyObject *x = PyTuple_GET_ITEM(I->nat.names, j);
                if (PyUnicode_Check(x) && PyUnicode_Compare(x, name) == 0) { pos[i] = (int)j; break; }
            }
            for (Py_ssize_t j = 0; pos[i] == -1 && j < consts; j++)
                if (PyUnicode_Compare(PyTuple_GET_ITEM(I->nat.cnames, j), name) == 0) pos[i] = -2 - (int)j;
            ok = pos[i] != -1;
        }
        free(e->pos);
        e->pos = pos;
        e->pos_state = ok ? 1 : -1;
        e->pos_plan = I->nat.gen;
    } else if (e) {
        e->pos_state = -1;
        e->pos_plan = I->nat.gen;
    }
    if (PyErr_Occurred()) PyErr_Clear();
    PyGILState_Release(g);
    return (e && e->pos_state == 1) ? e : NULL;
}

BRIDGE_INTERNAL int native_get_real(Instance *I, const fmi2ValueReference vr[], size_t n, fmi2Real v[])
{
    VrEntry *e = native_slots(I, M_GET_REAL, vr, n);
    if (!e) return 0;
    for (size_t i = 0; i < n; i++) {
        int p = e->pos[i];
        v[i] = p >= 0 ? I->nat.v[p] : I->nat.cv[-2 - p];
    }
    return 1;
}

/* fmi2GetInteger of Integer outputs the array holds (no GIL needed): 1 done, 0 the slave's path. */
BRIDGE_INTERNAL int native_get_integer(Instance *I, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
{
    for (size_t i = 0; i < n; i++) {
        Py_ssize_t j = 0;
        while (j < I->nat.n_int && I->nat.ivr[2 * j] != vr[i]) j++;
        if (j == I->nat.n_int) return 0;
        v[i] = (fmi2Integer)I->nat.v[I->nat.ivr[2 * j + 1]];
    }
    return 1;
}

BRIDGE_INTERNAL int native_set_real(Instance *I, const fmi2ValueReference vr[], size_t n, const fmi2Real v[])
{
    VrEntry *e = native_slots(I, M_SET_REAL, vr, n);
    if (!e) return 0;
    for (size_t i = 0; i < n; i++) {
        I->nat.v[e->pos[i]] = v[i];
        if (!(e->lo[i] <= v[i] && v[i] <= e->hi[i])) I->nat.bad = 1;   /* NaN too */
    }
    return 1;
}

/* ------------------------------------------------------------------------------ the hand-over
 * The model in its own process (fmi2_server.c) hands its compiled step to the host's process
 * (fmi2_loader.c steps it there, native_start.c: ns_open_live) and takes it back before any call the
 * host does not answer there: spurdiffNativeExport asks the slave's fmi2_native_export() (bytes, False
 * or None; a native state here is taken back first), spurdiffNativeImport hands the arrays to its
 * fmi2_native_import(data, time, bad, steps). */
/* A slave's answer of bytes (GIL held): 1 and a copy in *bytes (malloc'd, *len), 0 for None, -1 else. */
static int bytes_of(PyObject *r, unsigned char **bytes, size_t *len)
{
    if (r == Py_None) return 0;
    if (!r || !PyBytes_Check(r)) return -1;
    size_t n = (size_t)PyBytes_GET_SIZE(r);
    if (!(*bytes = (unsigned char *)malloc(n ? n : 1))) return -1;
    memcpy(*bytes, PyBytes_AS_STRING(r), n);
    *len = n;
    return 1;
}

int spurdiffNativeExport(fmi2Component c, unsigned char **bytes, size_t *len)
{
    *bytes = NULL;
    *len = 0;
    Instance *I = valid(c);
    if (!I) return -1;
    PyGILState_STATE g = PyGILState_Ensure();
    int kind = -1;
    if (!I->nat.on || native_leave(I) == 0) {
        PyObject *r = PyObject_CallMethod(I->slave, "fmi2_native_export", NULL);
        kind = bytes_of(r, bytes, len);
        if (!r) {   /* a failure: said once, and the model's process steps from now on */
            char text[4096];
            exception_text(text, sizeof text);
            emitf(&I->cb, I->name, fmi2Warning, "the compiled step stays in the model's process: %s", text);
        }
        Py_XDECREF(r);
    }
    if (PyErr_Occurred()) PyErr_Clear();
    flush_log(I);
    PyGILState_Release(g);
    return kind;
}

fmi2Status spurdiffNativeImport(fmi2Component c, const double *arrays, size_t n, double time, int bad, long steps)
{
    ENTER
    PyObject *data = PyBytes_FromStringAndSize((const char *)arrays, (Py_ssize_t)(n * sizeof *arrays));
    PyObject *r = data ? PyObject_CallMethod(I->slave, "fmi2_native_import", "Odil", data, time, bad, steps) : NULL;
    Py_XDECREF(data);
    s = status_of(I, r, "taking the compiled step's state back from the host's process");
    LEAVE
}

/* ------------------------------------------------------------------------------ the start cache
 * The slave's fmi2_start_snapshot(sets) (bytes or None): the native start of its FMU class with the
 * values `sets` set (the loader's encoding, fmi2_loader.c: keep_start), made in fresh probe instances as
 * the build makes native_start.bin. Nothing is said to the host: a failure only means no cache file. */
int spurdiffStartSnapshot(fmi2Component c, const unsigned char *sets, size_t n, unsigned char **bytes, size_t *len)
{
    *bytes = NULL;
    *len = 0;
    Instance *I = valid(c);
    if (!I) return -1;
    PyGILState_STATE g = PyGILState_Ensure();
    int kind = -1;
    PyObject *data = PyBytes_FromStringAndSize((const char *)sets, (Py_ssize_t)n);
    PyObject *r = data ? PyObject_CallMethod(I->slave, "fmi2_start_snapshot", "O", data) : NULL;
    Py_XDECREF(data);
    kind = bytes_of(r, bytes, len);
    Py_XDECREF(r);
    if (PyErr_Occurred()) PyErr_Clear();
    PyGILState_Release(g);
    return kind;
}
