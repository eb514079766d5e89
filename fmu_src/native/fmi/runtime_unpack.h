/* The FMU's Python runtime carried as archives and unpacked once per user and runtime (issue 44
 * item 1). Header-only, static functions; included by runtime_cfg.h (the loader, the server and
 * the bridge each carry a copy: whichever starts the Python first unpacks, the others find it).
 *
 * Needs cfg_slurp (runtime_cfg.h includes this header after it).
 *
 * Why: a host unzips the whole FMU at every extraction; some 30 MB of CPython in 200 files for two
 * platforms made that unzip the whole run's cost. The runtime's files now travel as a few members
 * the host's unzip copies (stored: resources/runtime/common.zip, linux64.zip, win64.zip, each
 * LZMA inside), listed in the runtime description with their SHA-256 (`archive=<hex> <path>`).
 * A start that needs the Python (not the native start) unpacks them here:
 *
 *   <cache>/spurdiff/python-<key>/   key: the first 16 hex digits of the SHA-256 of the listed digests
 *
 * <cache> is $SPURDIFF_FMU_RUNTIME_DIR when set (an absolute path; the folder itself, made if
 * missing), else $XDG_CACHE_HOME or ~/.cache (Windows: %LOCALAPPDATA%, else %USERPROFILE%\AppData\
 * Local) followed by /spurdiff; when that cannot be made or is not private, $TMPDIR (or /tmp) /
 * spurdiff-<uid> (Windows: the temporary folder's spurdiff). A folder is used only when it is a
 * folder of this user's, not a link, mode 0700, every folder above it this user's or root's and
 * writable by others only when sticky (Windows: a folder, not a reparse point), and the runtime
 * folder holds the marker naming its key; anything else is refused with one line naming
 * it, never deleted. Unpacking: each archive's SHA-256 checked against the description, every
 * member's name checked to stay inside (relative, no '..', no '\', no ':'), inflated by the
 * decoders below (deflate, RFC 1951; LZMA with its end marker; stored members copied), its size and CRC-32 checked, written into a
 * fresh private temporary folder beside the target with O_EXCL, the marker last, then the folder
 * renamed into place (a process that renamed first wins; its folder is used, this one removed).
 * Before an unpack, the temporary folders of earlier unpacks whose process died halfway, and the
 * folders of other runtimes no start used for 30 days, are removed (ru_sweep).
 */
#ifndef SPURDIFF_RUNTIME_UNPACK_H
#define SPURDIFF_RUNTIME_UNPACK_H

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "platform.h"

#ifndef _WIN32
#include <dirent.h>
#include <ftw.h>
#include <pwd.h>
#include <signal.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#endif

#define RU_FN static __attribute__((unused))
#define RU_MAX_ARCHIVE (256LL << 20)    /* bytes of one archive */
#define RU_MAX_MEMBER (512LL << 20)     /* bytes of one unpacked member */
#define RU_MARKER ".spurdiff-runtime"
#define RU_ENV "SPURDIFF_FMU_RUNTIME_DIR"

/* ------------------------------------------------------------------------------------ SHA-256 */
typedef struct { uint32_t h[8]; uint64_t n; uint8_t buf[64]; size_t used; } RuSha;

static const uint32_t RU_K[64] = {
    0x428a2f98u, 0x71374491u, 0xb5c0fbcfu, 0xe9b5dba5u, 0x3956c25bu, 0x59f111f1u, 0x923f82a4u, 0xab1c5ed5u,
    0xd807aa98u, 0x12835b01u, 0x243185beu, 0x550c7dc3u, 0x72be5d74u, 0x80deb1feu, 0x9bdc06a7u, 0xc19bf174u,
    0xe49b69c1u, 0xefbe4786u, 0x0fc19dc6u, 0x240ca1ccu, 0x2de92c6fu, 0x4a7484aau, 0x5cb0a9dcu, 0x76f988dau,
    0x983e5152u, 0xa831c66du, 0xb00327c8u, 0xbf597fc7u, 0xc6e00bf3u, 0xd5a79147u, 0x06ca6351u, 0x14292967u,
    0x27b70a85u, 0x2e1b2138u, 0x4d2c6dfcu, 0x53380d13u, 0x650a7354u, 0x766a0abbu, 0x81c2c92eu, 0x92722c85u,
    0xa2bfe8a1u, 0xa81a664bu, 0xc24b8b70u, 0xc76c51a3u, 0xd192e819u, 0xd6990624u, 0xf40e3585u, 0x106aa070u,
    0x19a4c116u, 0x1e376c08u, 0x2748774cu, 0x34b0bcb5u, 0x391c0cb3u, 0x4ed8aa4au, 0x5b9cca4fu, 0x682e6ff3u,
    0x748f82eeu, 0x78a5636fu, 0x84c87814u, 0x8cc70208u, 0x90befffau, 0xa4506cebu, 0xbef9a3f7u, 0xc67178f2u};

#define RU_ROR(x, k) (((x) >> (k)) | ((x) << (32 - (k))))

RU_FN void ru_sha_block(RuSha *s, const uint8_t *p)
{
    uint32_t w[64], a[8];
    for (int i = 0; i < 16; i++)
        w[i] = (uint32_t)p[4 * i] << 24 | (uint32_t)p[4 * i + 1] << 16 | (uint32_t)p[4 * i + 2] << 8 | p[4 * i + 3];
    for (int i = 16; i < 64; i++) {
        uint32_t s0 = RU_ROR(w[i - 15], 7) ^ RU_ROR(w[i - 15], 18) ^ (w[i - 15] >> 3);
        uint32_t s1 = RU_ROR(w[i - 2], 17) ^ RU_ROR(w[i - 2], 19) ^ (w[i - 2] >> 10);
        w[i] = w[i - 16] + s0 + w[i - 7] + s1;
    }
    memcpy(a, s->h, sizeof a);
    uint32_t A = a[0], B = a[1], C = a[2], D = a[3], E = a[4], F = a[5], G = a[6], H = a[7];
    for (int i = 0; i < 64; i++) {
        uint32_t t1 = H + (RU_ROR(E, 6) ^ RU_ROR(E, 11) ^ RU_ROR(E, 25)) + ((E & F) ^ (~E & G)) + RU_K[i] + w[i];
        uint32_t t2 = (RU_ROR(A, 2) ^ RU_ROR(A, 13) ^ RU_ROR(A, 22)) + ((A & B) ^ (A & C) ^ (B & C));
        H = G; G = F; F = E; E = D + t1;
        D = C; C = B; B = A; A = t1 + t2;
    }
    s->h[0] += A; s->h[1] += B; s->h[2] += C; s->h[3] += D;
    s->h[4] += E; s->h[5] += F; s->h[6] += G; s->h[7] += H;
}

RU_FN void ru_sha_init(RuSha *s)
{
    static const uint32_t h0[8] = {0x6a09e667u, 0xbb67ae85u, 0x3c6ef372u, 0xa54ff53au,
                                   0x510e527fu, 0x9b05688cu, 0x1f83d9abu, 0x5be0cd19u};
    memcpy(s->h, h0, sizeof h0);
    s->n = 0;
    s->used = 0;
}

