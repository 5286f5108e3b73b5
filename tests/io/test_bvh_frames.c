#define _POSIX_C_SOURCE 200809L
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF /* the references round as the library does */
#endif
/* The BVH reader's MOTION kernels (libmlayer/io/bvh_frames.c, compiled in here). The whole-line
 * number kernel, on a CPU that has it, must take every frame line of every real clip and random
 * lines of numbers, give strtod's double bit for bit, and decline (leave to the careful parser,
 * which reports the error) every line that holds something other than C numbers. The frame
 * kernels (portable, AVX2, AVX-512) must give the same bits on random conversion plans, those of
 * common__quat_from_euler_half on the sines and cosines of the half-angles. The reader-level checks
 * are in test_bvh.c. */
#include "mlr_test.h"

#include "io/bvh_frames.c"
#include "common/mlr_internal.h" /* common__quat_from_euler_half: the reference product */
#include "io/numparse.c"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Axes and parity of the Euler orders as mlr_quat.h numbers them (quat.c's tables are not
 * compiled in here). */
static const unsigned char ref_axes[6][3] = {
    {0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0},
};
static const double ref_parity[6] = {1.0, -1.0, -1.0, 1.0, 1.0, -1.0};

/* Text placed before every line: the kernel reads up to 16 bytes before a token's end. */
static const char prefix[] = "Frame Time: 0.033333\n";

static bvh_kernels kernels(void)
{
    bvh_kernels k;
    bvh_kernels_pick(&k, BVH_KERNELS_BEST);
    return k;
}

/* Line kernel variant v (0: AVX-512, 1: AVX2, 2: AVX-512 with VBMI2) in k.line, NULL when
 * this CPU lacks it. */
static bvh_kernels line_variant(int v)
{
    bvh_kernels k;
    bvh_kernels_pick(&k, BVH_KERNELS_PORTABLE);
#ifdef BVH_X86
    const int isa = cpu__isa(MLR_ISA_BEST);
    if (v == 0 && isa >= MLR_ISA_AVX512)
        k.line = line_avx512;
    if (v == 1 && isa >= MLR_ISA_AVX2)
        k.line = line_avx2;
    if (v == 2 && isa >= MLR_ISA_AVX512_VBMI2)
        k.line = line_vbmi2;
#else
    (void)v;
#endif
    return k;
}

/* A copy of prefix + line in a block of exactly that size (so that ASan sees any overread). */
static char *framed(const char *line, size_t len, const char **start, const char **end)
{
    size_t pl = sizeof prefix - 1;
    char *b = malloc(pl + len);
    ck_assert_ptr_nonnull(b);
    memcpy(b, prefix, pl);
    memcpy(b + pl, line, len);
    *start = b + pl;
    *end = b + pl + len;
    return b;
}

/* Run the kernel on line[0, len) holding C values; returns its verdict and checks, when it
 * takes the line, every value against strtod and the line end against the first CR/LF. */
static int run_line(const bvh_kernels *k, const char *line, size_t len, size_t C)
{
    const char *p, *end, *le = NULL;
    char *b = framed(line, len, &p, &end);
    const char **ends = malloc((C + 16) * sizeof *ends);
    double *row = malloc(((C + 7) / 8 * 8 + 8) * sizeof *row);
    ck_assert(ends && row);
    int ok = k->line(p, end, C, ends, row, &le);
    if (ok) {
        const char *q = p, *eol = p;
        while (eol < end && *eol != '\n' && *eol != '\r')
            eol++;
        ck_assert_ptr_eq(le, eol);
        char tmp[64];
        for (size_t c = 0; c < C; c++) {
            while (*q == ' ' || *q == '\t')
                q++;
            size_t n = 0;
            while (q + n < eol && q[n] != ' ' && q[n] != '\t')
                n++;
            ck_assert(n > 0 && n < sizeof tmp);
            memcpy(tmp, q, n);
            tmp[n] = '\0';
            const double ref = strtod(tmp, NULL);
            ck_assert_msg(memcmp(&ref, &row[c], sizeof ref) == 0, "'%s': %.17g, strtod %.17g", tmp,
                          row[c], ref);
            q += n;
        }
    }
    free(row);
    free(ends);
    free(b);
    return ok;
}

