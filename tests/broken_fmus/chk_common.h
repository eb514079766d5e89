/* chk_common.h: what ChkC (chkc.c, FMI 2.0) and Chk3C (chk3c.c, FMI 3.0) share, the compliance-kit
   test FMUs of tests/broken_fmus/ (built by chk_build.py): x' = k u, y = k u, their log, the values, the
   FMU state and its serialization, the directional derivative, the doStep checks. Both standards say the
   same here; only the names differ, so the including file defines, before #include "chk_common.h":

   CHK_STATUS, CHK_OK, CHK_ERROR               its status type and values
   CHK_STOP_STATUS                             what a step past the stop time returns
   CHK_VR                                      its value reference type
   CHK_LOG(m, st, cat, msg)                    one log message through its logger (m->... may be NULL)
   CHK_TIME_VR (optional)                      the value reference of the independent variable time
   Inst                                        its instance, with double u, k, x, time, stop, ystale and
                                               int stopDefined, state, logging; X(m): where x lives
   INSTANTIATED, INITIALIZATION, STEP, TERMINATED (the states before STEP less than it), VR_U, VR_K, VR_X,
   VR_Y, VR_DX

   The BREAK_* macros handled here are those the two FMUs break alike (see each file's first comment):
   BREAK_INIT_GET, BREAK_TERMINATED_GET, BREAK_STALE_Y, BREAK_DEBUG_LOGGING, BREAK_FREE_STATE,
   BREAK_STATE_NOOP, BREAK_SERIALIZE, BREAK_DIRDER (in the caller), BREAK_JACOBIAN, BREAK_CLOCK,
   BREAK_STOP_TIME, BREAK_LATE_STEP. */