RU_FN void ru_sha_add(RuSha *s, const void *data, size_t n)
{
    const uint8_t *p = (const uint8_t *)data;
    s->n += n;
    while (n) {
        if (s->used == 0 && n >= 64) {
            ru_sha_block(s, p);
            p += 64;
            n -= 64;
            continue;
        }
        size_t k = 64 - s->used < n ? 64 - s->used : n;
        memcpy(s->buf + s->used, p, k);
        s->used += k;
        p += k;
        n -= k;
        if (s->used == 64) {
            ru_sha_block(s, s->buf);
            s->used = 0;
        }
    }
}

/* the digest as 64 lower-case hex digits and a NUL */
RU_FN void ru_sha_hex(RuSha *s, char hex[65])
{
    uint64_t bits = s->n * 8;
    uint8_t pad = 0x80, zero = 0, len[8];
    ru_sha_add(s, &pad, 1);
    while (s->used != 56) ru_sha_add(s, &zero, 1);
    for (int i = 0; i < 8; i++) len[i] = (uint8_t)(bits >> (56 - 8 * i));
    ru_sha_add(s, len, 8);
    for (int i = 0; i < 8; i++) snprintf(hex + 8 * i, 9, "%08x", (unsigned)s->h[i]);
}

/* ------------------------------------------------------------------------------------- CRC-32 */
RU_FN uint32_t ru_crc32(const uint8_t *p, size_t n)
{
    static uint32_t table[256];
    static volatile int ready;
    if (!ready) {   /* idempotent: two threads fill it with the same values */
        for (uint32_t i = 0; i < 256; i++) {
            uint32_t c = i;
            for (int k = 0; k < 8; k++) c = c & 1 ? 0xedb88320u ^ (c >> 1) : c >> 1;
            table[i] = c;
        }
        ready = 1;
    }
    uint32_t c = 0xffffffffu;
    for (size_t i = 0; i < n; i++) c = table[(c ^ p[i]) & 0xff] ^ (c >> 8);
    return c ^ 0xffffffffu;
}

/* ---------------------------------------------------------------------- inflate (RFC 1951) */
#define RU_FAST 10   /* codes of up to this many bits are found by one table look-up */

typedef struct {
    uint16_t fast[1 << RU_FAST];   /* (length << 9) | symbol, 0: a longer code (the canonical walk) */
    uint16_t count[16];            /* codes per length */
    uint16_t sym[288];             /* symbols ordered by (length, value) */
} RuHuff;

typedef struct {
    const uint8_t *in;
    size_t in_len, in_pos;
    uint64_t bits;
    int nbits;
    uint8_t *out;
    size_t out_len, out_pos;
} RuInflate;

/* the canonical code of `n` lengths; -1 when over-subscribed (an incomplete code is allowed: a
 * code word it lacks is refused when met) */
RU_FN int ru_huff(RuHuff *h, const uint8_t *len, int n)
{
    uint16_t offs[16];
    memset(h->count, 0, sizeof h->count);
    memset(h->fast, 0, sizeof h->fast);
    for (int i = 0; i < n; i++) h->count[len[i]]++;
    h->count[0] = 0;
    int left = 1;
    for (int l = 1; l < 16; l++) {
        left = left * 2 - h->count[l];
        if (left < 0) return -1;
    }
    offs[1] = 0;
    for (int l = 1; l < 15; l++) offs[l + 1] = (uint16_t)(offs[l] + h->count[l]);
    for (int i = 0; i < n; i++)
        if (len[i]) h->sym[offs[len[i]]++] = (uint16_t)i;
    /* the fast table: each code of up to RU_FAST bits, bit-reversed (the stream's order), repeated */
    unsigned code = 0;
    int k = 0;
    for (int l = 1; l <= RU_FAST; l++) {
        for (int j = 0; j < h->count[l]; j++, k++, code++) {
            unsigned rev = 0;
            for (int b = 0; b < l; b++) rev |= ((code >> b) & 1u) << (l - 1 - b);
            for (unsigned e = rev; e < (1u << RU_FAST); e += 1u << l) h->fast[e] = (uint16_t)(l << 9 | h->sym[k]);
        }
        code <<= 1;
    }
    return 0;
}

RU_FN int ru_fill(RuInflate *s, int need)
{
    while (s->nbits <= 56 && s->in_pos < s->in_len) {
        s->bits |= (uint64_t)s->in[s->in_pos++] << s->nbits;
        s->nbits += 8;
    }
    return s->nbits >= need ? 0 : -1;
}

RU_FN int ru_bits(RuInflate *s, int n, unsigned *v)
{
    if (n == 0) { *v = 0; return 0; }
    if (s->nbits < n && ru_fill(s, n) != 0) return -1;
    *v = (unsigned)(s->bits & ((1u << n) - 1));
    s->bits >>= n;
    s->nbits -= n;
    return 0;
}

/* the next symbol of `h`, or -1 (the input ended, or a code the table lacks) */
RU_FN int ru_decode(RuInflate *s, const RuHuff *h)
{
    if (s->nbits < 15) ru_fill(s, 15);
    if (s->nbits >= RU_FAST) {
        unsigned e = h->fast[s->bits & ((1u << RU_FAST) - 1)];
        if (e) {
            s->bits >>= e >> 9;
            s->nbits -= (int)(e >> 9);
            return (int)(e & 511);
        }
    }
    int code = 0, first = 0, index = 0;   /* the canonical walk, one bit at a time */
    for (int l = 1; l < 16; l++) {
        unsigned b;
        if (ru_bits(s, 1, &b) != 0) return -1;
        code |= (int)b;
        int count = h->count[l];
        if (code - first < count) return h->sym[index + code - first];
        index += count;
        first = (first + count) << 1;
        code <<= 1;
    }
    return -1;
}

RU_FN int ru_codes(RuInflate *s, const RuHuff *lit, const RuHuff *dist)
{
    static const uint16_t lbase[29] = {3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59,
                                       67, 83, 99, 115, 131, 163, 195, 227, 258};
    static const uint8_t lextra[29] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4,
                                       5, 5, 5, 5, 0};
    static const uint16_t dbase[30] = {1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193, 257, 385, 513,
                                       769, 1025, 1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577};
    static const uint8_t dextra[30] = {0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7, 8, 8, 9, 9, 10, 10,
                                       11, 11, 12, 12, 13, 13};
    for (;;) {
        int sym = ru_decode(s, lit);
        if (sym < 0) return -1;
        if (sym < 256) {
            if (s->out_pos >= s->out_len) return -1;
            s->out[s->out_pos++] = (uint8_t)sym;
        } else if (sym == 256) {
            return 0;
        } else {
            sym -= 257;
            unsigned extra, dextra_v;
            if (sym >= 29 || ru_bits(s, lextra[sym], &extra) != 0) return -1;
            size_t n = lbase[sym] + extra;
            int d = ru_decode(s, dist);
            if (d < 0 || d >= 30 || ru_bits(s, dextra[d], &dextra_v) != 0) return -1;
            size_t back = dbase[d] + dextra_v;
            if (back > s->out_pos || n > s->out_len - s->out_pos) return -1;
            uint8_t *o = s->out + s->out_pos;
            if (back >= n) memcpy(o, o - back, n);                /* apart: one copy */
            else for (size_t i = 0; i < n; i++) o[i] = o[i - back];   /* overlapping: byte by byte */
            s->out_pos += n;
        }
    }
}

/* Inflate `in` into exactly `out_len` bytes at `out`. 0, or -1 when the data is not a deflate stream
 * of that length. */
