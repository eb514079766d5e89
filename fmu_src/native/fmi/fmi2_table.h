/* The FMI 2.0 functions our binaries pass on, as one list (the loader's in-process table, the
 * out-of-process client and the server share it). */
#ifndef SPURDIFF_FMI2_TABLE_H
#define SPURDIFF_FMI2_TABLE_H

#include "fmi2Functions.h"

/* name, parameter list, argument list of every function with an fmi2Component but
 * fmi2FreeInstance and fmi2GetString (which have their own rules in the loader) */
/* the getters and setters with a value array (the loader checks the arrays first) */
#define FMI2_FORWARDED_ARRAYS(X)                                                                                        \
    X(fmi2GetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]), (c, vr, n, v))             \
    X(fmi2GetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]), (c, vr, n, v))       \
    X(fmi2GetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]), (c, vr, n, v))       \
    X(fmi2SetReal, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[]), (c, vr, n, v))       \
    X(fmi2SetInteger, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]), (c, vr, n, v)) \
    X(fmi2SetBoolean, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]), (c, vr, n, v)) \
    X(fmi2SetString, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]), (c, vr, n, v))
/* the others */
#define FMI2_FORWARDED_PLAIN(X)                                                                                                                                                                         \
    X(fmi2SetDebugLogging, (fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]), (c, on, n, cat))                                                                                        \
    X(fmi2SetupExperiment, (fmi2Component c, fmi2Boolean td, fmi2Real tol, fmi2Real t0, fmi2Boolean sd, fmi2Real t1), (c, td, tol, t0, sd, t1))                                                         \
    X(fmi2EnterInitializationMode, (fmi2Component c), (c))                                                                                                                                              \
    X(fmi2ExitInitializationMode, (fmi2Component c), (c))                                                                                                                                               \
    X(fmi2Terminate, (fmi2Component c), (c))                                                                                                                                                            \
    X(fmi2Reset, (fmi2Component c), (c))                                                                                                                                                                \
    X(fmi2GetFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))                                                                                                                                      \
    X(fmi2SetFMUstate, (fmi2Component c, fmi2FMUstate s), (c, s))                                                                                                                                       \
    X(fmi2FreeFMUstate, (fmi2Component c, fmi2FMUstate *s), (c, s))                                                                                                                                     \
    X(fmi2SerializedFMUstateSize, (fmi2Component c, fmi2FMUstate s, size_t *n), (c, s, n))                                                                                                              \
    X(fmi2SerializeFMUstate, (fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n), (c, s, b, n))                                                                                                   \
    X(fmi2DeSerializeFMUstate, (fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s), (c, b, n, s))                                                                                          \
    X(fmi2GetDirectionalDerivative, (fmi2Component c, const fmi2ValueReference u[], size_t nu, const fmi2ValueReference z[], size_t nz, const fmi2Real du[], fmi2Real dz[]), (c, u, nu, z, nz, du, dz)) \
    X(fmi2SetRealInputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], const fmi2Real v[]), (c, vr, n, o, v))                                             \
    X(fmi2GetRealOutputDerivatives, (fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], fmi2Real v[]), (c, vr, n, o, v))                                                  \
    X(fmi2DoStep, (fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean nsp), (c, t, h, nsp))                                                                                                           \
    X(fmi2CancelStep, (fmi2Component c), (c))                                                                                                                                                           \
    X(fmi2GetStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Status *v), (c, k, v))                                                                                                               \
    X(fmi2GetRealStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Real *v), (c, k, v))                                                                                                             \
    X(fmi2GetIntegerStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Integer *v), (c, k, v))                                                                                                       \
    X(fmi2GetBooleanStatus, (fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v), (c, k, v))                                                                                                       \
    X(fmi2GetStringStatus, (fmi2Component c, const fmi2StatusKind k, fmi2String *v), (c, k, v))
#define FMI2_FORWARDED(X) FMI2_FORWARDED_ARRAYS(X) FMI2_FORWARDED_PLAIN(X)

/* The bridge's functions (fmi2Instantiate takes the resources folder as a decoded path). */
typedef struct {
    fmi2InstantiateTYPE *fmi2Instantiate;
    fmi2FreeInstanceTYPE *fmi2FreeInstance;
    fmi2GetStringTYPE *fmi2GetString;
#define FMI2_TABLE_MEMBER(name, params, args) name##TYPE *name;
    FMI2_FORWARDED(FMI2_TABLE_MEMBER)
#undef FMI2_TABLE_MEMBER
} Fmi2Table;

#endif
