/* The FMU's runtime description, resources/python_runtime.cfg (written by harness/build.py).
 *
 * Format 2. One `key=value` per line, `#` starts a comment line; nothing else. Every path is
 * relative to the FMU's resources folder (no leading '/', no '..' component): the FMU carries its
 * own Python, nothing from the building machine is recorded. Keys:
 *   format     2
 *   version    the runtime's Python "major.minor" (e.g. 3.11)
 *   libpython  the runtime's shared libpython
 *   home       PyConfig.home of the runtime (sys.base_prefix inside the FMU)
 *   path       one module search path entry of the runtime (repeated, in order)
 *   preload    a shared library the runtime's extension modules need (repeated; loaded first)
 *   package    the FMU's Python package folder, imported under a private name per extraction
 *   module     the module inside that package that holds the slave class
 *   class      the slave class
 *   guid       the guid of modelDescription.xml; fmi2Instantiate refuses any other
 *   archive    `<SHA-256, 64 hex digits> <relative path>`: an archive of the runtime's files (repeated,
 *              at most CFG_MAX_ARCHIVE; runtime_unpack.h). With archives, libpython, home, path and
 *              preload are relative to the folder they are unpacked into (cfg_runtime_root), not to
 *              the resources folder
 * The file is read strictly: a regular file of at most CFG_MAX_FILE bytes, lines of at most
 * CFG_MAX_LINE - 1 bytes, no NUL byte, known keys only, each single key once, at most
 * CFG_MAX_LIST of a repeated one; anything else refuses the FMU with the line named.
 * Shared by the loader, the server and the bridge (header-only, static functions).
 */
#ifndef SPURDIFF_RUNTIME_CFG_H
#define SPURDIFF_RUNTIME_CFG_H

#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "platform.h"

#define CFG_MAX_LIST 64
#define CFG_MAX_ARCHIVE 8
#define CFG_MAX_LINE 4096
#define CFG_MAX_FILE 65536
#ifdef _WIN32   /* the win64 binaries read their own runtime's description */
#define CFG_FILE "python_runtime_win64.cfg"
#else
#define CFG_FILE "python_runtime.cfg"
#endif
#define CFG_FORMAT "2"
#define CFG_FN static __attribute__((unused))

typedef struct {
    char *format, *version, *libpython, *home, *package, *module, *klass, *guid;
    char *path[CFG_MAX_LIST];
    int n_path;
    char *preload[CFG_MAX_LIST];
    int n_preload;
    char *archive[CFG_MAX_ARCHIVE], *archive_sha[CFG_MAX_ARCHIVE];
    int n_archive;
} RuntimeCfg;

CFG_FN void cfg_free(RuntimeCfg *c)
{
    free(c->format); free(c->version); free(c->libpython); free(c->home);
    free(c->package); free(c->module); free(c->klass); free(c->guid);
    for (int i = 0; i < c->n_path; i++) free(c->path[i]);
    for (int i = 0; i < c->n_preload; i++) free(c->preload[i]);
    for (int i = 0; i < c->n_archive; i++) { free(c->archive[i]); free(c->archive_sha[i]); }
    memset(c, 0, sizeof *c);
}

CFG_FN char *cfg_strdup(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = (char *)malloc(n);
    if (d) memcpy(d, s, n);
    return d;
}

/* The length of the URI scheme `p` starts with (RFC 3986: a letter, then letters, digits, '+', '-'
 * or '.', then ':'), 0 when it has none. A one-letter "scheme" is a Windows drive (C:\dir). */
CFG_FN size_t cfg_uri_scheme(const char *p)
{
    size_t n = 0;
    if (!isalpha((unsigned char)p[0])) return 0;
    while (isalnum((unsigned char)p[n]) || p[n] == '+' || p[n] == '-' || p[n] == '.') n++;
    return p[n] == ':' && n >= 2 ? n : 0;
}

/* Decode a resource location (file URI, RFC 8089 forms file:/p, file:///p, file://localhost/p,
 * with %XX escapes) or a plain path into `out`. Returns 0 on success; -1 for a URI of another
 * scheme (http:, ftp:, ...) or of a remote host (file://host/p): not a local file. */
CFG_FN int cfg_uri_to_path(const char *uri, char *out, size_t size)
{
    const char *p = uri;
    if (!uri || !*uri) return -1;
    size_t scheme = cfg_uri_scheme(p);
    int file = scheme == 4 && tolower((unsigned char)p[0]) == 'f' && tolower((unsigned char)p[1]) == 'i'
               && tolower((unsigned char)p[2]) == 'l' && tolower((unsigned char)p[3]) == 'e';   /* any case */
    if (scheme && !file) return -1;   /* http:, ftp:, urn:...: not a local file */
    if (file) {
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
            if (ch == 0) return -1;                  /* %00 would cut the path */
        }
        if (n + 1 >= size) return -1;
        out[n++] = (char)ch;
    }
    while (n > 1 && out[n - 1] == '/') n--;          /* no trailing slash */
    out[n] = 0;