RU_FN int ru_inflate(const uint8_t *in, size_t in_len, uint8_t *out, size_t out_len)
{
    static const uint8_t order[19] = {16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15};
    RuInflate s = {in, in_len, 0, 0, 0, out, out_len, 0};
    RuHuff *lit = (RuHuff *)malloc(sizeof *lit), *dist = (RuHuff *)malloc(sizeof *dist);
    int rc = lit && dist ? 0 : -1;
    unsigned last = 0;
    while (rc == 0 && !last) {
        unsigned type;
        if (ru_bits(&s, 1, &last) != 0 || ru_bits(&s, 2, &type) != 0) { rc = -1; break; }
        if (type == 0) {   /* stored: to the byte boundary, then LEN, NLEN and the bytes */
            s.bits >>= s.nbits & 7;
            s.nbits -= s.nbits & 7;
            s.in_pos -= (size_t)(s.nbits / 8);   /* the whole bytes still in the buffer are read again */
            s.bits = 0;
            s.nbits = 0;
            if (s.in_len - s.in_pos < 4) { rc = -1; break; }
            unsigned n = s.in[s.in_pos] | (unsigned)s.in[s.in_pos + 1] << 8;
            unsigned nn = s.in[s.in_pos + 2] | (unsigned)s.in[s.in_pos + 3] << 8;
            s.in_pos += 4;
            if ((n ^ 0xffffu) != nn || n > s.in_len - s.in_pos || n > s.out_len - s.out_pos) { rc = -1; break; }
            memcpy(s.out + s.out_pos, s.in + s.in_pos, n);
            s.in_pos += n;
            s.out_pos += n;
        } else if (type == 1) {   /* the fixed codes */
            uint8_t len[288];
            memset(len, 8, 144);
            memset(len + 144, 9, 112);
            memset(len + 256, 7, 24);
            memset(len + 280, 8, 8);
            rc = ru_huff(lit, len, 288);
            memset(len, 5, 30);
            if (rc == 0) rc = ru_huff(dist, len, 30);
            if (rc == 0) rc = ru_codes(&s, lit, dist);
        } else if (type == 2) {   /* the codes described in the block */
            unsigned hlit, hdist, hclen, v;
            uint8_t len[320] = {0}, cl[19] = {0};
            if (ru_bits(&s, 5, &hlit) || ru_bits(&s, 5, &hdist) || ru_bits(&s, 4, &hclen)) { rc = -1; break; }
            hlit += 257;
            hdist += 1;
            hclen += 4;
            if (hlit > 286 || hdist > 30) { rc = -1; break; }
            for (unsigned i = 0; i < hclen && rc == 0; i++) {
                rc = ru_bits(&s, 3, &v);
                cl[order[i]] = (uint8_t)v;
            }
            if (rc == 0) rc = ru_huff(lit, cl, 19);
            for (unsigned i = 0; rc == 0 && i < hlit + hdist;) {
                int sym = ru_decode(&s, lit);
                unsigned rep = 0, val = 0;
                if (sym < 0) rc = -1;
                else if (sym < 16) { len[i++] = (uint8_t)sym; continue; }
                else if (sym == 16) { if (i == 0 || ru_bits(&s, 2, &rep)) rc = -1; else { val = len[i - 1]; rep += 3; } }
                else if (sym == 17) { if (ru_bits(&s, 3, &rep)) rc = -1; else rep += 3; }
                else { if (ru_bits(&s, 7, &rep)) rc = -1; else rep += 11; }
                if (rc == 0 && i + rep > hlit + hdist) rc = -1;
                while (rc == 0 && rep--) len[i++] = (uint8_t)val;
            }
            if (rc == 0 && len[256] == 0) rc = -1;   /* no end-of-block code */
            if (rc == 0) rc = ru_huff(lit, len, (int)hlit);
            if (rc == 0) rc = ru_huff(dist, len + hlit, (int)hdist);
            if (rc == 0) rc = ru_codes(&s, lit, dist);
        } else {
            rc = -1;
        }
    }
    free(lit);
    free(dist);
    return rc == 0 && s.out_pos == out_len ? 0 : -1;
}

/* ------------------------------------------------------------------------------------ LZMA
 * An LZMA (LZMA1) decoder for the archives' members of zip method 14, written from the format's
 * description (Igor Pavlov's lzma-specification, public domain): a range decoder over adaptive
 * binary probabilities, literals (matched against the byte at the last distance after a match),
 * matches with lengths from two length coders and distances from position slots, reverse bit trees
 * and direct bits, the four last distances. The whole member is the window (its size is known):
 * every distance is checked against what was written, every input byte against the input's end. */
typedef struct { const uint8_t *in; size_t len, pos; uint32_t range, code; int bad; } RuRc;

static inline void ru_rc_norm(RuRc *r)
{
    if (r->range < (1u << 24)) {
        r->range <<= 8;
        r->code = (r->code << 8) | (r->pos < r->len ? r->in[r->pos] : 0);
        if (r->pos++ >= r->len) r->bad = 1;
    }
}

static inline unsigned ru_rc_bit(RuRc *r, uint16_t *p)
{
    uint32_t bound = (r->range >> 11) * *p;
    unsigned b;
    if (r->code < bound) { *p = (uint16_t)(*p + ((2048u - *p) >> 5)); r->range = bound; b = 0; }
    else { *p = (uint16_t)(*p - (*p >> 5)); r->code -= bound; r->range -= bound; b = 1; }
    ru_rc_norm(r);
    return b;
}

static uint32_t ru_rc_direct(RuRc *r, unsigned n)
{
    uint32_t res = 0;
    while (n--) {
        r->range >>= 1;
        r->code -= r->range;
        uint32_t t = 0u - (r->code >> 31);
        r->code += r->range & t;
        if (r->code == r->range) r->bad = 1;
        ru_rc_norm(r);
        res = (res << 1) + (t + 1);
    }
    return res;
}

static unsigned ru_rc_tree(RuRc *r, uint16_t *probs, unsigned bits)
{
    unsigned m = 1;
    for (unsigned i = 0; i < bits; i++) m = (m << 1) + ru_rc_bit(r, &probs[m]);
    return m - (1u << bits);
}

static unsigned ru_rc_tree_rev(RuRc *r, uint16_t *probs, unsigned bits)
{
    unsigned m = 1, sym = 0;
    for (unsigned i = 0; i < bits; i++) {
        unsigned b = ru_rc_bit(r, &probs[m]);
        m = (m << 1) + b;
        sym |= b << i;
    }
    return sym;
}

typedef struct { uint16_t choice, choice2, low[16][8], mid[16][8], high[256]; } RuLzLen;

static unsigned ru_lz_len(RuRc *r, RuLzLen *l, unsigned pos_state)
{
    if (!ru_rc_bit(r, &l->choice)) return ru_rc_tree(r, l->low[pos_state], 3);
    if (!ru_rc_bit(r, &l->choice2)) return 8 + ru_rc_tree(r, l->mid[pos_state], 3);
    return 16 + ru_rc_tree(r, l->high, 8);
}

typedef struct {
    uint16_t is_match[12 << 4], is_rep[12], is_rep_g0[12], is_rep_g1[12], is_rep_g2[12], is_rep0_long[12 << 4];
    uint16_t pos_slot[4][64], pos[115], align[16];
    RuLzLen len, rep_len;
} RuLzProbs;

/* Decode the LZMA data of a zip member (method 14: version, the properties' size 5, lc/lp/pb and
 * the dictionary's size, then the range-coded stream ending with the end marker, as zipfile and
 * liblzma write it) into exactly `out_len` bytes at `out`, the marker right after the last byte. 0,
 * or -1 when the data is not such a stream. */