/* A random number of the form the kernel takes, of 1 to `bytes` bytes: a sign, digits, at
 * most one dot ("-12.3456", "7", ".5", "-3.", "12345678", ...). */
static size_t random_token(mlr_test_rng *r, size_t bytes, char *t)
{
    size_t n = 0;
    const int neg = (int)(mlr_test_rng_u64(r) & 1);
    if (neg)
        t[n++] = '-';
    const size_t room = bytes - (size_t)neg;
    const int dot = (int)(mlr_test_rng_u64(r) % 4) != 0;
    size_t digits = 1 + (size_t)(mlr_test_rng_u64(r) % (room - (size_t)dot));
    if (bytes > 8 && mlr_test_rng_u64(r) % 3 == 0) /* short tokens are common in real files */
        digits = 1 + (size_t)(mlr_test_rng_u64(r) % 3);
    const size_t at = dot ? (size_t)(mlr_test_rng_u64(r) % (digits + 1)) : SIZE_MAX;
    for (size_t i = 0; i < digits; i++) {
        if (i == at)
            t[n++] = '.';
        t[n++] = (char)('0' + mlr_test_rng_u64(r) % 10);
    }
    if (at == digits)
        t[n++] = '.';
    t[n] = '\0';
    return n;
}

/* Up to 15 bytes: the kernel's four-at-once lanes (and one-at-a-time below them). */
static size_t simple_token(mlr_test_rng *r, char *t) { return random_token(r, 15, t); }

/* Up to 8 bytes: the kernel's eight-at-once path. */
static size_t short_token(mlr_test_rng *r, char *t) { return random_token(r, 8, t); }

/* A random line of C simple tokens with varied blanks and line end; returns its length. */
static size_t simple_line(mlr_test_rng *r, size_t C, char *buf)
{
    static const char *const seps[] = {" ", " ", " ", "\t", "  ", " \t ", "\t\t"};
    static const char *const eols[] = {"\n", "\r\n", "\r", "", "\r\n"};
    size_t n = 0;
    if (mlr_test_rng_u64(r) % 8 == 0)
        buf[n++] = ' ';
    for (size_t c = 0; c < C; c++) {
        if (c)
            n += (size_t)sprintf(buf + n, "%s", seps[mlr_test_rng_u64(r) % MLR_COUNTOF(seps)]);
        n += simple_token(r, buf + n);
    }
    if (mlr_test_rng_u64(r) % 8 == 0)
        buf[n++] = '\t';
    n += (size_t)sprintf(buf + n, "%s", eols[mlr_test_rng_u64(r) % MLR_COUNTOF(eols)]);
    return n;
}