#ifdef _WIN32   /* file:///C:/dir decodes to /C:/dir: the path is C:/dir */
    if (out[0] == '/' && isalpha((unsigned char)out[1]) && out[2] == ':') memmove(out, out + 1, n);
#endif
    return 0;
}

/* A relative path inside the resources folder: not empty, no leading '/', no '..' component,
 * no backslash. */
CFG_FN int cfg_relative_ok(const char *v)
{
    if (!*v || v[0] == '/' || strchr(v, '\\')) return 0;
#ifdef _WIN32   /* no drive letter (C:x is relative to that drive's current folder) */
    if (strchr(v, ':')) return 0;
#endif
    for (const char *p = v; *p;) {
        const char *e = strchr(p, '/');
        size_t n = e ? (size_t)(e - p) : strlen(p);
        if (n == 2 && p[0] == '.' && p[1] == '.') return 0;
        p += n + (e ? 1 : 0);
    }
    return 1;
}

/* A Python identifier (dotted when `dots`), ASCII. */
CFG_FN int cfg_identifier_ok(const char *v, int dots)
{
    int start = 1;
    if (!*v) return 0;
    for (const char *p = v; *p; p++) {
        unsigned char ch = (unsigned char)*p;
        if (dots && ch == '.' && !start) { start = 1; continue; }
        if (!(isalpha(ch) || ch == '_' || (!start && isdigit(ch)))) return 0;
        start = 0;
    }
    return !start;
}

/* Join the resources folder and a relative cfg path into `out`. 0, or -1 when it does not fit. */
CFG_FN int cfg_join(const char *resources, const char *rel, char *out, size_t size)
{
    int n = snprintf(out, size, "%s/%s", resources, rel);
    return (n < 0 || (size_t)n >= size) ? -1 : 0;
}

/* The whole regular file `file` (at most `max` bytes) in a new buffer with a NUL after its `*len`
 * bytes (free()), or NULL with a reason in `err`. A FIFO planted in its place does not block the
 * open (platform.h) and is refused. */
CFG_FN char *cfg_slurp(const char *file, long long max, size_t *len, char *err, size_t errsize)
{
    int fd = plat_open_read(file);
    if (fd < 0) {
        snprintf(err, errsize, "cannot read %s: %s (the FMU's resources are incomplete or not readable)",
                 file, strerror(errno));
        return NULL;
    }
#ifdef _WIN32
    struct _stat64 st;
    if (_fstat64(fd, &st) != 0 || !(st.st_mode & _S_IFREG)) {
#else
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
#endif
        snprintf(err, errsize, "%s is not a regular file (the FMU's resources are damaged)", file);
        close(fd);
        return NULL;
    }
    if (st.st_size > max) {
        snprintf(err, errsize, "%s has %lld bytes, more than the %lld it may have", file, (long long)st.st_size, max);
        close(fd);
        return NULL;
    }
    char *text = (char *)malloc((size_t)st.st_size + 1);
    size_t got = 0;
    while (text && got < (size_t)st.st_size) {
        ssize_t r = read(fd, text + got, (size_t)st.st_size - got);
        if (r < 0 && errno == EINTR) continue;
        if (r <= 0) break;
        got += (size_t)r;
    }
    close(fd);
    if (!text || got != (size_t)st.st_size) {
        snprintf(err, errsize, "cannot read %s completely", file);
        free(text);
        return NULL;
    }
    text[got] = 0;
    *len = got;
    return text;
}