RU_FN int ru_unlzma(const uint8_t *in, size_t in_len, uint8_t *out, size_t out_len)
{
    if (in_len < 9 || in[2] != 5 || in[3] != 0 || in[4] >= 9 * 5 * 5) return -1;
    unsigned d = in[4], lc = d % 9, lp = (d / 9) % 5, pb = d / 45;
    if (lc + lp > 12) return -1;
    size_t n_lit = (size_t)0x300 << (lc + lp);
    uint16_t *lit = (uint16_t *)malloc(n_lit * sizeof *lit);
    RuLzProbs *p = (RuLzProbs *)malloc(sizeof *p);
    if (!lit || !p) { free(lit); free(p); return -1; }
    for (size_t i = 0; i < n_lit; i++) lit[i] = 1024;
    uint16_t *flat = (uint16_t *)p;
    for (size_t i = 0; i < sizeof *p / sizeof *flat; i++) flat[i] = 1024;
    RuRc r = {in + 9, in_len - 9, 0, 0xFFFFFFFFu, 0, 0};
    if (r.len < 5 || r.in[0] != 0) r.bad = 1;
    for (int i = 1; i < 5 && !r.bad; i++) r.code = (r.code << 8) | r.in[i];
    r.pos = 5;
    if (r.code == r.range) r.bad = 1;
    size_t at = 0;
    uint32_t rep0 = 0, rep1 = 0, rep2 = 0, rep3 = 0;
    unsigned state = 0, pb_mask = (1u << pb) - 1, lp_mask = (1u << lp) - 1;
    int rc = -1;
    while (!r.bad) {
        unsigned ps = (unsigned)at & pb_mask;
        if (!ru_rc_bit(&r, &p->is_match[(state << 4) + ps])) {   /* a literal */
            if (at == out_len) break;
            unsigned prev = at ? out[at - 1] : 0;
            uint16_t *probs = lit + 0x300 * (size_t)((((unsigned)at & lp_mask) << lc) + (prev >> (8 - lc)));
            unsigned sym = 1;
            if (state >= 7) {   /* after a match: against the byte at the last distance */
                if (rep0 >= at) break;
                unsigned mb = out[at - rep0 - 1];
                do {
                    unsigned mbit = (mb >> 7) & 1;
                    mb <<= 1;
                    unsigned b = ru_rc_bit(&r, &probs[((1 + mbit) << 8) + sym]);
                    sym = (sym << 1) | b;
                    if (mbit != b) break;
                } while (sym < 0x100);
            }
            while (sym < 0x100) sym = (sym << 1) | ru_rc_bit(&r, &probs[sym]);
            out[at++] = (uint8_t)sym;
            state = state < 4 ? 0 : (state < 10 ? state - 3 : state - 6);
            continue;
        }
        unsigned len;
        if (ru_rc_bit(&r, &p->is_rep[state])) {   /* one of the last four distances */
            if (at == 0 || at == out_len) break;
            if (!ru_rc_bit(&r, &p->is_rep_g0[state])) {
                if (!ru_rc_bit(&r, &p->is_rep0_long[(state << 4) + ps])) {   /* one byte */
                    if (rep0 >= at) break;
                    out[at] = out[at - rep0 - 1];
                    at++;
                    state = state < 7 ? 9 : 11;
                    continue;
                }
            } else {
                uint32_t dist;
                if (!ru_rc_bit(&r, &p->is_rep_g1[state])) {
                    dist = rep1;
                } else {
                    if (!ru_rc_bit(&r, &p->is_rep_g2[state])) dist = rep2;
                    else { dist = rep3; rep3 = rep2; }
                    rep2 = rep1;
                }
                rep1 = rep0;
                rep0 = dist;
            }
            len = ru_lz_len(&r, &p->rep_len, ps);
            state = state < 7 ? 8 : 11;
        } else {   /* a match: its length, then its distance */
            rep3 = rep2; rep2 = rep1; rep1 = rep0;
            len = ru_lz_len(&r, &p->len, ps);
            state = state < 7 ? 7 : 10;
            unsigned slot = ru_rc_tree(&r, p->pos_slot[len < 3 ? len : 3], 6);
            if (slot < 4) {
                rep0 = slot;
            } else {
                unsigned nd = (slot >> 1) - 1;
                uint32_t dist = (2u | (slot & 1)) << nd;
                if (slot < 14) dist += ru_rc_tree_rev(&r, p->pos + dist - slot, nd);
                else dist += (ru_rc_direct(&r, nd - 4) << 4) + ru_rc_tree_rev(&r, p->align, 4);
                rep0 = dist;
            }
            if (rep0 == 0xFFFFFFFFu) {   /* the end marker */
                rc = at == out_len && r.code == 0 && !r.bad ? 0 : -1;
                break;
            }
            if (at == out_len || rep0 >= at) break;
        }
        len += 2;
        if (rep0 >= at || len > out_len - at) break;
        uint8_t *o = out + at;
        const uint8_t *from = o - rep0 - 1;
        for (unsigned i = 0; i < len; i++) o[i] = from[i];   /* overlapping: byte by byte */
        at += len;
    }
    free(lit);
    free(p);
    return rc;
}

/* ------------------------------------------------------------------- files and private folders */
#ifdef _WIN32
RU_FN int ru_mkdir(const char *p)
{
    wchar_t *w = plat_wide(p);
    int ok = w && CreateDirectoryW(w, NULL);
    if (!ok) errno = w && GetLastError() == ERROR_ALREADY_EXISTS ? EEXIST : ENOENT;
    free(w);
    return ok ? 0 : -1;
}

/* why `p` is not a folder we may use (a folder, not a link or junction), or NULL */
RU_FN const char *ru_private_dir(const char *p, char *why, size_t size)
{
    wchar_t *w = plat_wide(p);
    DWORD a = w ? GetFileAttributesW(w) : INVALID_FILE_ATTRIBUTES;
    free(w);
    if (a == INVALID_FILE_ATTRIBUTES) snprintf(why, size, "%s does not exist", p);
    else if (!(a & FILE_ATTRIBUTE_DIRECTORY) || (a & FILE_ATTRIBUTE_REPARSE_POINT))
        snprintf(why, size, "%s is not a folder (a link, a junction or a file)", p);
    else return NULL;
    return why;
}

RU_FN int ru_create(const char *p, int exec)
{
    (void)exec;
    wchar_t *w = plat_wide(p);
    int fd = w ? _wopen(w, _O_WRONLY | _O_CREAT | _O_EXCL | _O_BINARY | _O_NOINHERIT, _S_IREAD | _S_IWRITE) : -1;
    free(w);
    return fd;
}

RU_FN int ru_rename(const char *from, const char *to)
{
    wchar_t *a = plat_wide(from), *b = plat_wide(to);
    int ok = a && b && MoveFileExW(a, b, 0);
    free(a);
    free(b);
    return ok ? 0 : -1;
}

RU_FN void ru_remove(const char *p, int dir)
{
    wchar_t *w = plat_wide(p);
    if (w) dir ? RemoveDirectoryW(w) : DeleteFileW(w);
    free(w);
}

RU_FN unsigned long ru_pid(void) { return (unsigned long)GetCurrentProcessId(); }

