/* One message to the host's logger, as every binary of ours sends it (the loader, the native start,
 * the bridge, the model process's client): the text as the logger's format with no arguments, every
 * '%' doubled, so a host that formats it (FMI 2.0 section 2.1.5) prints the text as it is and so does
 * one that reads the format itself (fmpy); without a logger, a warning or worse to stderr. */
#ifndef SPURDIFF_LOG_TEXT_H
#define SPURDIFF_LOG_TEXT_H

#include <stdio.h>
#include <stdlib.h>

#include "fmi2Functions.h"

static __attribute__((unused)) void log_text(const fmi2CallbackFunctions *cb, const char *name, fmi2Status status,
                                             const char *category, const char *text)
{
    if (!name) name = "";
    if (!cb || !cb->logger) {
        if (status >= fmi2Warning) fprintf(stderr, "%s: %s\n", *name ? name : "fmu", text);
        return;
    }
    size_t n = 0;
    for (const char *p = text; *p; p++) n += *p == '%' ? 2 : 1;
    char *buf = (char *)malloc(n + 1), *q = buf;
    if (!buf) {
        cb->logger(cb->componentEnvironment, name, status, category, "(a message lost: out of memory)");
        return;
    }
    for (const char *p = text; *p; p++) {
        if (*p == '%') *q++ = '%';
        *q++ = *p;
    }
    *q = 0;
    cb->logger(cb->componentEnvironment, name, status, category, buf);
    free(buf);
}

#endif