START_TEST(line_kernel_takes_every_line_of_every_clip)
{
    static const char *const files[] = {
        "cmu_01_01_playground_jumps.bvh", "cmu_131_01_mj_style_walk.bvh",
        "cmu_10_01_soccer_kick.bvh",      "cmu_60_10_salsa_dance.bvh",
        "cmu_02_03_run_jog_25fps.bvh",    "lafan1_clip_a.bvh",
        "bandai1_walk_happy_001.bvh",     "ai4a_dog_D1_008_KAN01_002.bvh",
    };
    const bvh_kernels k = line_variant(_i / 8);
    if (!k.line)
        return; /* no such kernel on this CPU: the careful parser or the other kernel reads */
    char path[4096];
    const char *file = files[_i % 8];
    MLR_TEST_NEED_CLIP(file);
    mlr_test_clip_path(file, path, sizeof path);
    FILE *fp = fopen(path, "rb");
    ck_assert_ptr_nonnull(fp);
    fseek(fp, 0, SEEK_END);
    const size_t len = (size_t)ftell(fp);
    fseek(fp, 0, SEEK_SET);
    char *text = malloc(len);
    ck_assert_ptr_nonnull(text);
    ck_assert_uint_eq(fread(text, 1, len, fp), len);
    fclose(fp);
    const char *end = text + len, *p = text;
    while (p < end && strncmp(p, "Frame Time:", 11) != 0)
        p = (const char *)memchr(p, '\n', (size_t)(end - p)) + 1;
    p = (const char *)memchr(p, '\n', (size_t)(end - p)) + 1;
    size_t C = 0, lines = 0;
    for (const char *q = p; *q != '\r' && *q != '\n'; q++)
        C += (q[0] != ' ' && q[0] != '\t') && (q == p || q[-1] == ' ' || q[-1] == '\t');
    const char **ends = malloc((C + 16) * sizeof *ends);
    double *row = malloc((C + 16) * sizeof *row);
    ck_assert(ends && row);
    while (p < end) {
        const char *le = NULL;
        ck_assert_msg(k.line(p, end, C, ends, row, &le), "%s: line %zu of the frames declined",
                      file, lines + 1);
        const char *q = p;
        for (size_t c = 0; c < C; c++) {
            char *e;
            const double ref = strtod(q, &e);
            ck_assert_msg(memcmp(&ref, &row[c], sizeof ref) == 0,
                          "%s: frame %zu value %zu: %.17g, strtod %.17g", file, lines + 1, c + 1,
                          row[c], ref);
            q = e;
        }
        while (q < end && (*q == ' ' || *q == '\t'))
            q++;
        ck_assert_ptr_eq(le, q);
        p = le;
        if (p < end && *p == '\r')
            p++;
        if (p < end && *p == '\n')
            p++;
        lines++;
    }
    ck_assert_uint_gt(lines, 100);
    free(row);
    free(ends);
    free(text);
}
END_TEST

/* Kernel variant v on 3000 random lines from make (C values, 1 to 40, every tenth line up to
 * 400): every line taken, every value exact. */
static void takes_random_lines(int v, uint64_t seed,
                               size_t (*make)(mlr_test_rng *r, size_t C, char *buf))
{
    const bvh_kernels k = line_variant(v);
    if (!k.line)
        return;
    mlr_test_rng r;
    mlr_test_rng_seed(&r, seed);
    char *buf = malloc(400 * 24);
    ck_assert_ptr_nonnull(buf);
    size_t values = 0;
    for (int it = 0; it < 3000; it++) {
        const size_t C = 1 + (size_t)(mlr_test_rng_u64(&r) % (it % 10 == 0 ? 400 : 40));
        const size_t len = make(&r, C, buf);
        ck_assert_msg(run_line(&k, buf, len, C), "declined: '%.*s'", (int)len, buf);
        values += C;
    }
    ck_assert_uint_gt(values, 50000);
    free(buf);
}

/* A line of C short tokens one blank apart, as files written with 4 decimals have them; in
 * three lines of four now and then a long token, two blanks or a tab. */
static size_t short_line(mlr_test_rng *r, size_t C, char *buf)
{
    const unsigned odd = (unsigned)(mlr_test_rng_u64(r) % 4); /* 0: all short, one blank */
    size_t n = 0;
    for (size_t c = 0; c < C; c++) {
        const uint64_t u = mlr_test_rng_u64(r) % 64;
        if (c)
            n += (size_t)sprintf(buf + n, "%s", odd && u == 1 ? "  " : odd && u == 2 ? "\t" : " ");
        n += odd && u == 3 ? simple_token(r, buf + n) : short_token(r, buf + n);
    }
    n += (size_t)sprintf(buf + n, "%s", mlr_test_rng_u64(r) % 3 ? "\n" : "\r\n");
    return n;
}

START_TEST(line_kernel_takes_random_simple_lines) { takes_random_lines(_i, 2024, simple_line); }
END_TEST

/* Whichever way the kernel takes each group of eight, every value exact. */
START_TEST(line_kernel_takes_random_short_lines) { takes_random_lines(_i, 77, short_line); }
END_TEST

/* A line of C random tokens (1 to 30) with tok[0, tlen) at a random place, blank-separated,
 * ending with eol; the tokens around it are short ones (the eight-at-once path) when rep % 4
 * is 0 or 1. Returns its length. */