/* an environment variable as UTF-8 in `out`; 0, or -1 when unset or too long */
RU_FN int ru_env(const char *name, char *out, size_t size)
{
    wchar_t wn[64], v[4096];
    if (!MultiByteToWideChar(CP_UTF8, 0, name, -1, wn, 64)) return -1;
    DWORD n = GetEnvironmentVariableW(wn, v, 4096);
    if (n == 0 || n >= 4096) return -1;
    return WideCharToMultiByte(CP_UTF8, 0, v, -1, out, (int)size, NULL, NULL) > 0 ? 0 : -1;
}

RU_FN int ru_absolute(const char *p)
{
    return (((p[0] | 32) >= 'a' && (p[0] | 32) <= 'z' && p[1] == ':' && (p[2] == '/' || p[2] == '\\'))
            || (p[0] == '\\' && p[1] == '\\'));
}

RU_FN int ru_user_cache(char *out, size_t size)
{
    char base[4096];
    if (ru_env("LOCALAPPDATA", base, sizeof base) == 0 && ru_absolute(base))
        return snprintf(out, size, "%s/spurdiff", base) < (int)size ? 0 : -1;
    if (ru_env("USERPROFILE", base, sizeof base) == 0 && ru_absolute(base))
        return snprintf(out, size, "%s/AppData/Local/spurdiff", base) < (int)size ? 0 : -1;
    return -1;
}

RU_FN int ru_temp_cache(char *out, size_t size)
{
    wchar_t w[MAX_PATH + 1];
    char t[4096];
    DWORD n = GetTempPathW(MAX_PATH + 1, w);
    if (n == 0 || n > MAX_PATH || !WideCharToMultiByte(CP_UTF8, 0, w, -1, t, (int)sizeof t, NULL, NULL)) return -1;
    size_t k = strlen(t);
    while (k && (t[k - 1] == '\\' || t[k - 1] == '/')) t[--k] = 0;
    return snprintf(out, size, "%s/spurdiff", t) < (int)size ? 0 : -1;
}

/* FILETIME (100 ns since 1601) as seconds since 1970 */
static double ru_seconds(FILETIME f)
{
    unsigned long long v = (unsigned long long)f.dwHighDateTime << 32 | f.dwLowDateTime;
    return (double)(v - 116444736000000000ULL) / 1e7;
}

/* call `f(ctx, dir, name)` for each entry of the folder `dir` but . and .. (names as UTF-8) */
RU_FN void ru_list(const char *dir, void (*f)(void *, const char *, const char *), void *ctx)
{
    char pat[8200];
    snprintf(pat, sizeof pat, "%s/*", dir);
    wchar_t *w = plat_wide(pat);
    WIN32_FIND_DATAW d;
    HANDLE h = w ? FindFirstFileW(w, &d) : INVALID_HANDLE_VALUE;
    free(w);
    if (h == INVALID_HANDLE_VALUE) return;
    do {
        char name[1024];
        if (wcscmp(d.cFileName, L".") == 0 || wcscmp(d.cFileName, L"..") == 0) continue;
        if (WideCharToMultiByte(CP_UTF8, 0, d.cFileName, -1, name, (int)sizeof name, NULL, NULL) > 0) f(ctx, dir, name);
    } while (FindNextFileW(h, &d));
    FindClose(h);
}

static void ru_rm_entry(void *ctx, const char *dir, const char *name);

/* the folder `p` and everything in it removed; a link or junction inside is removed, never followed */
RU_FN void ru_rm_tree(const char *p)
{
    ru_list(p, ru_rm_entry, NULL);
    ru_remove(p, 1);
}

static void ru_rm_entry(void *ctx, const char *dir, const char *name)
{
    (void)ctx;
    char p[8200];
    if (snprintf(p, sizeof p, "%s/%s", dir, name) >= (int)sizeof p) return;
    wchar_t *w = plat_wide(p);
    DWORD a = w ? GetFileAttributesW(w) : INVALID_FILE_ATTRIBUTES;
    if (a != INVALID_FILE_ATTRIBUTES && (a & FILE_ATTRIBUTE_DIRECTORY) && !(a & FILE_ATTRIBUTE_REPARSE_POINT)) {
        free(w);
        ru_rm_tree(p);
        return;
    }
    if (w && a != INVALID_FILE_ATTRIBUTES) {
        SetFileAttributesW(w, FILE_ATTRIBUTE_NORMAL);   /* a read-only file, too */
        (a & FILE_ATTRIBUTE_DIRECTORY) ? RemoveDirectoryW(w) : DeleteFileW(w);
    }
    free(w);
}

static int ru_attr_time(const char *p, int dir, double *when)
{
    WIN32_FILE_ATTRIBUTE_DATA d;
    wchar_t *w = plat_wide(p);
    int ok = w && GetFileAttributesExW(w, GetFileExInfoStandard, &d)
             && !(d.dwFileAttributes & FILE_ATTRIBUTE_REPARSE_POINT)
             && !!(d.dwFileAttributes & FILE_ATTRIBUTE_DIRECTORY) == dir;
    free(w);
    if (ok) *when = ru_seconds(d.ftLastWriteTime);
    return ok;
}

/* `p` a folder (not a link or junction: Windows folders have access lists, not owners): 1 with its time */
RU_FN int ru_own_dir_time(const char *p, double *when) { return ru_attr_time(p, 1, when); }

RU_FN int ru_file_time(const char *p, double *when) { return ru_attr_time(p, 0, when); }

RU_FN void ru_touch(const char *p)
{
    wchar_t *w = plat_wide(p);
    HANDLE h = w ? CreateFileW(w, FILE_WRITE_ATTRIBUTES, FILE_SHARE_READ | FILE_SHARE_WRITE | FILE_SHARE_DELETE, NULL,
                               OPEN_EXISTING, FILE_FLAG_OPEN_REPARSE_POINT, NULL)
                 : INVALID_HANDLE_VALUE;
    free(w);
    if (h == INVALID_HANDLE_VALUE) return;
    FILETIME now;
    GetSystemTimeAsFileTime(&now);
    SetFileTime(h, NULL, NULL, &now);
    CloseHandle(h);
}

RU_FN int ru_pid_gone(unsigned long pid)
{
    HANDLE h = OpenProcess(SYNCHRONIZE, FALSE, (DWORD)pid);
    if (!h) return GetLastError() == ERROR_INVALID_PARAMETER;   /* no such process (not: not ours to open) */
    DWORD r = WaitForSingleObject(h, 0);
    CloseHandle(h);
    return r == WAIT_OBJECT_0;                                   /* it has ended */
}

RU_FN double ru_now(void)
{
    FILETIME now;
    GetSystemTimeAsFileTime(&now);
    return ru_seconds(now);
}
#else
RU_FN int ru_mkdir(const char *p) { return mkdir(p, 0700); }

/* why a folder above `p` could let another user move `p` away and put another in its place (not
 * ours or root's, or writable by others and not sticky; group-writable by our own group allowed,
 * as harness/common/private_dir.py), or NULL. A link above is judged by its target. */