#ifndef CHK_COMMON_H
#define CHK_COMMON_H

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* the FMU state: what fmiXGetFMUstate saves (xprev of chkc.c's BREAK_HISTORY is left out on purpose) */
typedef struct { double u, k, x, time, ystale; int state; } Saved;

static void logmsg(Inst *m, CHK_STATUS st, const char *cat, const char *fmt, ...) {
    char buf[256];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    CHK_LOG(m, st, cat, buf);
}

static CHK_STATUS refuse(Inst *m, const char *fn) {
    logmsg(m, CHK_ERROR, "logStatusError", "%s: illegal call in this state", fn);
    return CHK_ERROR;
}

/* ---- the state machine both standards share: Instantiated, Initialization Mode, stepping or events, Terminated */
/* from the state ``from`` to ``to``; refused in any other */
static CHK_STATUS move(Inst *m, int from, int to, const char *fn) {
    if (m->state != from) return refuse(m, fn);
    m->state = to;
    return CHK_OK;
}

static CHK_STATUS start_initialization(Inst *m, double start, int stopDefined, double stop, const char *fn) {
    if (m->state != INSTANTIATED) return refuse(m, fn);
    m->time = start; m->stopDefined = stopDefined; m->stop = stop;
    return CHK_OK;
}

static CHK_STATUS exit_initialization(Inst *m, int next, const char *fn) {
    if (m->state != INITIALIZATION) return refuse(m, fn);
    m->ystale = m->k * m->u;
    m->state = next;
    return CHK_OK;
}

static CHK_STATUS terminate(Inst *m, const char *fn) {
    if (m->state < STEP || m->state == TERMINATED) return refuse(m, fn);   /* not before stepping, not twice */
    m->state = TERMINATED;
    return CHK_OK;
}

/* fmiXSetDebugLogging: the two declared categories only */
static CHK_STATUS debug_logging(Inst *m, int on, size_t n, const char *const cats[]) {
    size_t i;
    for (i = 0; i < n; i++) {
#ifdef BREAK_DEBUG_LOGGING
        return CHK_ERROR;
#endif
        if (strcmp(cats[i], "logStatusError") && strcmp(cats[i], "logEvents")) {
            logmsg(m, CHK_ERROR, "logStatusError", "unknown log category %s", cats[i]);
            return CHK_ERROR;
        }
    }
    m->logging = on;
    return CHK_OK;
}

static double value(Inst *m, CHK_VR vr, int *ok) {
    *ok = 1;
#ifdef CHK_TIME_VR
    if (vr == CHK_TIME_VR) return m->time;
#endif
    switch (vr) {
    case VR_U: return m->u;
    case VR_K: return m->k;
    case VR_X: return X(m);
#ifdef BREAK_STALE_Y
    case VR_Y: return m->ystale;
#else
    case VR_Y: return m->k * m->u;
#endif
    case VR_DX: return m->k * m->u;
    }
    *ok = 0;
    return 0.0;
}

/* fmiXGetReal / fmi3GetFloat64 once the caller has refused the states it never answers in */
static CHK_STATUS get_reals(Inst *m, const CHK_VR vr[], size_t n, double v[], const char *fn) {
    size_t i;
    int ok;
#ifdef BREAK_INIT_GET
    if (m->state == INITIALIZATION) return refuse(m, fn);
#endif
#ifdef BREAK_TERMINATED_GET
    if (m->state == TERMINATED) return refuse(m, fn);
#endif
    for (i = 0; i < n; i++) {
        v[i] = value(m, vr[i], &ok);
        if (!ok) {
            logmsg(m, CHK_ERROR, "logStatusError", "%s (value reference): illegal call in this state", fn);
            return CHK_ERROR;
        }
    }
    return CHK_OK;
}

/* ---- FMU state and its serialization */
static CHK_STATUS get_state(Inst *m, void **s) {
    Saved *p = *s ? (Saved *)*s : (Saved *)malloc(sizeof(Saved));
    if (!p) return CHK_ERROR;
    p->u = m->u; p->k = m->k; p->x = X(m); p->time = m->time; p->ystale = m->ystale; p->state = m->state;
    *s = p;
    return CHK_OK;
}

static CHK_STATUS set_state(Inst *m, const void *s, const char *fn) {
    const Saved *p = (const Saved *)s;
    if (!p) {
        logmsg(m, CHK_ERROR, "logStatusError", "%s (NULL): illegal call in this state", fn);
        return CHK_ERROR;
    }
#ifdef BREAK_STATE_NOOP
    return CHK_OK;
#endif
    m->u = p->u; m->k = p->k; X(m) = p->x; m->time = p->time; m->ystale = p->ystale; m->state = p->state;
    return CHK_OK;
}

static CHK_STATUS free_state(void **s) {
    if (!s || !*s) return CHK_OK;
    free(*s);
#ifndef BREAK_FREE_STATE
    *s = NULL;
#endif
    return CHK_OK;
}

static CHK_STATUS serialize_state(const void *s, void *b, size_t n) {
    if (n != sizeof(Saved)) return CHK_ERROR;
    memcpy(b, s, n);
    return CHK_OK;
}

static CHK_STATUS deserialize_state(const void *b, size_t n, void **s) {
    if (n != sizeof(Saved)) return CHK_ERROR;
    if (!*s) *s = malloc(sizeof(Saved));
    if (!*s) return CHK_ERROR;
    memcpy(*s, b, n);
#ifdef BREAK_SERIALIZE
    ((Saved *)*s)->x = 0.0;
#endif
    return CHK_OK;
}

/* the six FMU-state functions of a standard, from its instance, state and byte types and their names */
#define CHK_STATE_FUNCTIONS(Comp, State, Byte, Get, Set, Free, Size, Serialize, Deserialize) \
    CHK_STATUS Get(Comp c, State *s) { return get_state((Inst *)c, s); } \
    CHK_STATUS Set(Comp c, State s) { return set_state((Inst *)c, s, #Set); } \
    CHK_STATUS Free(Comp c, State *s) { (void)c; return free_state(s); } \
    CHK_STATUS Size(Comp c, State s, size_t *n) { (void)c; (void)s; *n = sizeof(Saved); return CHK_OK; } \
    CHK_STATUS Serialize(Comp c, State s, Byte b[], size_t n) { (void)c; return serialize_state(s, b, n); } \
    CHK_STATUS Deserialize(Comp c, const Byte b[], size_t n, State *s) { (void)c; return deserialize_state(b, n, s); }

/* d unknowns / d knowns times the seed: only y and der(x) depend on u (by k) */
static void directional_derivative(Inst *m, const CHK_VR unk[], size_t nu, const CHK_VR kn[], size_t nk,
                                   const double seed[], double sens[]) {
    size_t i, j;
    for (i = 0; i < nu; i++) {
        sens[i] = 0.0;
        for (j = 0; j < nk; j++) {
            if (kn[j] == VR_U && (unk[i] == VR_Y || unk[i] == VR_DX)) sens[i] += m->k * seed[j];
#ifdef BREAK_JACOBIAN
            else if (kn[j] == VR_X && unk[i] == VR_DX) sens[i] += seed[j];
#endif
        }
    }
}

/* ---- co-simulation: the checks of a doStep from t by h (CHK_OK: it may be taken) */
static CHK_STATUS step_checks(Inst *m, double t, double h, const char *fn) {
    if (!(h > 0)) {
        logmsg(m, CHK_ERROR, "logStatusError", "step size must be > 0, was %g", h);
        return CHK_ERROR;
    }
#ifndef BREAK_CLOCK
    if (fabs(t - m->time) > 1e-9 * (1.0 + fabs(t))) {
        logmsg(m, CHK_ERROR, "logStatusError", "communication point %g, expected %g", t, m->time);
        return CHK_ERROR;
    }
#endif
#ifndef BREAK_STOP_TIME
    if (m->stopDefined && t + h > m->stop + 1e-9 * (1.0 + fabs(m->stop))) {
        logmsg(m, CHK_ERROR, "logStatusError", "a step to %g passes the stop time %g", t + h, m->stop);
        return CHK_STOP_STATUS;
    }
#endif
#ifdef BREAK_LATE_STEP
    if (t >= 0.5) return refuse(m, fn);
#endif
    (void)fn;
    return CHK_OK;
}

#ifdef BREAK_CLOCK
/* its own clock: whole internal steps of 0.01 s from where it was, whatever t says */
static void own_clock_step(Inst *m, double h) {
    long n = (long)floor(h / 0.01 + 1e-9);
    X(m) += m->k * m->u * 0.01 * n;
    m->time += 0.01 * n;
}
#endif

#endif