static size_t line_around(mlr_test_rng *r, const char *tok, size_t tlen, int rep, const char *eol,
                          char *buf, size_t *C)
{
    *C = 1 + (size_t)(mlr_test_rng_u64(r) % 30);
    const size_t at = (size_t)(mlr_test_rng_u64(r) % *C);
    size_t n = 0;
    for (size_t c = 0; c < *C; c++) {
        if (c)
            buf[n++] = ' ';
        if (c == at) {
            memcpy(buf + n, tok, tlen);
            n += tlen;
        } else {
            n += rep % 4 < 2 ? short_token(r, buf + n) : simple_token(r, buf + n);
        }
    }
    return n + (size_t)sprintf(buf + n, "%s", eol);
}

START_TEST(line_kernel_declines_what_it_does_not_take)
{
    const bvh_kernels k = line_variant(_i);
    if (!k.line)
        return;
    /* no numbers: the line goes to the careful parser, which reports them */
    static const char *const odd[] = {
        "1.2.3",
        "..1",
        "-1.2.3",
        "1.-2",
        "-1-",
        "12.34.5",
        "-0-0",
        "1..",
        "-..",
        "-",
        ".",
        "-.",
        "1-2",
        "--1",
        "1-",
        "0x1",
        "nan",
        "inf",
        "-inf",
        "1,5",
        "1/2",
        "/",
        "12a",
        "1e",
        "1e+",
        "e5",
        "+",
        "1e999",
        "\x01",
        "1\x7f",
        "\xc3\xa9",
        "1\v2",
        "1\f2",
        ("1\x00"
         "2"),
    };
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 99);
    char buf[4096];
    for (size_t i = 0; i < MLR_COUNTOF(odd); i++) {
        const size_t olen = i == MLR_COUNTOF(odd) - 1 ? 3 : strlen(odd[i]);
        for (int rep = 0; rep < 40; rep++) {
            size_t C;
            const size_t n = line_around(&r, odd[i], olen, rep, rep % 2 ? "\r\n" : "\n", buf, &C);
            ck_assert_msg(!run_line(&k, buf, n, C), "took '%s'", odd[i]);
        }
    }
    /* wrong counts, blank lines, a lone line end */
    for (int rep = 0; rep < 200; rep++) {
        const size_t C = 1 + (size_t)(mlr_test_rng_u64(&r) % 50);
        size_t n = simple_line(&r, C, buf);
        ck_assert(run_line(&k, buf, n, C));
        ck_assert(!run_line(&k, buf, n, C + 1));
        if (C > 1)
            ck_assert(!run_line(&k, buf, n, C - 1));
    }
    /* numbers the vector lanes leave to the scalar parser: still taken, still exact */
    static const char *const long_ones[] = {
        "1e5",
        "1E5",
        "+1",
        "+.5",
        "-2.5e+2",
        "1.5E-3",
        "5.1072e-06",
        "-1.51632e-14",
        "1234567890123456",
        "-123456789012345",
        "123456789012345.",
        "1.23456789012345",
        "0.12345678901234567",
        "9007199254740993",
        "-0.000000000000000000001",
        "1.00000000000000011102230246251565",
        "2.5e-300",
    };
    for (size_t i = 0; i < MLR_COUNTOF(long_ones); i++)
        for (int rep = 0; rep < 40; rep++) {
            size_t C;
            const size_t n = line_around(&r, long_ones[i], strlen(long_ones[i]), rep,
                                         rep % 2 ? "\r\n" : "", buf, &C);
            ck_assert_msg(run_line(&k, buf, n, C), "declined '%s'", long_ones[i]);
        }
    ck_assert(!run_line(&k, "\n1 2 3\n", 7, 3));
    ck_assert(!run_line(&k, "  \t \r\n", 6, 1));
    ck_assert(!run_line(&k, "", 0, 1));
}
END_TEST