/* Read `<resources>/python_runtime.cfg`. Returns 0, or -1 with a reason in `err`. */
CFG_FN int cfg_read(const char *resources, RuntimeCfg *c, char *err, size_t errsize)
{
    char file[CFG_MAX_LINE];
    memset(c, 0, sizeof *c);
    if (cfg_join(resources, CFG_FILE, file, sizeof file) != 0) {
        snprintf(err, errsize, "the resources path is longer than %d bytes", CFG_MAX_LINE - 32);
        return -1;
    }
    size_t got = 0;
    char *text = cfg_slurp(file, CFG_MAX_FILE, &got, err, errsize);
    if (!text) return -1;
    if (memchr(text, 0, got)) {
        snprintf(err, errsize, "%s contains a NUL byte (the FMU's resources are damaged)", file);
        free(text);
        return -1;
    }
    int lineno = 0, rc = 0;
    char *p = text;
    while (*p && rc == 0) {
        char *nl = strchr(p, '\n');
        size_t n = nl ? (size_t)(nl - p) : strlen(p);
        lineno++;
        if (n >= CFG_MAX_LINE) {
            snprintf(err, errsize, "%.2000s line %d is longer than %d bytes", file, lineno, CFG_MAX_LINE - 1);
            rc = -1;
            break;
        }
        char line[CFG_MAX_LINE];
        memcpy(line, p, n);
        line[n] = 0;
        p += n + (nl ? 1 : 0);
        if (n && line[n - 1] == '\r') line[--n] = 0;
        if (!n || line[0] == '#') continue;
        char *eq = strchr(line, '=');
        if (!eq) {
            snprintf(err, errsize, "%.2000s line %d is not key=value", file, lineno);
            rc = -1;
            break;
        }
        *eq = 0;
        const char *k = line, *v = eq + 1;
        char **slot = NULL;
        int kind = 0;   /* 0 plain, 1 relative path, 2 identifier, 3 dotted identifier */
        if (!strcmp(k, "format")) slot = &c->format;
        else if (!strcmp(k, "version")) slot = &c->version;
        else if (!strcmp(k, "libpython")) { slot = &c->libpython; kind = 1; }
        else if (!strcmp(k, "home")) { slot = &c->home; kind = 1; }
        else if (!strcmp(k, "package")) { slot = &c->package; kind = 2; }
        else if (!strcmp(k, "module")) { slot = &c->module; kind = 3; }
        else if (!strcmp(k, "class")) { slot = &c->klass; kind = 2; }
        else if (!strcmp(k, "guid")) slot = &c->guid;
        else if (!strcmp(k, "archive")) {
            const char *sp = strchr(v, ' ');
            int hex = sp && sp - v == 64;
            for (int i = 0; hex && i < 64; i++) hex = (v[i] >= '0' && v[i] <= '9') || (v[i] >= 'a' && v[i] <= 'f');
            if (c->n_archive >= CFG_MAX_ARCHIVE || !hex || !cfg_relative_ok(sp + 1)) {
                snprintf(err, errsize, "%.2000s line %d: 'archive' must be a SHA-256 (64 hex digits), a space and a "
                         "relative path inside the resources folder, at most %d times", file, lineno, CFG_MAX_ARCHIVE);
                rc = -1;
                break;
            }
            c->archive[c->n_archive] = cfg_strdup(sp + 1);
            c->archive_sha[c->n_archive] = (char *)malloc(65);
            if (c->archive_sha[c->n_archive]) { memcpy(c->archive_sha[c->n_archive], v, 64); c->archive_sha[c->n_archive][64] = 0; }
            if (!c->archive[c->n_archive++] || !c->archive_sha[c->n_archive - 1]) {
                snprintf(err, errsize, "out of memory reading %s", file);
                rc = -1;
            }
            continue;
        }
        else if (!strcmp(k, "path") || !strcmp(k, "preload")) {
            int *count = k[1] == 'a' ? &c->n_path : &c->n_preload;
            char **list = k[1] == 'a' ? c->path : c->preload;
            if (*count >= CFG_MAX_LIST) {
                snprintf(err, errsize, "%.2000s line %d: more than %d '%s' lines", file, lineno, CFG_MAX_LIST, k);
                rc = -1;
                break;
            }
            slot = &list[(*count)++];
            kind = 1;
        } else {
            snprintf(err, errsize, "%.2000s line %d: unknown key '%.40s'", file, lineno, k);
            rc = -1;
            break;
        }
        if (*slot) {
            snprintf(err, errsize, "%.2000s line %d: '%.40s' given twice", file, lineno, k);
            rc = -1;
            break;
        }
        if (!*v || (kind == 1 && !cfg_relative_ok(v)) || (kind == 2 && !cfg_identifier_ok(v, 0)) ||
            (kind == 3 && !cfg_identifier_ok(v, 1))) {
            snprintf(err, errsize, "%.2000s line %d: '%.40s' must be %s", file, lineno, k,
                     kind == 1 ? "a relative path inside the resources folder (no '/' at the start, no '..')"
                     : kind ? "a Python identifier" : "a non-empty value");
            rc = -1;
            break;
        }
        if (!(*slot = cfg_strdup(v))) {
            snprintf(err, errsize, "out of memory reading %s", file);
            rc = -1;
        }
    }
    free(text);
    if (rc == 0 && (!c->format || strcmp(c->format, CFG_FORMAT) != 0)) {
        snprintf(err, errsize, "%s has format %s where this loader reads format " CFG_FORMAT
                 " (the FMU's binary and resources come from different builds)", file,
                 c->format ? c->format : "(none)");
        rc = -1;
    }
    if (rc == 0 && (!c->version || !c->libpython || !c->home || !c->n_path || !c->package || !c->module ||
                    !c->klass || !c->guid)) {
        snprintf(err, errsize, "%s lacks one of version, libpython, home, path, package, module, class, guid", file);
        rc = -1;
    }
    if (rc != 0) cfg_free(c);
    return rc;
}

#include "runtime_unpack.h"

/* The folder the runtime's paths (libpython, home, path, preload) are relative to: the resources
 * folder, or with archives the folder they are unpacked into (made at the first call per user and
 * runtime; runtime_unpack.h). 0, or -1 with one line in `err`. */
CFG_FN int cfg_runtime_root(const char *resources, const RuntimeCfg *c, char *out, size_t size, char *err,
                            size_t errsize)
{
    if (c->n_archive == 0) {
        if (snprintf(out, size, "%s", resources) >= (int)size) {
            snprintf(err, errsize, "the resources path is too long");
            return -1;
        }
        return 0;
    }
    return ru_runtime_root(resources, c->n_archive, c->archive, c->archive_sha, out, size, err, errsize);
}

#endif