RU_FN const char *ru_ancestors(const char *p, char *why, size_t size)
{
    char up[4096];
    if (snprintf(up, sizeof up, "%s", p) >= (int)sizeof up) {
        snprintf(why, size, "%.200s...: too long", p);
        return why;
    }
    for (char *slash = strrchr(up, '/'); slash; slash = strrchr(up, '/')) {
        if (slash == up) slash[1] = 0;   /* "/" itself, then done */
        else *slash = 0;
        struct stat st;
        if (stat(up, &st) == 0) {
            int open_to = (st.st_mode & 002) || ((st.st_mode & 020) && st.st_gid != getegid());
            if (st.st_uid != 0 && st.st_uid != geteuid())
                snprintf(why, size, "the folder above it, %s, belongs to uid %lu, not to this user or root", up,
                         (unsigned long)st.st_uid);
            else if (open_to && !(st.st_mode & S_ISVTX))
                snprintf(why, size, "the folder above it, %s, is writable by others (mode %03o, not sticky)", up,
                         (unsigned)(st.st_mode & 0777));
            else open_to = -1;
            if (open_to != -1) return why;
        }
        if (slash == up) break;
    }
    return NULL;
}

RU_FN const char *ru_private_dir(const char *p, char *why, size_t size)
{
    struct stat st;
    if (lstat(p, &st) != 0) snprintf(why, size, "%s: %s", p, strerror(errno));
    else if (!S_ISDIR(st.st_mode)) snprintf(why, size, "%s is not a folder (a link or a file)", p);
    else if (st.st_uid != geteuid())
        snprintf(why, size, "%s belongs to uid %lu, not to this user (%lu)", p, (unsigned long)st.st_uid,
                 (unsigned long)geteuid());
    else if (st.st_mode & 077)
        snprintf(why, size, "%s has mode %03o: others can read or write it (0700 expected)", p,
                 (unsigned)(st.st_mode & 0777));
    else return ru_ancestors(p, why, size);
    return why;
}

RU_FN int ru_create(const char *p, int exec)
{
    return open(p, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, exec ? 0700 : 0600);
}

RU_FN int ru_rename(const char *from, const char *to) { return rename(from, to); }

RU_FN void ru_remove(const char *p, int dir) { dir ? rmdir(p) : unlink(p); }

RU_FN unsigned long ru_pid(void) { return (unsigned long)getpid(); }

static int ru_rm_one(const char *p, const struct stat *st, int flag, struct FTW *ftw)
{
    (void)st;
    (void)ftw;
    return flag == FTW_DP ? rmdir(p) : unlink(p);
}

/* the folder `p` and everything in it removed, no link followed */
RU_FN void ru_rm_tree(const char *p) { nftw(p, ru_rm_one, 16, FTW_DEPTH | FTW_PHYS); }

/* `p` a folder of this user's (not a link): 1 with its modification time (seconds since 1970) */
RU_FN int ru_own_dir_time(const char *p, double *when)
{
    struct stat st;
    if (lstat(p, &st) != 0 || !S_ISDIR(st.st_mode) || st.st_uid != geteuid()) return 0;
    *when = (double)st.st_mtime;
    return 1;
}

/* `p` a regular file (not a link): 1 with its modification time */
RU_FN int ru_file_time(const char *p, double *when)
{
    struct stat st;
    if (lstat(p, &st) != 0 || !S_ISREG(st.st_mode)) return 0;
    *when = (double)st.st_mtime;
    return 1;
}

RU_FN void ru_touch(const char *p) { utimensat(AT_FDCWD, p, NULL, AT_SYMLINK_NOFOLLOW); }

/* the process `pid` is gone (not merely another user's) */
RU_FN int ru_pid_gone(unsigned long pid) { return pid != 0 && kill((pid_t)pid, 0) != 0 && errno == ESRCH; }

RU_FN double ru_now(void) { return (double)time(NULL); }

/* call `f(ctx, name)` for each entry of the folder `dir` but . and .. */
RU_FN void ru_list(const char *dir, void (*f)(void *, const char *, const char *), void *ctx)
{
    DIR *d = opendir(dir);
    if (!d) return;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0) f(ctx, dir, e->d_name);
    closedir(d);
}

RU_FN int ru_env(const char *name, char *out, size_t size)
{
    const char *v = getenv(name);
    return v && *v && snprintf(out, size, "%s", v) < (int)size ? 0 : -1;
}

RU_FN int ru_absolute(const char *p) { return p[0] == '/'; }

RU_FN int ru_user_cache(char *out, size_t size)
{
    char base[4096];
    if (ru_env("XDG_CACHE_HOME", base, sizeof base) == 0 && ru_absolute(base))
        return snprintf(out, size, "%s/spurdiff", base) < (int)size ? 0 : -1;
    if (ru_env("HOME", base, sizeof base) != 0 || !ru_absolute(base)) {
        struct passwd *pw = getpwuid(geteuid());   /* no HOME: the account's */
        if (!pw || !pw->pw_dir || !ru_absolute(pw->pw_dir)) return -1;
        snprintf(base, sizeof base, "%s", pw->pw_dir);
    }
    return snprintf(out, size, "%s/.cache/spurdiff", base) < (int)size ? 0 : -1;
}

RU_FN int ru_temp_cache(char *out, size_t size)
{
    char t[4096];
    if (ru_env("TMPDIR", t, sizeof t) != 0 || !ru_absolute(t)) snprintf(t, sizeof t, "/tmp");
    return snprintf(out, size, "%s/spurdiff-%lu", t, (unsigned long)geteuid()) < (int)size ? 0 : -1;
}
#endif

/* `path` and its missing parents made (new ones private); 0, or -1 */
RU_FN int ru_make_dirs(char *path)
{
    if (plat_is_dir(path)) return 0;
    for (char *p = path + 1; *p; p++) {
        if (*p != '/' && *p != '\\') continue;
        char c = *p;
        *p = 0;
        int skip = p[-1] == ':' || plat_is_dir(path);   /* a drive ("C:") or a folder that is there */
        if (!skip && ru_mkdir(path) != 0 && errno != EEXIST) { *p = c; return -1; }
        *p = c;
    }
    return ru_mkdir(path) == 0 || errno == EEXIST ? 0 : -1;
}

#define RU_UNUSED_S (30.0 * 24 * 3600)   /* a runtime folder no start used for this long is removed */

static void ru_sweep_one(void *ctx, const char *base, const char *name)
{
    (void)ctx;
    unsigned long pid = 0;
    char key[17], end, p[8192], marker[8300];
    double when, now = ru_now();
    int temp = strncmp(name, ".python-", 8) == 0 && sscanf(name + 8, "%16[0-9a-f].%lu.", key, &pid) == 2;
    int old = !temp && strncmp(name, "python-", 7) == 0 && strlen(name) == 23
              && sscanf(name + 7, "%16[0-9a-f]%c", key, &end) == 1;
    /* numpy's folders, which FMUs of earlier builds unpacked beside the runtimes (marker .spurdiff-numpy) */
    int numpy = !temp && !old && strncmp(name, "numpy-", 6) == 0 && strlen(name) == 22
                && sscanf(name + 6, "%16[0-9a-f]%c", key, &end) == 1;
    if (!temp && !old && !numpy) return;
    if (snprintf(p, sizeof p, "%s/%s", base, name) >= (int)sizeof p || !ru_own_dir_time(p, &when)) return;
    if (temp && (now - when < 600 || !ru_pid_gone(pid))) return;
    if (old || numpy) {
        snprintf(marker, sizeof marker, "%s/%s", p, numpy ? ".spurdiff-numpy" : RU_MARKER);
        if (!ru_file_time(marker, &when) || now - when < RU_UNUSED_S) return;
    }
    ru_rm_tree(p);
}