START_TEST(portable_kernels_and_line_counts)
{
    bvh_kernels k;
    bvh_kernels_pick(&k, BVH_KERNELS_PORTABLE);
    ck_assert(k.line == NULL);
    ck_assert(k.frame == frame_portable);
    /* the line counts that place the threads' shares, both builds */
    const bvh_kernels f = kernels();
    char *text = malloc(1000);
    ck_assert_ptr_nonnull(text);
    for (size_t i = 0; i < 1000; i++)
        text[i] = i % 7 == 0 || i % 11 == 0 ? '\n' : i % 13 == 0 ? '\r' : 'x';
    for (size_t a = 0; a < 200; a += 7)
        for (size_t b = a; b <= 1000; b += 61) {
            size_t want = 0;
            for (size_t i = a; i < b; i++)
                want += text[i] == '\n';
            ck_assert_uint_eq(k.count_newlines(text + a, text + b), want);
            ck_assert_uint_eq(f.count_newlines(text + a, text + b), want);
        }
    free(text);
}
END_TEST

/* A random conversion plan: C channels, J joints, P translated joints; each slot takes a random
 * channel or none, joints in groups of 8 with their angles in consecutive channels or not. */
typedef struct rplan {
    bvh_conv cv;
    uint32_t *src, *tri;
    unsigned char *sel, *tri_ok;
    double *par;
} rplan;

static void rplan_make(mlr_test_rng *r, rplan *rp)
{
    const size_t J = 1 + (size_t)(mlr_test_rng_u64(r) % 50), Jp = (J + 7) / 8 * 8;
    const size_t P = (size_t)(mlr_test_rng_u64(r) % J);
    const size_t C = 3 * J + 6 + (size_t)(mlr_test_rng_u64(r) % 9);
    const size_t R = (C + 7) / 8 * 8;
    bvh_conv *cv = &rp->cv;
    cv->C = C, cv->J = J, cv->Jp = Jp, cv->P = P, cv->R = R;
    rp->src = malloc((3 + 3 * P + 3 * Jp) * sizeof(uint32_t));
    rp->tri = malloc(Jp * sizeof(uint32_t));
    rp->sel = malloc(3 * Jp);
    rp->tri_ok = malloc(Jp / 8);
    rp->par = malloc(Jp * sizeof(double));
    ck_assert(rp->src && rp->tri && rp->sel && rp->tri_ok && rp->par);
    for (size_t k = 0; k < 3 + 3 * P; k++) /* a channel or a constant */
        rp->src[k] =
            mlr_test_rng_u64(r) % 4 ? (uint32_t)(mlr_test_rng_u64(r) % C) : (uint32_t)(R + 4 + k);
    uint32_t *g = rp->src + 3 + 3 * P;
    for (size_t j = 0; j < Jp; j += 8) {
        const int regular = mlr_test_rng_u64(r) % 3 != 0;
        rp->tri_ok[j / 8] = (unsigned char)regular;
        for (size_t i = j; i < j + 8; i++) {
            const uint32_t base = (uint32_t)(mlr_test_rng_u64(r) % (C - 2));
            rp->tri[i] = i < J ? base : (uint32_t)R;
            for (size_t k = 0; k < 3; k++)
                g[k * Jp + i] = i >= J                    ? (uint32_t)R
                                : regular                 ? base + (uint32_t)k
                                : mlr_test_rng_u64(r) % 5 ? (uint32_t)(mlr_test_rng_u64(r) % C)
                                                          : (uint32_t)R;
            const unsigned o = (unsigned)(mlr_test_rng_u64(r) % 6);
            rp->par[i] = i < J ? ref_parity[o] : 1.0;
            for (size_t a = 0; a < 3; a++) /* slot of axis a: the inverse of the order's axes */
                rp->sel[ref_axes[o][a] * Jp + i] = i < J ? (unsigned char)a : 0;
        }
    }
    cv->src = rp->src, cv->tri = rp->tri, cv->tri_ok = rp->tri_ok, cv->sel = rp->sel;
    cv->par = rp->par;
}

static void rplan_free(rplan *rp)
{
    free(rp->src), free(rp->tri), free(rp->sel), free(rp->tri_ok), free(rp->par);
}

