/*
 * Foot contact detection: slow and low points, with hysteresis, gap closing and a minimum
 * duration; thresholds relative to the body height and to seconds.
 */
#include "guards/contacts_internal.h"
#include "common/mlr_internal.h"
#include "common/options_internal.h"

#include <math.h>

#define SPEED_ON 0.25      /* body heights per second */
#define HEIGHT_ON 0.06     /* body heights above the local floor level */
#define MIN_CONTACT 0.08   /* seconds */
#define MAX_GAP 0.05       /* seconds */
#define FLOOR_WINDOW 0.75  /* seconds each side for the local floor level */
#define SPEED_STEP 60.0    /* k = round(fps / 60): central differences over about 1/30 s */

/* Python's round() of a value >= 0 to an integer: to nearest, ties to even. */
static size_t round_half_even(double x)
{
    double r = floor(x);
    const double d = x - r;
    if (d > 0.5 || (d == 0.5 && fmod(r, 2.0) != 0.0))
        r += 1.0;
    return (size_t)r;
}

/* out[t] = min x[t - half .. t + half] (clipped to [0, n)), van Herk / Gil-Werman on x padded
 * with +inf to whole blocks of w = 2 half + 1: O(n) for any half. pad, fwd, bwd hold
 * padded_len(n, half) doubles each. */
static size_t padded_len(size_t n, size_t half)
{
    const size_t w = 2 * half + 1, len = n + 2 * half;
    return len + (w - len % w) % w;
}

static void moving_min(const double *x, size_t n, size_t half, double *pad, double *fwd,
                       double *bwd, double *out)
{
    if (half == 0 || n <= 1) {
        for (size_t t = 0; t < n; t++)
            out[t] = x[t];
        return;
    }
    const size_t w = 2 * half + 1, L = padded_len(n, half);
    for (size_t i = 0; i < L; i++)
        pad[i] = i >= half && i < half + n ? x[i - half] : INFINITY;
    for (size_t b = 0; b < L; b += w) {
        fwd[b] = pad[b];
        for (size_t i = b + 1; i < b + w; i++)
            fwd[i] = pad[i] < fwd[i - 1] ? pad[i] : fwd[i - 1];
        bwd[b + w - 1] = pad[b + w - 1];
        for (size_t i = b + w - 1; i-- > b;)
            bwd[i] = pad[i] < bwd[i + 1] ? pad[i] : bwd[i + 1];
    }
    /* the window starting at t (padded coordinates) covers t .. t + w - 1 */
    for (size_t t = 0; t < n; t++) {
        const double a = bwd[t], b = fwd[t + w - 1];
        out[t] = a < b ? a : b;
    }
}

static const mlr_opt_spec contacts_opts[] = {
    {MLR_CONTACTS_OPT_SPEED, "speed", MLR_OPT_DOUBLE, 0.0, INFINITY, 1, 0, SPEED_ON, NULL},
    {MLR_CONTACTS_OPT_HEIGHT, "height", MLR_OPT_DOUBLE, 0.0, INFINITY, 1, 0, HEIGHT_ON, NULL},
    {MLR_CONTACTS_OPT_MIN_DURATION, "min_duration", MLR_OPT_DOUBLE, 0.0, INFINITY, 1, 0,
     MIN_CONTACT, NULL},
};

static mlr_status parse_options(const mlr_contacts_option *opts, size_t n_opts, double *speed,
                                double *height, double *min_duration, mlr_diag *diag)
{
    mlr_opt_values o;
    mlr_status st = MLR_OPTIONS_READ("contacts", contacts_opts, opts, n_opts, &o, diag);
    *speed = o.v[MLR_CONTACTS_OPT_SPEED];
    *height = o.v[MLR_CONTACTS_OPT_HEIGHT];
    *min_duration = o.v[MLR_CONTACTS_OPT_MIN_DURATION];
    return st;
}

/* Close gaps of at most `gap` frames inside a column (stride s), then drop contacts shorter
 * than `shortest` frames. */
static void clean_column(uint8_t *c, size_t N, size_t s, size_t gap, size_t shortest)
{
    for (size_t t = 0; t < N;) {
        if (c[t * s]) {
            t++;
            continue;
        }
        size_t b = t;
        while (b < N && !c[b * s])
            b++;
        if (t > 0 && b < N && b - t <= gap)
            for (size_t i = t; i < b; i++)
                c[i * s] = 1;
        t = b;
    }
    for (size_t t = 0; t < N;) {
        if (!c[t * s]) {
            t++;
            continue;
        }
        size_t b = t;
        while (b < N && c[b * s])
            b++;
        if (b - t < shortest)
            for (size_t i = t; i < b; i++)
                c[i * s] = 0;
        t = b;
    }
}

