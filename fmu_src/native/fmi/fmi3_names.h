/* The FMI 3.0 names of what the FMI 2.0 side (loader, bridge, adapter) names in its log lines:
 * an FMI 3.0 host reads "fmi3SetFloat64: ..." where the model said "fmi2SetReal: ...".
 * fmi3_rename copies `in` to `out`, replacing each whole word of RENAMES (a word: not followed by
 * a letter or digit, so fmi2SetReal does not match inside fmi2SetRealInputDerivatives). File
 * names (fmi2_pybridge.so) are never touched. Header-only, used by fmi3_loader.c.
 */
#ifndef SPURDIFF_FMI3_NAMES_H
#define SPURDIFF_FMI3_NAMES_H

#include <ctype.h>
#include <string.h>

static const char *const RENAMES[][2] = {
    {"fmi2Instantiate", "fmi3InstantiateCoSimulation"},
    {"fmi2SetupExperiment", "fmi3EnterInitializationMode"},
    {"fmi2EnterInitializationMode", "fmi3EnterInitializationMode"},
    {"fmi2ExitInitializationMode", "fmi3ExitInitializationMode"},
    {"fmi2DoStep", "fmi3DoStep"},
    {"fmi2GetReal", "fmi3GetFloat64"},
    {"fmi2SetReal", "fmi3SetFloat64"},
    {"fmi2GetInteger", "fmi3GetInt32"},
    {"fmi2SetInteger", "fmi3SetInt32"},
    {"fmi2GetBoolean", "fmi3GetBoolean"},
    {"fmi2SetBoolean", "fmi3SetBoolean"},
    {"fmi2GetString", "fmi3GetString"},
    {"fmi2SetString", "fmi3SetString"},
    {"fmi2Terminate", "fmi3Terminate"},
    {"fmi2Reset", "fmi3Reset"},
    {"fmi2FreeInstance", "fmi3FreeInstance"},
    {"fmi2SetDebugLogging", "fmi3SetDebugLogging"},
    {"fmi2GetFMUstate", "fmi3GetFMUState"},
    {"fmi2SetFMUstate", "fmi3SetFMUState"},
    {"fmi2FreeFMUstate", "fmi3FreeFMUState"},
    {"fmi2SerializedFMUstateSize", "fmi3SerializedFMUStateSize"},
    {"fmi2SerializeFMUstate", "fmi3SerializeFMUState"},
    {"fmi2DeSerializeFMUstate", "fmi3DeserializeFMUState"},
    {"fmi2GetRealStatus", "fmi3DoStep (lastSuccessfulTime)"},
    {"fmi2GetBooleanStatus", "fmi3DoStep (terminateSimulation)"},
    {"fmi2OK", "fmi3OK"},
    {"fmi2Warning", "fmi3Warning"},
    {"fmi2Discard", "fmi3Discard"},
    {"fmi2Error", "fmi3Error"},
    {"fmi2Fatal", "fmi3Fatal"},
    {"fmi2Terminated", "terminateSimulation"},
    /* the adapter's type names in "is not a Real variable of this FMU" */
    {"settable Real variable", "settable Float64 variable"},
    {"a Real variable", "a Float64 variable"},
    {"settable Integer variable", "settable Int32 variable"},
    {"a Integer variable", "an Int32 variable"},
};

static void fmi3_rename(const char *in, char *out, size_t size)
{
    size_t n = 0;
    if (!size) return;
    while (*in && n + 1 < size) {
        const char *to = NULL;
        size_t len = 0;
        if (in[0] == 'f' || in[0] == 's' || in[0] == 'a') {
            for (size_t i = 0; i < sizeof RENAMES / sizeof RENAMES[0]; i++) {
                size_t l = strlen(RENAMES[i][0]);
                if (!strncmp(in, RENAMES[i][0], l) && !isalnum((unsigned char)in[l]) && in[l] != '_') {
                    to = RENAMES[i][1];
                    len = l;
                    break;
                }
            }
        }
        if (to) {
            size_t l = strlen(to);
            if (n + l + 1 > size) break;
            memcpy(out + n, to, l);
            n += l;
            in += len;
        } else {
            out[n++] = *in++;
        }
    }
    out[n] = 0;
}

#endif