START_TEST(frame_kernels_agree_bit_for_bit)
{
    bvh_frame_fn fns[3] = {frame_portable, NULL, NULL};
#ifdef BVH_X86
    if (cpu__isa(MLR_ISA_BEST) >= MLR_ISA_AVX2)
        fns[1] = frame_avx2;
    if (cpu__isa(MLR_ISA_BEST) >= MLR_ISA_AVX512)
        fns[2] = frame_avx512;
#endif
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 31337);
    for (int it = 0; it < 300; it++) {
        rplan rp;
        rplan_make(&r, &rp);
        const bvh_conv *cv = &rp.cv;
        const size_t J = cv->J, P = cv->P, n_row = bvh_frame_row_size(cv);
        double *row = malloc(n_row * sizeof *row), *tmp = malloc(bvh_frame_tmp_size(cv) * 8);
        double *out[3];
        const size_t n_out = 3 + 3 * P + 4 * J;
        for (int v = 0; v < 3; v++)
            out[v] = malloc(n_out * sizeof(double));
        ck_assert(row && tmp && out[0] && out[1] && out[2]);
        for (size_t c = 0; c < n_row; c++) {
            const uint64_t kind = mlr_test_rng_u64(&r) % 50;
            row[c] = kind == 0   ? 0x1p53 * mlr_test_rng_normal(&r) /* reduced with fmod */
                     : kind == 1 ? 90.0 * (double)(int)(mlr_test_rng_u64(&r) % 9)
                                 : 400.0 * mlr_test_rng_normal(&r);
        }
        for (size_t k = cv->R; k < cv->R + 4; k++)
            row[k] = 0.0;
        for (int v = 0; v < 3; v++) {
            if (!fns[v])
                continue;
            double *o = out[v];
            fns[v](cv, row, tmp, o, o + 3, o + 3 + 3 * P);
            ck_assert_msg(memcmp(o, out[0], n_out * sizeof(double)) == 0,
                          "kernel %d differs from the portable one (plan %d)", v, it);
        }
        /* the portable kernel against the reference formula */
        const uint32_t *g = cv->src + 3 + 3 * P;
        for (size_t j = 0; j < J; j++) {
            double sn[3], cs[3];
            for (size_t k = 0; k < 3; k++) {
                const double h = 0.5 * row[g[k * cv->Jp + j]];
                mlr_sincosd_kernel(fabs(h) < MLR_SINCOSD_LIMIT ? h : fmod(h, 360.0), &sn[k],
                                   &cs[k]);
            }
            unsigned char axes[3];
            for (size_t a = 0; a < 3; a++)
                axes[cv->sel[a * cv->Jp + j]] = (unsigned char)a;
            mlr_quat q;
            common__quat_from_euler_half(cs[0], sn[0], cs[1], sn[1], cs[2], sn[2], axes,
                                         cv->par[j], &q);
            const double want[4] = {q.w, q.x, q.y, q.z};
            ck_assert(memcmp(want, out[0] + 3 + 3 * P + 4 * j, sizeof want) == 0);
        }
        for (size_t k = 0; k < 3 + 3 * P; k++)
            ck_assert(memcmp(&out[0][k], &row[cv->src[k]], sizeof(double)) == 0);
        for (int v = 0; v < 3; v++)
            free(out[v]);
        free(tmp);
        free(row);
        rplan_free(&rp);
    }
}
END_TEST

static Suite *bvh_frames_suite(void)
{
    Suite *s = suite_create("bvh_frames");
    TCase *tc = tcase_create("line kernel");
    /* the AVX-512, AVX2 and AVX-512 VBMI2 line kernels */
    tcase_add_loop_test(tc, line_kernel_takes_every_line_of_every_clip, 0, 24);
    tcase_add_loop_test(tc, line_kernel_takes_random_simple_lines, 0, 3);
    tcase_add_loop_test(tc, line_kernel_takes_random_short_lines, 0, 3);
    tcase_add_loop_test(tc, line_kernel_declines_what_it_does_not_take, 0, 3);
    tcase_add_test(tc, portable_kernels_and_line_counts);
    tcase_add_test(tc, frame_kernels_agree_bit_for_bit);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(bvh_frames_suite()); }
