/* What the bridge's files share (fmi2_pybridge.c: the interpreter, the instances and the calls;
 * fmi2_pybridge_native.c: the native step; fmi2_pybridge_state.c: FMU states; fmi2_pybridge_log.c:
 * the messages to the host): the renamed FMI functions, the instance and its caches. */
#ifndef SPURDIFF_FMI2_PYBRIDGE_H
#define SPURDIFF_FMI2_PYBRIDGE_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <pthread.h>
#include <stdarg.h>

#include "fmi2Functions.h"
#include "runtime_cfg.h"

/* every function defined here carries the prefix the loader looks for */
#define fmi2SetDebugLogging spurdiff_bridge_fmi2SetDebugLogging
#define fmi2Instantiate spurdiff_bridge_fmi2Instantiate
#define fmi2FreeInstance spurdiff_bridge_fmi2FreeInstance
#define fmi2SetupExperiment spurdiff_bridge_fmi2SetupExperiment
#define fmi2EnterInitializationMode spurdiff_bridge_fmi2EnterInitializationMode
#define fmi2ExitInitializationMode spurdiff_bridge_fmi2ExitInitializationMode
#define fmi2Terminate spurdiff_bridge_fmi2Terminate
#define fmi2Reset spurdiff_bridge_fmi2Reset
#define fmi2GetReal spurdiff_bridge_fmi2GetReal
#define fmi2GetInteger spurdiff_bridge_fmi2GetInteger
#define fmi2GetBoolean spurdiff_bridge_fmi2GetBoolean
#define fmi2GetString spurdiff_bridge_fmi2GetString
#define fmi2SetReal spurdiff_bridge_fmi2SetReal
#define fmi2SetInteger spurdiff_bridge_fmi2SetInteger
#define fmi2SetBoolean spurdiff_bridge_fmi2SetBoolean
#define fmi2SetString spurdiff_bridge_fmi2SetString
#define fmi2GetFMUstate spurdiff_bridge_fmi2GetFMUstate
#define fmi2SetFMUstate spurdiff_bridge_fmi2SetFMUstate
#define fmi2FreeFMUstate spurdiff_bridge_fmi2FreeFMUstate
#define fmi2SerializedFMUstateSize spurdiff_bridge_fmi2SerializedFMUstateSize
#define fmi2SerializeFMUstate spurdiff_bridge_fmi2SerializeFMUstate
#define fmi2DeSerializeFMUstate spurdiff_bridge_fmi2DeSerializeFMUstate
#define fmi2GetDirectionalDerivative spurdiff_bridge_fmi2GetDirectionalDerivative
#define fmi2SetRealInputDerivatives spurdiff_bridge_fmi2SetRealInputDerivatives
#define fmi2GetRealOutputDerivatives spurdiff_bridge_fmi2GetRealOutputDerivatives
#define fmi2DoStep spurdiff_bridge_fmi2DoStep
#define fmi2CancelStep spurdiff_bridge_fmi2CancelStep
#define fmi2GetStatus spurdiff_bridge_fmi2GetStatus
#define fmi2GetRealStatus spurdiff_bridge_fmi2GetRealStatus
#define fmi2GetIntegerStatus spurdiff_bridge_fmi2GetIntegerStatus
#define fmi2GetBooleanStatus spurdiff_bridge_fmi2GetBooleanStatus
#define fmi2GetStringStatus spurdiff_bridge_fmi2GetStringStatus
#define spurdiffDoStepEarly spurdiff_bridge_spurdiffDoStepEarly
#define spurdiffNativeExport spurdiff_bridge_spurdiffNativeExport
#define spurdiffNativeImport spurdiff_bridge_spurdiffNativeImport
#define spurdiffStartSnapshot spurdiff_bridge_spurdiffStartSnapshot
#define spurdiffFork spurdiff_bridge_spurdiffFork

#define INSTANCE_MAGIC 0x5350444Du  /* "SPDM" */
#define STATE_MAGIC 0x53544154u     /* "STAT" */

enum {
    M_SET_DEBUG_LOGGING, M_SETUP_EXPERIMENT, M_ENTER_INIT, M_EXIT_INIT, M_TERMINATE,
    M_GET_REAL, M_GET_INTEGER, M_GET_BOOLEAN, M_GET_STRING,
    M_SET_REAL, M_SET_INTEGER, M_SET_BOOLEAN, M_SET_STRING,
    M_GET_STATE, M_SET_STATE, M_SERIALIZE_STATE, M_DESERIALIZE_STATE,
    M_DO_STEP, M_CANCEL_STEP, M_GET_STATUS, N_METHODS
};
extern const char *const METHOD_NAMES[N_METHODS];


/* The last value-reference vectors (VR_SLOTS per method) a getter or setter was called with, the
 * Python tuple made of each, and for fmi2GetReal / fmi2SetReal the slave's plan of the fast path
 * (fmi2_real_plan: the names of the variables in the slave's value table, for a setter the range
 * of each value): a master calls with the same few vectors every step, so the tuple and the plan
 * are made once and the slave's caches keyed on the tuple (spurdiff/fmi/adapter.py) hit. */