/* The arguments of mlr_contacts_detect, checked, and its options (speed, height,
   min_duration). The points are validated by position, before anything is allocated. */
static mlr_status detect_check(const mlr_rig *rig, double fps, int up, size_t N,
                               const double *world_pos, const double *world_rot, size_t C,
                               const int32_t *joints, const int32_t *end_sites,
                               const mlr_contacts_option *opts, size_t n_opts,
                               const uint8_t *contacts, double *speed, double *height,
                               double *min_duration, mlr_diag *diag)
{
    mlr_status st = mlr_rig_check(rig, diag);
    if (st != MLR_OK)
        return st;
    if (!(isfinite(fps) && fps > 0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "contacts: fps must be finite and > 0, got %g", fps);
    if (up < MLR_AXIS_X || up > MLR_AXIS_Z)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "contacts: up axis %d is not 0 (X), 1 (Y) or 2 (Z)", up);
    if (N < 3)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "contacts: detection needs at least 3 frames, got %zu", N);
    if (C == 0)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "contacts: no contact points");
    if (!world_pos || !joints || !contacts)
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0, "contacts: NULL argument");
    st = parse_options(opts, n_opts, speed, height, min_duration, diag);
    if (st != MLR_OK)
        return st;
    for (size_t c = 0; c < C; c++)
        for (size_t d = 0; d < c; d++)
            if (joints[c] == joints[d] &&
                (end_sites ? end_sites[c] : -1) == (end_sites ? end_sites[d] : -1))
                return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                        "contacts: points %zu and %zu are the same", d, c);
    /* validates the points; positions first, so that bad points fail before the allocation */
    return mlr_rig_point_positions(rig, 0, world_pos, world_rot, C, joints, end_sites, NULL, diag);
}

/* The points' speeds v (N x C) from their positions p (N x C x 3): central differences over
   2 k frames, the first and last k frames the nearest computed value; for N <= 2 k the mean
   speed over the clip. */
static void point_speeds(const double *p, size_t N, size_t C, double fps, double *v)
{
    const size_t k0 = round_half_even(fps / SPEED_STEP), k = k0 > 1 ? k0 : 1;
    if (N > 2 * k) {
        const double dt = (double)(2 * k) / fps;
        for (size_t t = k; t < N - k; t++)
            for (size_t c = 0; c < C; c++) {
                const double *a1 = p + 3 * ((t + k) * C + c), *a0 = p + 3 * ((t - k) * C + c);
                const double dx = a1[0] - a0[0], dy = a1[1] - a0[1], dz = a1[2] - a0[2];
                v[t * C + c] = sqrt(dx * dx + dy * dy + dz * dz) / dt;
            }
        for (size_t t = 0; t < k; t++)
            for (size_t c = 0; c < C; c++) {
                v[t * C + c] = v[k * C + c];
                v[(N - 1 - t) * C + c] = v[(N - k - 1) * C + c];
            }
    } else {
        const double dt = (double)(N - 1) / fps;
        for (size_t c = 0; c < C; c++) {
            const double *a1 = p + 3 * ((N - 1) * C + c), *a0 = p + 3 * c;
            const double dx = a1[0] - a0[0], dy = a1[1] - a0[1], dz = a1[2] - a0[2];
            const double s = sqrt(dx * dx + dy * dy + dz * dz) / dt;
            for (size_t t = 0; t < N; t++)
                v[t * C + c] = s;
        }
    }
}

/* The thresholds of one detection, in length units and frames. */
typedef struct thresholds {
    double v_on, v_off, h_on, h_off;
    size_t half, gap, shortest; /* the floor window's half width, the gap closed, the shortest
                                   contact kept */
} thresholds;

/* Point c's contacts (column c of the N x C contacts) from its positions p and speeds v:
   enter slow and low, leave fast or high, then gaps closed and short contacts dropped.
   Scratch: y, fl (N), pad, fwd, bwd (padded_len). */
