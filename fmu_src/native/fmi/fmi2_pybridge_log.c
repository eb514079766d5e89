/* The bridge's messages to the host (see fmi2_pybridge.c): the logger's calls, the slave's log
 * queue, a Python exception as text and as the call's status. */
#include "fmi2_pybridge.h"
#include "log_text.h"

/* ------------------------------------------------------------------------------ logging */
/* The message goes to the host as the logger's format with no arguments, every '%' doubled: a
 * host that formats it (FMI 2.0 section 2.1.5) prints the text as it is, and so does one that
 * cannot handle variadic arguments and reads the format itself (fmpy). */
BRIDGE_INTERNAL void emit(const fmi2CallbackFunctions *cb, const char *name, fmi2Status status,
                 const char *category, const char *msg)
{
    log_text(cb, name, status, category ? category : "logAll", msg);
}

BRIDGE_INTERNAL void emitf(const fmi2CallbackFunctions *cb, const char *name, fmi2Status status, const char *fmt, ...)
{
    char msg[8192];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    emit(cb, name, status, status >= fmi2Error ? "logStatusError" : "logAll", msg);
}

/* The pending Python exception as "Type: message" (cleared). */
BRIDGE_INTERNAL void exception_text(char *out, size_t size)
{
    PyObject *type, *value, *tb;
    PyErr_Fetch(&type, &value, &tb);
    PyErr_NormalizeException(&type, &value, &tb);
    const char *tname = type ? ((PyTypeObject *)type)->tp_name : "Error";
    PyObject *s = value ? PyObject_Str(value) : NULL;
    const char *text = s ? PyUnicode_AsUTF8(s) : NULL;
    if (!text) { PyErr_Clear(); text = "(no message)"; }
    snprintf(out, size, "%s: %s", tname, text);
    Py_XDECREF(s);
    Py_XDECREF(type);
    Py_XDECREF(value);
    Py_XDECREF(tb);
}

/* Pass the slave's queued messages to the host (GIL held). */
BRIDGE_INTERNAL void flush_log(Instance *I)
{
    if (!I->log_queue || !PyList_Check(I->log_queue)) return;
    Py_ssize_t n = PyList_GET_SIZE(I->log_queue);
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *m = PyList_GET_ITEM(I->log_queue, i);
        PyObject *st = PyObject_GetAttrString(m, "status");
        PyObject *cat = PyObject_GetAttrString(m, "category");
        PyObject *msg = PyObject_GetAttrString(m, "msg");
        long status = st ? PyLong_AsLong(st) : fmi2Error;
        const char *c = (cat && PyUnicode_Check(cat)) ? PyUnicode_AsUTF8(cat) : "logAll";
        PyObject *ms = msg ? PyObject_Str(msg) : NULL;
        const char *text = ms ? PyUnicode_AsUTF8(ms) : NULL;
        if (PyErr_Occurred()) PyErr_Clear();
        if (status < fmi2OK || status > fmi2Fatal) status = fmi2Error;
        if (text && (status != fmi2OK || I->logging_on))
            emit(&I->cb, I->name, (fmi2Status)status, c ? c : "logAll", text);
        Py_XDECREF(st);
        Py_XDECREF(cat);
        Py_XDECREF(msg);
        Py_XDECREF(ms);
    }
    if (n) PyList_SetSlice(I->log_queue, 0, n, NULL);
}

/* The status a slave method returned (reference stolen), or fmi2Error with the exception logged. */
BRIDGE_INTERNAL fmi2Status status_of(Instance *I, PyObject *r, const char *fn)
{
    if (!r) {
        char text[4096];
        exception_text(text, sizeof text);
        flush_log(I);
        emitf(&I->cb, I->name, fmi2Error, "%s failed: %s", fn, text);
        return fmi2Error;
    }
    fmi2Status s = fmi2OK;
    if (r != Py_None) {
        long v = PyLong_AsLong(r);
        if (v == -1 && PyErr_Occurred()) {
            PyErr_Clear();
            emitf(&I->cb, I->name, fmi2Error, "%s: the slave returned a status that is not an integer", fn);
            s = fmi2Error;
        } else if (v < fmi2OK || v > fmi2Error) {   /* a slave never ends the process's simulation: no fatal */
            s = fmi2Error;
        } else {
            s = (fmi2Status)v;
        }
    }
    Py_DECREF(r);
    return s;
}