#define VR_SLOTS 4
typedef struct {
    fmi2ValueReference *vr;
    size_t n;
    PyObject *tuple;
    PyObject *names;          /* fast path: tuple of str; Py_None: none; NULL: not asked yet */
    double *lo, *hi;          /* setter: the accepted range of each value */
    int *pos;                 /* native step: the slot of each value in the plan's array */
    int pos_state;            /* 0 not asked, 1 every value has a slot, -1 not all (the slave's path) */
    unsigned long pos_plan;   /* the plan the slots are of (its number, nat.gen) */
} VrEntry;

typedef struct {
    VrEntry e[VR_SLOTS];
    int next;                 /* the slot a new vector replaces */
} VrCache;

typedef struct {
    unsigned magic;
    char *name;
    char *resources;
    fmi2CallbackFunctions cb;
    int logging_on;
    int visible;
    PyObject *klass;          /* the slave class (kept for fmi2Reset) */
    PyObject *alias;          /* the private name of the FMU's package (str) */
    PyObject *slave;          /* the slave object */
    PyObject *log_queue;      /* slave.log_queue */
    PyObject *methods[N_METHODS];
    PyObject *strings;        /* keeps the buffers of the last fmi2GetString alive */
    VrCache vrc[N_METHODS];   /* per getter/setter method */
    struct {                  /* the native step (see the native section) */
        int never;            /* the slave has none (asked once per slave) */
        int on;               /* the model's state is in v, not in the slave */
        int bad;              /* an input outside its range was stored while on */
        long steps;           /* the steps taken while on */
        int64_t (*fn)(const double *, double *, double, double);
        const double *ctx;
        double *v;
        PyObject *plan;       /* the slave's plan tuple (keeps the arrays alive), NULL: none */
        unsigned long gen;    /* the number of the plan taken (a new plan: the slots looked up again) */
        PyObject *names;      /* the slots' value-table names (str or None) */
        Py_ssize_t n_in;      /* the first n_in slots are the inputs */
        PyObject *cnames;     /* the Real parameters' names: constant while stepping natively */
        double *cv;           /* their values (read by fmi2GetReal from here) */
        unsigned *ivr;        /* the Integer outputs' value references and slots, in pairs */
        int early;            /* the model may end a step early (FMI 3.0): that step stays in Python */
        Py_ssize_t n_int;     /* the number of pairs */
        double time, stop, stop_tol;
    } nat;
} Instance;


typedef struct {
    unsigned magic;
    Instance *owner;
    PyObject *obj;            /* the slave's state object */
    PyObject *bytes;          /* its serialization, once asked for */
} State;

/* what the bridge's files share (hidden: never exported, never a host's symbol) */
#ifdef _WIN32
#define BRIDGE_INTERNAL
#else
#define BRIDGE_INTERNAL __attribute__((visibility("hidden")))
#endif
/* fmi2_pybridge_log.c */
BRIDGE_INTERNAL void emit(const fmi2CallbackFunctions *cb, const char *name, fmi2Status status, const char *category,
                          const char *msg);
BRIDGE_INTERNAL void emitf(const fmi2CallbackFunctions *cb, const char *name, fmi2Status status, const char *fmt, ...);
BRIDGE_INTERNAL void exception_text(char *out, size_t size);
BRIDGE_INTERNAL void flush_log(Instance *I);
BRIDGE_INTERNAL fmi2Status status_of(Instance *I, PyObject *r, const char *fn);
/* fmi2_pybridge.c */
BRIDGE_INTERNAL Instance *valid(fmi2Component c);
BRIDGE_INTERNAL VrEntry *vr_entry(Instance *I, int method, const fmi2ValueReference vr[], size_t n);
BRIDGE_INTERNAL PyObject *vr_tuple(Instance *I, int method, const fmi2ValueReference vr[], size_t n);
/* fmi2_pybridge_native.c: the fast Real get/set, the native step */
BRIDGE_INTERNAL int plan_of(Instance *I, VrEntry *e, int write);
BRIDGE_INTERNAL int fast_get_real(Instance *I, const fmi2ValueReference vr[], size_t n, fmi2Real v[]);
BRIDGE_INTERNAL int fast_set_real(Instance *I, const fmi2ValueReference vr[], size_t n, const fmi2Real v[], fmi2Status *s);
BRIDGE_INTERNAL void native_drop(Instance *I);
BRIDGE_INTERNAL int native_leave(Instance *I);
BRIDGE_INTERNAL int native_try(Instance *I, double t, double h, int early);
BRIDGE_INTERNAL int native_get_real(Instance *I, const fmi2ValueReference vr[], size_t n, fmi2Real v[]);
BRIDGE_INTERNAL int native_get_integer(Instance *I, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]);
BRIDGE_INTERNAL int native_set_real(Instance *I, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]);


#define ENTER                                                                                      \
    Instance *I = valid(c);                                                                        \
    if (!I) return fmi2Error;                                                                      \
    PyGILState_STATE g = PyGILState_Ensure();                                                      \
    fmi2Status s;                                                                                  \
    if (I->nat.on && native_leave(I) != 0) {                                                       \
        s = fmi2Error;                                                                             \
        LEAVE                                                                                      \
    }

#define LEAVE                                                                                      \
    flush_log(I);                                                                                  \
    PyGILState_Release(g);                                                                         \
    return s;

#endif