static void detect_point(const double *p, const double *v, size_t N, size_t C, size_t c, int up,
                         const thresholds *th, double *y, double *pad, double *fwd, double *bwd,
                         double *fl, uint8_t *contacts)
{
    for (size_t t = 0; t < N; t++)
        y[t] = p[3 * (t * C + c) + (size_t)up];
    moving_min(y, N, th->half, pad, fwd, bwd, fl);
    uint8_t state = 0;
    for (size_t t = 0; t < N; t++) {
        const double h = y[t] - fl[t], s = v[t * C + c];
        if (s < th->v_on && h < th->h_on)
            state = 1;
        else if (s > th->v_off || h > th->h_off)
            state = 0;
        contacts[t * C + c] = state;
    }
    clean_column(contacts + c, N, C, th->gap, th->shortest);
}

mlr_status mlr_contacts_detect(const mlr_rig *rig, double fps, int up, size_t n_frames,
                               const double *world_pos, const double *world_rot, size_t n_points,
                               const int32_t *joints, const int32_t *end_sites,
                               const mlr_contacts_option *opts, size_t n_opts, uint8_t *contacts,
                               const mlr_allocator *alloc, mlr_diag *diag)
{
    return contacts__detect(rig, fps, up, n_frames, world_pos, world_rot, n_points, joints,
                            end_sites, opts, n_opts, contacts, alloc, NULL, diag);
}

mlr_status contacts__detect(const mlr_rig *rig, double fps, int up, size_t n_frames,
                            const double *world_pos, const double *world_rot, size_t n_points,
                            const int32_t *joints, const int32_t *end_sites,
                            const mlr_contacts_option *opts, size_t n_opts, uint8_t *contacts,
                            const mlr_allocator *alloc, const double *body_height, mlr_diag *diag)
{
    const size_t N = n_frames, C = n_points;
    double speed = SPEED_ON, height = HEIGHT_ON, min_duration = MIN_CONTACT;
    mlr_status st = detect_check(rig, fps, up, N, world_pos, world_rot, C, joints, end_sites, opts,
                                 n_opts, contacts, &speed, &height, &min_duration, diag);
    if (st != MLR_OK)
        return st;

    mlr_allocator a;
    common__allocator_resolve(alloc, &a);
    double H = body_height ? *body_height : 0.0;
    st = body_height ? MLR_OK : mlr_rig_body_height(N, rig->n_joints, world_pos, up, &H, &a, diag);
    if (st != MLR_OK)
        return common__diag_prefix(diag, st, "contacts");
    if (!(H > 0))
        return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                "contacts: the motion has no extent along the up axis (a flat "
                                "skeleton), so no body size to scale thresholds by");

    const size_t half_raw = round_half_even(FLOOR_WINDOW * fps);
    const size_t half = half_raw < N - 1 ? half_raw : N - 1; /* a wider window adds nothing */
    const size_t L = padded_len(N, half);
    size_t NC, bytes;
    if (common__mul_size(N, C, &NC) != MLR_OK || NC > SIZE_MAX / 4 - 3 * L - 2 * N ||
        common__mul_size(4 * NC + 3 * L + 2 * N, sizeof(double), &bytes) != MLR_OK)
        return common__diag_set(diag, MLR_E_OVERFLOW, 0, 0, "contacts: too many frames");
    double *p = common__alloc(&a, bytes);
    if (!p)
        return common__diag_set(diag, MLR_E_NO_MEMORY, 0, 0, "contacts: out of memory");
    double *v = p + 3 * NC, *pad = v + NC, *fwd = pad + L, *bwd = fwd + L, *y = bwd + L,
           *fl = y + N;
    mlr_rig_point_positions(rig, N, world_pos, world_rot, C, joints, end_sites, p, NULL);
    for (size_t i = 0; i < 3 * NC; i++)
        if (!isfinite(p[i])) {
            common__free(&a, p, bytes);
            return common__diag_set(diag, MLR_E_INVALID_ARG, 0, 0,
                                    "contacts: position of point %zu at frame %zu is not finite",
                                    (i / 3) % C, i / (3 * C));
        }
    point_speeds(p, N, C, fps, v);

    /* in the order of the reference: (2 speed) H and (1.5 height) H */
    thresholds th = {speed * H, 2.0 * speed * H, height * H, 1.5 * height * H, half, 0, 0};
    th.gap = round_half_even(MAX_GAP * fps);
    const size_t shortest0 = round_half_even(min_duration * fps);
    th.shortest = shortest0 > 2 ? shortest0 : 2;
    for (size_t c = 0; c < C; c++)
        detect_point(p, v, N, C, c, up, &th, y, pad, fwd, bwd, fl, contacts);
    common__free(&a, p, bytes);
    return MLR_OK;
}
