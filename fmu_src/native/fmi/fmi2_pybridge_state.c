/* The bridge's FMU states (see fmi2_pybridge.c): get, set, free, serialize, deserialize. */
#include "fmi2_pybridge.h"

/* ------------------------------------------------------------------------------ FMU states */
static State *valid_state(Instance *I, fmi2FMUstate p)
{
    State *S = (State *)p;
    return (S && S->magic == STATE_MAGIC && S->owner == I) ? S : NULL;
}

static fmi2Status new_state(Instance *I, PyObject *obj, fmi2FMUstate *out, const char *fn)
{
    if (!obj) return status_of(I, NULL, fn);
    State *S = (State *)calloc(1, sizeof *S);
    if (!S) { Py_DECREF(obj); emitf(&I->cb, I->name, fmi2Error, "%s: out of memory", fn); return fmi2Error; }
    S->magic = STATE_MAGIC;
    S->owner = I;
    S->obj = obj;
    *out = S;
    return fmi2OK;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *p)
{
    ENTER
    if (!p) { emitf(&I->cb, I->name, fmi2Error, "fmi2GetFMUstate: FMUstate is NULL"); s = fmi2Error; LEAVE }
    PyObject *obj = PyObject_CallNoArgs(I->methods[M_GET_STATE]);
    State *S = *p ? valid_state(I, *p) : NULL;
    if (*p && !S) {
        Py_XDECREF(obj);
        emitf(&I->cb, I->name, fmi2Error, "fmi2GetFMUstate: *FMUstate is neither NULL nor a state of this instance");
        s = fmi2Error;
    } else if (S && obj) {          /* overwrite the given state (FMI 2.0 section 2.1.8) */
        Py_XSETREF(S->obj, obj);
        Py_CLEAR(S->bytes);
        s = fmi2OK;
    } else {
        s = new_state(I, obj, p, "fmi2GetFMUstate");
    }
    LEAVE
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate p)
{
    ENTER
    State *S = valid_state(I, p);
    if (!S) { emitf(&I->cb, I->name, fmi2Error, "fmi2SetFMUstate: not a state of this instance"); s = fmi2Error; }
    else s = status_of(I, PyObject_CallOneArg(I->methods[M_SET_STATE], S->obj), "fmi2SetFMUstate");
    LEAVE
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *p)
{
    ENTER
    if (!p || !*p) { s = fmi2OK; LEAVE }   /* freeing NULL is a no-op */
    State *S = valid_state(I, *p);
    if (!S) { emitf(&I->cb, I->name, fmi2Error, "fmi2FreeFMUstate: not a state of this instance"); s = fmi2Error; LEAVE }
    Py_CLEAR(S->obj);
    Py_CLEAR(S->bytes);
    S->magic = 0;
    free(S);
    *p = NULL;
    s = fmi2OK;
    LEAVE
}

static PyObject *state_bytes(Instance *I, State *S, const char *fn)
{
    if (!S->bytes) {
        PyObject *b = PyObject_CallOneArg(I->methods[M_SERIALIZE_STATE], S->obj);
        if (b && !PyBytes_Check(b)) {
            Py_DECREF(b);
            PyErr_SetString(PyExc_TypeError, "the slave's serialization is not bytes");
            b = NULL;
        }
        if (!b) { status_of(I, NULL, fn); return NULL; }
        S->bytes = b;
    }
    return S->bytes;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate p, size_t *n)
{
    ENTER
    State *S = valid_state(I, p);
    PyObject *b = (S && n) ? state_bytes(I, S, "fmi2SerializedFMUstateSize") : NULL;
    if (!S || !n) emitf(&I->cb, I->name, fmi2Error, "fmi2SerializedFMUstateSize: not a state of this instance");
    if (b) { *n = (size_t)PyBytes_GET_SIZE(b); s = fmi2OK; } else s = fmi2Error;
    LEAVE
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate p, fmi2Byte out[], size_t n)
{
    ENTER
    State *S = valid_state(I, p);
    PyObject *b = (S && out) ? state_bytes(I, S, "fmi2SerializeFMUstate") : NULL;
    if (!S || !out) emitf(&I->cb, I->name, fmi2Error, "fmi2SerializeFMUstate: not a state of this instance");
    if (b && (size_t)PyBytes_GET_SIZE(b) != n) {
        emitf(&I->cb, I->name, fmi2Error, "fmi2SerializeFMUstate: size %zu given, fmi2SerializedFMUstateSize "
              "said %zd", n, PyBytes_GET_SIZE(b));
        b = NULL;
    }
    if (b) { memcpy(out, PyBytes_AS_STRING(b), n); s = fmi2OK; } else s = fmi2Error;
    LEAVE
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte in[], size_t n, fmi2FMUstate *p)
{
    ENTER
    if (!p || (n && !in)) {
        emitf(&I->cb, I->name, fmi2Error, "fmi2DeSerializeFMUstate: NULL argument");
        s = fmi2Error;
        LEAVE
    }
    PyObject *b = PyBytes_FromStringAndSize((const char *)in, (Py_ssize_t)n);
    PyObject *obj = b ? PyObject_CallOneArg(I->methods[M_DESERIALIZE_STATE], b) : NULL;
    Py_XDECREF(b);
    s = new_state(I, obj, p, "fmi2DeSerializeFMUstate");
    LEAVE
}
