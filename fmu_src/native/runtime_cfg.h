/* The FMU's Python runtime description, resources/python_runtime.cfg (written by the build).
 *
 * One `key=value` per line, `#` starts a comment line. Keys:
 *   libpython  absolute path of the shared libpython the FMU was built with
 *   version    that Python's "major.minor" (e.g. 3.11); a process that already runs another
 *              Python version is refused
 *   executable the building interpreter (for messages only)
 *   home       its sys.base_prefix (PyConfig.home)
 *   path       one sys.path entry of the building interpreter (repeated, in order)
 *   require    a module the FMU needs (repeated): checked at instantiate, named when missing
 *   module     the FMU script's module name in resources/
 *   class      the Fmi2Slave subclass in that module
 *   guid       the guid of modelDescription.xml; fmi2Instantiate refuses any other
 * Shared by the loader and the bridge (header-only, static functions).
 */
#ifndef SPURDIFF_RUNTIME_CFG_H
#define SPURDIFF_RUNTIME_CFG_H

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CFG_MAX_LIST 64
#define CFG_MAX_LINE 4096

typedef struct {
    char *libpython, *version, *executable, *home, *module, *klass, *guid;
    char *path[CFG_MAX_LIST];
    int n_path;
    char *require[CFG_MAX_LIST];
    int n_require;
} RuntimeCfg;

static void cfg_free(RuntimeCfg *c)
{
    free(c->libpython); free(c->version); free(c->executable); free(c->home);
    free(c->module); free(c->klass); free(c->guid);
    for (int i = 0; i < c->n_path; i++) free(c->path[i]);
    for (int i = 0; i < c->n_require; i++) free(c->require[i]);
    memset(c, 0, sizeof *c);
}

static char *cfg_strdup(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = (char *)malloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

/* Decode a resource location (file URI, RFC 8089 forms file:/p, file:///p, file://localhost/p,
 * with %XX escapes) or a plain path into `out`. Returns 0 on success. */
static inline int cfg_uri_to_path(const char *uri, char *out, size_t size)
{
    const char *p = uri;
    if (!uri || !*uri) return -1;
    if (strncmp(p, "file:", 5) == 0) {
        p += 5;
        if (strncmp(p, "//", 2) == 0) {
            p += 2;
            if (strncmp(p, "localhost/", 10) == 0) p += 9;
            else if (*p != '/') return -1;           /* a remote host: not a local file */
        }
    }
    size_t n = 0;
    for (; *p; p++) {
        int ch = (unsigned char)*p;
        if (ch == '%' && isxdigit((unsigned char)p[1]) && isxdigit((unsigned char)p[2])) {
            char hex[3] = {p[1], p[2], 0};
            ch = (int)strtol(hex, NULL, 16);
            p += 2;
        }
        if (n + 1 >= size) return -1;
        out[n++] = (char)ch;
    }
    while (n > 1 && out[n - 1] == '/') n--;          /* no trailing slash */
    out[n] = 0;
    return 0;
}

/* Read `<resources>/python_runtime.cfg`. Returns 0, or -1 with a reason in `err`. */
static int cfg_read(const char *resources, RuntimeCfg *c, char *err, size_t errsize)
{
    char file[CFG_MAX_LINE], line[CFG_MAX_LINE];
    memset(c, 0, sizeof *c);
    snprintf(file, sizeof file, "%s/python_runtime.cfg", resources);
    FILE *f = fopen(file, "r");
    if (!f) {
        snprintf(err, errsize, "cannot read %s (the FMU's resources are incomplete)", file);
        return -1;
    }
    while (fgets(line, sizeof line, f)) {
        size_t n = strlen(line);
        while (n && (line[n - 1] == '\n' || line[n - 1] == '\r')) line[--n] = 0;
        if (!n || line[0] == '#') continue;
        char *eq = strchr(line, '=');
        if (!eq) continue;
        *eq = 0;
        const char *k = line, *v = eq + 1;
        char **slot = NULL;
        if (!strcmp(k, "libpython")) slot = &c->libpython;
        else if (!strcmp(k, "version")) slot = &c->version;
        else if (!strcmp(k, "executable")) slot = &c->executable;
        else if (!strcmp(k, "home")) slot = &c->home;
        else if (!strcmp(k, "module")) slot = &c->module;
        else if (!strcmp(k, "class")) slot = &c->klass;
        else if (!strcmp(k, "guid")) slot = &c->guid;
        else if (!strcmp(k, "path") && c->n_path < CFG_MAX_LIST) slot = &c->path[c->n_path++];
        else if (!strcmp(k, "require") && c->n_require < CFG_MAX_LIST) slot = &c->require[c->n_require++];
        if (slot) { free(*slot); *slot = cfg_strdup(v); }
    }
    fclose(f);
    if (!c->libpython || !c->version || !c->module || !c->klass || !c->guid) {
        snprintf(err, errsize, "%s lacks one of libpython, version, module, class, guid", file);
        cfg_free(c);
        return -1;
    }
    return 0;
}

#endif