/* Removed from `base` before an unpack (links and junctions never followed, only folders of this
 * user's; on Windows, folders that are not reparse points):
 * - the temporary folders of unpacks whose process died (killed halfway): .python-<key>.<pid>.<n>,
 *   that pid gone, untouched for ten minutes (an unpack takes about a second);
 * - the folders of other runtimes (python-<16 hex digits>) whose marker no start touched for
 *   RU_UNUSED_S (every start that uses a folder touches its marker: ru_runtime_root);
 * - the same for numpy's folders (numpy-<16 hex digits>, marker .spurdiff-numpy), which the FMUs of
 *   earlier builds unpacked there and touched at each use (today's carry no numpy).
 * Nothing else is touched. */
RU_FN void ru_sweep(const char *base) { ru_list(base, ru_sweep_one, NULL); }

/* a usable base folder (made if missing, then checked private) in `out`; else -1 and why */
RU_FN int ru_base(char *out, size_t size, char *why, size_t wsize)
{
    char first[4096] = "";
    if (ru_env(RU_ENV, out, size) == 0) {
        if (!ru_absolute(out)) {
            snprintf(why, wsize, "%s=%s is not an absolute path", RU_ENV, out);
            return -1;
        }
        if (ru_make_dirs(out) != 0) {
            snprintf(why, wsize, "%s=%s cannot be made: %s", RU_ENV, out, strerror(errno));
            return -1;
        }
        return ru_private_dir(out, why, wsize) ? -1 : 0;
    }
    if (ru_user_cache(out, size) == 0) {
        if (ru_make_dirs(out) != 0) snprintf(first, sizeof first, "%.3000s cannot be made: %s", out, strerror(errno));
        else if (!ru_private_dir(out, first, sizeof first)) return 0;
    } else {
        snprintf(first, sizeof first, "no user cache folder (no HOME)");
    }
    if (ru_temp_cache(out, size) == 0 && (ru_make_dirs(out) == 0 || errno == EEXIST)) {
        char second[4096];
        if (!ru_private_dir(out, second, sizeof second)) return 0;
        snprintf(why, wsize, "%s; %s", first, second);
        return -1;
    }
    snprintf(why, wsize, "%s; no temporary folder either", first);
    return -1;
}

/* ---------------------------------------------------------------------------- the zip archives */
static inline unsigned ru_u16(const uint8_t *p) { return p[0] | (unsigned)p[1] << 8; }
static inline uint32_t ru_u32(const uint8_t *p) { return p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24; }

/* a member name that stays inside the folder: relative, '/'-separated, no empty, '.' or '..'
 * component, no '\' or ':' (a drive, a stream), no control character */
RU_FN int ru_name_ok(const char *n, size_t len)
{
    if (len == 0 || len > 1000 || n[0] == '/') return 0;
    size_t start = 0;
    for (size_t i = 0; i <= len; i++) {
        if (i < len && ((unsigned char)n[i] < 32 || n[i] == '\\' || n[i] == ':')) return 0;
        if (i == len || n[i] == '/') {
            size_t k = i - start;
            if (i == len && k == 0) break;   /* a folder's trailing '/' */
            if (k == 0 || (k == 1 && n[start] == '.') || (k == 2 && n[start] == '.' && n[start + 1] == '.')) return 0;
            start = i + 1;
        }
    }
    return 1;
}

typedef struct { char **p; int *dir; int n, cap; } RuMade;   /* what an unpack made, to undo it */

RU_FN int ru_made(RuMade *m, const char *p, int dir)
{
    if (m->n == m->cap) {
        int cap = m->cap ? 2 * m->cap : 256;
        char **np = (char **)realloc(m->p, (size_t)cap * sizeof *np);
        if (!np) return -1;
        m->p = np;
        int *nd = (int *)realloc(m->dir, (size_t)cap * sizeof *nd);
        if (!nd) return -1;
        m->dir = nd;
        m->cap = cap;
    }
    size_t k = strlen(p) + 1;
    if (!(m->p[m->n] = (char *)malloc(k))) return -1;
    memcpy(m->p[m->n], p, k);
    m->dir[m->n++] = dir;
    return 0;
}

RU_FN void ru_undo(RuMade *m, int remove)
{
    for (int i = m->n - 1; i >= 0; i--) {
        if (remove) ru_remove(m->p[i], m->dir[i]);
        free(m->p[i]);
    }
    free(m->p);
    free(m->dir);
    memset(m, 0, sizeof *m);
}

/* the folders of `rel` below `dir` made (recorded in `m`) */
RU_FN int ru_parents(const char *dir, const char *rel, RuMade *m)
{
    char p[8192];
    for (const char *s = strchr(rel, '/'); s; s = strchr(s + 1, '/')) {
        if (snprintf(p, sizeof p, "%s/%.*s", dir, (int)(s - rel), rel) >= (int)sizeof p) return -1;
        if (plat_is_dir(p)) continue;
        if (ru_mkdir(p) != 0 || ru_made(m, p, 1) != 0) return -1;
    }
    return 0;
}

RU_FN int ru_write_all(int fd, const uint8_t *p, size_t n)
{
    while (n) {
        int k = (int)(n > (1u << 30) ? (1u << 30) : n);
        int w = (int)write(fd, p, (unsigned)k);
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return -1;
        p += w;
        n -= (size_t)w;
    }
    return 0;
}

/* Unpack the zip `data` (`len` bytes, named `what` in messages) into the folder `dir`. */
RU_FN int ru_unzip(const uint8_t *data, size_t len, const char *what, const char *dir, RuMade *m, char *err,
                   size_t errsize)
{
    size_t eocd = 0;
    int found = 0;
    for (size_t back = 22; back <= len && back <= 22 + 65535; back++)
        if (ru_u32(data + len - back) == 0x06054b50u) { eocd = len - back; found = 1; break; }
    if (!found) { snprintf(err, errsize, "%s is not a zip archive (the FMU is damaged)", what); return -1; }
    const uint8_t *e = data + eocd;
    unsigned entries = ru_u16(e + 10);
    uint32_t cd_size = ru_u32(e + 12), cd_off = ru_u32(e + 16);
    if (ru_u16(e + 4) || ru_u16(e + 6) || (uint64_t)cd_off + cd_size > eocd) {
        snprintf(err, errsize, "%s has a damaged directory (the FMU is damaged)", what);
        return -1;
    }
    size_t pos = cd_off;
    for (unsigned i = 0; i < entries; i++) {
        if (pos + 46 > (size_t)cd_off + cd_size || ru_u32(data + pos) != 0x02014b50u) {
            snprintf(err, errsize, "%s: its directory's entry %u is damaged", what, i);
            return -1;
        }
        const uint8_t *c = data + pos;
        unsigned flags = ru_u16(c + 8), method = ru_u16(c + 10), nlen = ru_u16(c + 28);
        uint32_t crc = ru_u32(c + 16), csize = ru_u32(c + 20), usize = ru_u32(c + 24), lho = ru_u32(c + 42);
        uint32_t attr = ru_u32(c + 38);
        const char *name = (const char *)c + 46;
        pos += 46 + nlen + ru_u16(c + 30) + ru_u16(c + 32);
        if (pos > (size_t)cd_off + cd_size) {
            snprintf(err, errsize, "%s: its directory's entry %u is damaged", what, i);
            return -1;
        }
        if (!ru_name_ok(name, nlen)) {
            snprintf(err, errsize, "%s: member '%.*s' is not a relative name inside the folder", what, (int)(nlen > 200 ? 200 : nlen), name);
            return -1;
        }
        if ((flags & 1) || (method != 0 && method != 8 && !(method == 14 && (flags & 2))) || usize > RU_MAX_MEMBER) {
            snprintf(err, errsize, "%s: member '%.*s' is encrypted, of method %u or too large", what, (int)nlen, name, method);
            return -1;
        }
        if ((size_t)lho + 30 > len || ru_u32(data + lho) != 0x04034b50u) {
            snprintf(err, errsize, "%s: member '%.*s' has no local header", what, (int)nlen, name);
            return -1;
        }
        size_t at = (size_t)lho + 30 + ru_u16(data + lho + 26) + ru_u16(data + lho + 28);
        if (at > len || csize > len - at) {
            snprintf(err, errsize, "%s: member '%.*s' runs past the archive's end", what, (int)nlen, name);
            return -1;
        }
        char rel[1024], file[8192];
        memcpy(rel, name, nlen);
        rel[nlen] = 0;
        if (snprintf(file, sizeof file, "%s/%s", dir, rel) >= (int)sizeof file) {
            snprintf(err, errsize, "%s: the path of member '%s' is too long", what, rel);
            return -1;
        }
        if (ru_parents(dir, rel, m) != 0) {
            snprintf(err, errsize, "cannot make the folders of %s: %s", file, strerror(errno));
            return -1;
        }
        if (rel[nlen - 1] == '/') {   /* a folder: made above */
            file[strlen(file) - 1] = 0;
            if (!plat_is_dir(file) && (ru_mkdir(file) != 0 || ru_made(m, file, 1) != 0)) {
                snprintf(err, errsize, "cannot make %s: %s", file, strerror(errno));
                return -1;
            }
            continue;
        }
        uint8_t *out = (uint8_t *)malloc(usize ? usize : 1);
        if (!out) { snprintf(err, errsize, "out of memory unpacking %s", what); return -1; }
        int bad = method == 0 ? (csize != usize || (memcpy(out, data + at, usize), 0))
                  : method == 8 ? ru_inflate(data + at, csize, out, usize)
                                : ru_unlzma(data + at, csize, out, usize);
        if (bad || ru_crc32(out, usize) != crc) {
            free(out);
            snprintf(err, errsize, "%s: member '%s' does not unpack to its size and CRC-32 (the FMU is damaged)", what, rel);
            return -1;
        }
        int fd = ru_create(file, (int)((attr >> 16) & 0111));
        int ok = fd >= 0 && ru_made(m, file, 0) == 0 && ru_write_all(fd, out, usize) == 0;
        if (fd >= 0 && close(fd) != 0) ok = 0;
        free(out);
        if (!ok) {
            snprintf(err, errsize, "cannot write %s: %s", file, strerror(errno));
            return -1;
        }
    }
    return 0;
}

/* The folder holding the runtime unpacked from the `n` archives `rel[i]` (resource-relative paths,
 * SHA-256 `hex[i]`), made if needed, in `out`. 0, or -1 with one line in `err`. */
RU_FN int ru_runtime_root(const char *resources, int n, char *const *rel, char *const *hex, char *out, size_t size,
                          char *err, size_t errsize)
{
    char base[4096], why[8192], key[65], marker[8300];
    RuSha s;
    ru_sha_init(&s);
    for (int i = 0; i < n; i++) {
        ru_sha_add(&s, hex[i], strlen(hex[i]));
        ru_sha_add(&s, "\n", 1);
    }
    ru_sha_hex(&s, key);
    if (ru_base(base, sizeof base, why, sizeof why) != 0) {
        snprintf(err, errsize, "no private folder to unpack the FMU's Python runtime into (%s)", why);
        return -1;
    }
    if (snprintf(out, size, "%s/python-%.16s", base, key) >= (int)size) {
        snprintf(err, errsize, "the runtime folder's path %s is too long", base);
        return -1;
    }
    for (int attempt = 0; attempt < 2; attempt++) {
        snprintf(marker, sizeof marker, "%s/%s", out, RU_MARKER);
        if (plat_is_dir(out) || attempt) {   /* there (or renamed there by another process meanwhile) */
            if (ru_private_dir(out, why, sizeof why)) {
                snprintf(err, errsize, "the FMU's runtime folder is refused: %s", why);
                return -1;
            }
            size_t got = 0;
            char *text = cfg_slurp(marker, 128, &got, why, sizeof why);
            int same = text && got >= 64 && memcmp(text, key, 64) == 0;
            free(text);
            if (same) {
                ru_touch(marker);   /* used now (ru_sweep keeps it) */
                return 0;
            }
            snprintf(err, errsize, "the FMU's runtime folder is refused: %s does not name this runtime (%.16s); "
                     "remove the folder", marker, key);
            return -1;
        }
        /* unpack into a fresh private folder beside it, then rename */
        ru_sweep(base);
        static unsigned long counter;
        char tmp[4200];
        RuMade made = {0};
        int rc = -1;
        for (int k = 0; k < 100; k++) {
            snprintf(tmp, sizeof tmp, "%s/.python-%.16s.%lu.%lu", base, key, ru_pid(), ++counter);
            if (ru_mkdir(tmp) == 0) { rc = 0; break; }
            if (errno != EEXIST) break;
        }
        if (rc != 0) {
            snprintf(err, errsize, "cannot make a folder in %s: %s", base, strerror(errno));
            return -1;
        }
        for (int i = 0; i < n && rc == 0; i++) {
            char file[8192];
            size_t len = 0;
            snprintf(file, sizeof file, "%s/%s", resources, rel[i]);
            uint8_t *data = (uint8_t *)cfg_slurp(file, RU_MAX_ARCHIVE, &len, err, errsize);
            if (!data) { rc = -1; break; }
            char got[65];
            RuSha a;
            ru_sha_init(&a);
            ru_sha_add(&a, data, len);
            ru_sha_hex(&a, got);
            if (strcmp(got, hex[i]) != 0) {
                snprintf(err, errsize, "%s has SHA-256 %.16s..., not the %.16s... the runtime description names "
                         "(the FMU is damaged)", file, got, hex[i]);
                rc = -1;
            } else {
                rc = ru_unzip(data, len, file, tmp, &made, err, errsize);
            }
            free(data);
        }
        if (rc == 0) {
            char mfile[4300];
            snprintf(mfile, sizeof mfile, "%s/%s", tmp, RU_MARKER);
            int fd = ru_create(mfile, 0);
            char line[66];
            snprintf(line, sizeof line, "%s\n", key);
            int ok = fd >= 0 && ru_made(&made, mfile, 0) == 0 && ru_write_all(fd, (const uint8_t *)line, 65) == 0;
            if (fd >= 0 && close(fd) != 0) ok = 0;
            if (!ok) {
                snprintf(err, errsize, "cannot write %s: %s", mfile, strerror(errno));
                rc = -1;
            }
        }
        if (rc == 0 && ru_rename(tmp, out) == 0) {
            ru_undo(&made, 0);
            return 0;
        }
        ru_undo(&made, 1);
        ru_remove(tmp, 1);
        if (rc != 0) return -1;
        /* the rename failed: another process's folder is there now (checked in the next round) */
        if (!plat_is_dir(out)) {
            snprintf(err, errsize, "cannot rename the unpacked runtime to %s: %s", out, strerror(errno));
            return -1;
        }
    }
    return -1;
}

#endif
