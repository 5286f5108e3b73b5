/* Contact cleanup and floor (mlr_cleanup.h): a synthetic sliding foot pinned to its contact
 * (with and without a reference), frames far from every constrained frame kept, the floor
 * respected, MAX_FOLD moving the root away, the floor height against a sort, real clips,
 * bad input, allocation failures. */
#include "mlr_test.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define PI 3.14159265358979323846

/* Y up. Hips -> (LeftUpLeg -> LeftLeg -> LeftFoot -> LeftToe), the same on the right, Spine */
enum { J = 10, N = 300 };
static const int32_t parents[J] = {-1, 0, 1, 2, 3, 0, 5, 6, 7, 0};
static const double offsets[3 * J] = {0,  0, 0, 1, 0,  0, 0, -4, 0, 0, -4,   0,   0, -0.8, 1.5,
                                      -1, 0, 0, 0, -4, 0, 0, -4, 0, 0, -0.8, 1.5, 0, 2,    0};
static const char *const names[J] = {"Hips",       "LeftUpLeg", "LeftLeg",   "LeftFoot", "LeftToe",
                                     "RightUpLeg", "RightLeg",  "RightFoot", "RightToe", "Spine"};
static const int32_t es_parents[2] = {4, 8};
static const double es_offsets[6] = {0, 0, 0.5, 0, 0, 0.5};
/* points: LeftFoot, LeftToe, RightFoot, RightToe */
enum { C = 4 };
static const int32_t pj[C] = {3, 4, 7, 8};
static const double ROOT_Y = 8.0 * 0.96891242171064473 /* cos 0.25 */ + 0.8;

static mlr_rig rig(void)
{
    mlr_rig r = {J, parents, offsets, names, 0, NULL, 2, es_parents, es_offsets};
    return r;
}

static void qx(double a, double *q)
{
    q[0] = cos(0.5 * a), q[1] = sin(0.5 * a), q[2] = q[3] = 0.0;
}

/* A standing pose with bent knees (feet flat: toes at y = 0 when the root is at ROOT_Y), the
   root at z = slide * f and y = ROOT_Y - dip(f). */
static void pose_clip(double slide, double dip, size_t dip_lo, size_t dip_hi, double *root,
                      double *rot)
{
    for (size_t f = 0; f < N; f++) {
        double d = 0.0;
        if (f >= dip_lo && f < dip_hi) {
            const double s = sin(PI * (double)(f - dip_lo) / (double)(dip_hi - dip_lo));
            d = dip * s * s;
        }
        root[3 * f] = 0.0, root[3 * f + 1] = ROOT_Y - d, root[3 * f + 2] = slide * (double)f;
        for (size_t j = 0; j < J; j++)
            qx(0.0, rot + 4 * (f * J + j));
        for (int s = 0; s < 2; s++) {
            qx(0.25, rot + 4 * (f * J + 1 + 4 * (size_t)s));
            qx(-0.5, rot + 4 * (f * J + 2 + 4 * (size_t)s));
            qx(0.25, rot + 4 * (f * J + 3 + 4 * (size_t)s));
        }
    }
}

/* left points in contact on [80, 120), right on [180, 220) */
static void contacts_of(uint8_t *c)
{
    memset(c, 0, N * C);
    for (size_t f = 80; f < 120; f++)
        c[f * C] = c[f * C + 1] = 1;
    for (size_t f = 180; f < 220; f++)
        c[f * C + 2] = c[f * C + 3] = 1;
}

static void fk_pts(const double *root, const double *rot, double *pos, double *pts)
{
    mlr_rig r = rig();
    double *wrot = malloc(4 * N * J * sizeof(double));
    ck_assert_int_eq(
        mlr_fk_arrays(N, J, parents, offsets, root, rot, 0, NULL, NULL, pos, wrot, NULL, NULL),
        MLR_OK);
    ck_assert_int_eq(mlr_rig_point_positions(&r, N, pos, wrot, C, pj, NULL, pts, NULL), MLR_OK);
    free(wrot);
}

static double dist(const double *a, const double *b)
{
    return sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) +
                (a[2] - b[2]) * (a[2] - b[2]));
}

typedef struct synth {
    double root[3 * N], rot[4 * N * J], rroot[3 * N], rrot[4 * N * J];
    double oroot[3 * N], orot[4 * N * J];
    double pos[3 * N * J], pts[3 * N * C], opos[3 * N * J], opts[3 * N * C];
    uint8_t c[N * C];
} synth;

static mlr_status run(synth *s, int with_ref, const mlr_cleanup_option *o, size_t no,
                      mlr_cleanup_report *rep, const mlr_allocator *al, mlr_diag *d)
{
    mlr_rig r = rig();
    return mlr_cleanup_contacts(&r, N, 60.0, MLR_AXIS_Y, s->root, s->rot, NULL,
                                with_ref ? s->rroot : NULL, with_ref ? s->rrot : NULL, NULL, C, pj,
                                NULL, s->c, o, no, s->oroot, s->orot, rep, al, d);
}

START_TEST(a_sliding_foot_is_pinned_to_its_contact)
{
    synth *s = malloc(sizeof *s);
    pose_clip(0.01, 0.0, 0, 0, s->root, s->rot);
    pose_clip(0.0, 0.0, 0, 0, s->rroot, s->rrot); /* the reference stands still */
    contacts_of(s->c);
    fk_pts(s->root, s->rot, s->pos, s->pts);
    const mlr_cleanup_option off = {MLR_CLEANUP_OPT_FLOOR, 0.0};
    for (int with_ref = 0; with_ref < 2; with_ref++) {
        mlr_cleanup_report rep;
        mlr_diag d;
        ck_assert_msg(run(s, with_ref, &off, 1, &rep, NULL, &d) == MLR_OK, "%s", d.message);
        ck_assert_uint_eq(rep.contact_frames, 80);
        ck_assert_uint_eq(rep.floor_frames, 0);
        ck_assert(isnan(rep.floor_height));
        ck_assert(rep.root_shift_max == 0.0);
        fk_pts(s->oroot, s->orot, s->opos, s->opts);
        const size_t lo[2] = {80, 180};
        for (int side = 0; side < 2; side++)
            for (size_t p = 0; p < 2; p++) {
                const size_t cp = 2 * (size_t)side + p;
                /* want: the mean over the run (no reference); with the standing reference, its
                   own point shifted by the run's mean horizontal offset over both points */
                double want[3] = {0, 0, 0}, o[3] = {0, 0, 0};
                for (size_t f = lo[side]; f < lo[side] + 40; f++)
                    for (int k = 0; k < 3; k++) {
                        want[k] += s->pts[3 * (f * C + cp) + (size_t)k] / 40.0;
                        o[k] += s->root[3 * f + (size_t)k] / 40.0; /* ref root at z = 0 */
                    }
                if (with_ref) {
                    double rp[3 * N * C], rpos[3 * N * J];
                    fk_pts(s->rroot, s->rrot, rpos, rp);
                    for (int k = 0; k < 3; k++)
                        want[k] = rp[3 * cp + (size_t)k] + (k == 1 ? 0.0 : o[k]);
                }
                double in_slide = 0.0;
                for (size_t f = lo[side]; f < lo[side] + 40; f++) {
                    const double e = dist(s->opts + 3 * (f * C + cp), want);
                    ck_assert_msg(e < 1e-7, "ref %d point %zu frame %zu: %g from its pin",
                                  with_ref, cp, f, e);
                    in_slide = fmax(in_slide, dist(s->pts + 3 * (f * C + cp), want));
                }
                ck_assert(in_slide > 0.15); /* the input did slide */
            }
        /* bone lengths kept */
        for (size_t f = 0; f < N; f++)
            for (size_t j = 1; j < J; j++) {
                const double *o = offsets + 3 * j;
                ck_assert_double_eq_tol(
                    dist(s->opos + 3 * (f * J + j), s->opos + 3 * (f * J + (size_t)parents[j])),
                    sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]), 1e-12);
            }
    }
    free(s);
}
END_TEST

/* The body rises 1.2 (15% of the leg's 8) in the middle of the left foot's contact, the root
   shift off: the pinned ankle goes out of reach. Without SOFT_REACH the knee snaps straight
   there; with 0.05 the ankle's distance from the hip stays below the leg's length, the knee
   bent, and the right leg, whose targets stay within the soft zone's start (its knee bent 0.5
   rad: 0.969 L), is the same bits as without. */
START_TEST(soft_reach_bends_a_knee_whose_target_leaves_its_reach)
{
    synth *s = malloc(sizeof *s);
    pose_clip(0.0, -1.2, 92, 108, s->root, s->rot);
    contacts_of(s->c);
    const double L = 8.0;
    double dmax[2] = {0.0, 0.0}, step[2] = {0.0, 0.0};
    double *keep = malloc(4 * N * J * sizeof(double));
    for (int soft = 0; soft < 2; soft++) {
        const mlr_cleanup_option o[3] = {{MLR_CLEANUP_OPT_FLOOR, 0.0},
                                         {MLR_CLEANUP_OPT_ROOT, 0.0},
                                         {MLR_CLEANUP_OPT_SOFT_REACH, 0.05}};
        mlr_cleanup_report rep;
        mlr_diag d;
        ck_assert_msg(run(s, 0, o, soft ? 3 : 2, &rep, NULL, &d) == MLR_OK, "%s", d.message);
        fk_pts(s->oroot, s->orot, s->opos, s->opts);
        double prev = NAN;
        for (size_t f = 80; f < 120; f++) {
            const double *h = s->opos + 3 * (f * J + 1), *a = s->opos + 3 * (f * J + 3);
            dmax[soft] = fmax(dmax[soft], dist(h, a));
            /* the knee's bend, from the law of cosines on its two bones of 4 */
            const double bend = PI - acos((32.0 - dist(h, a) * dist(h, a)) / 32.0);
            if (!isnan(prev))
                step[soft] = fmax(step[soft], fabs(bend - prev));
            prev = bend;
        }
        if (!soft)
            memcpy(keep, s->orot, 4 * N * J * sizeof(double));
        else
            for (size_t f = 0; f < N; f++)
                for (size_t j = 5; j < 9; j++) /* the right leg */
                    ck_assert_int_eq(memcmp(keep + 4 * (f * J + j), s->orot + 4 * (f * J + j),
                                            4 * sizeof(double)),
                                     0);
    }
    ck_assert_msg(dmax[0] > 0.999 * L, "without: the knee straight (%.5f L)", dmax[0] / L);
    ck_assert_msg(dmax[1] < 0.998 * L, "with 0.05: %.5f L", dmax[1] / L);
    ck_assert_msg(step[1] < 0.5 * step[0], "the knee's largest step: %.2f deg with, %.2f without",
                  step[1] * 180 / PI, step[0] * 180 / PI);
    free(keep);
    free(s);
}
END_TEST

/* Two contacts of the left foot 3 frames (0.05 s at 60 fps) apart, the body sliding 0.001 a
   frame, the reference standing still: the reference's foot does not move across the gap, so
   the gap closes and the two runs are pinned with one offset, the ankle at one place. Pinned
   apart (each run with its own mean offset), the ankle stood 0.043 apart on the two sides.
   Where the reference's foot steps 1.2 across the gap (15% of the leg's 8), the runs stay
   apart, each with its own offset from the reference. */
START_TEST(a_short_gap_where_the_foot_stays_is_closed)
{
    synth *s = malloc(sizeof *s);
    for (int step = 0; step < 2; step++) {
        pose_clip(0.001, 0.0, 0, 0, s->root, s->rot);
        pose_clip(0.0, 0.0, 0, 0, s->rroot, s->rrot);
        for (size_t f = 121; step && f < N; f++)
            s->rroot[3 * f + 2] = 1.2;
        memset(s->c, 0, sizeof s->c);
        for (size_t f = 80; f < 120; f++)
            s->c[f * C] = s->c[f * C + 1] = 1;
        for (size_t f = 123; f < 163; f++)
            s->c[f * C] = s->c[f * C + 1] = 1;
        const mlr_cleanup_option off = {MLR_CLEANUP_OPT_FLOOR, 0.0};
        mlr_cleanup_report rep;
        mlr_diag d;
        ck_assert_msg(run(s, 1, &off, 1, &rep, NULL, &d) == MLR_OK, "%s", d.message);
        fk_pts(s->oroot, s->orot, s->opos, s->opts);
        const double apart = dist(s->opts + 3 * (100 * C), s->opts + 3 * (145 * C));
        if (!step)
            ck_assert_msg(apart < 1e-7, "one pin: the ankle %g apart", apart);
        else
            ck_assert_msg(apart > 0.03, "two pins: the ankle %g apart", apart);
    }
    free(s);
}
END_TEST

/* Horizontal (x, z) path of the points pts (N x C x 3) over consecutive contact frames. */
static double slide_of(const double *pts, const uint8_t *c)
{
    double len = 0.0;
    for (size_t f = 0; f + 1 < N; f++)
        for (size_t k = 0; k < C; k++)
            if (c[f * C + k] && c[(f + 1) * C + k]) {
                const double *a = pts + 3 * (f * C + k), *b = pts + 3 * ((f + 1) * C + k);
                len += hypot(b[0] - a[0], b[2] - a[2]);
            }
    return len;
}

/* The body slides 2x the reference's: KEEP_STILLER 2.5 keeps both contacts as they are;
   with KEEP_TOTAL the feet slide in all no more than the reference (the runs that slide most
   beyond it follow it). (A run whose feet stay within 2% of the leg of the reference's path is
   kept whatever KEEP_TOTAL says: at 1.1x the reference's speed these 40-frame runs were.) */
START_TEST(keep_total_caps_the_feet_sliding_at_the_references)
{
    synth *s = malloc(sizeof *s);
    pose_clip(0.020, 0.0, 0, 0, s->root, s->rot);
    pose_clip(0.010, 0.0, 0, 0, s->rroot, s->rrot);
    contacts_of(s->c);
    fk_pts(s->rroot, s->rrot, s->pos, s->pts);
    const double ref = slide_of(s->pts, s->c);
    fk_pts(s->root, s->rot, s->pos, s->pts);
    const double own = slide_of(s->pts, s->c);
    ck_assert_double_eq_tol(own, 2.0 * ref, 1e-9 * ref);
    const mlr_cleanup_option o[3] = {{MLR_CLEANUP_OPT_KEEP_STILLER, 2.5},
                                     {MLR_CLEANUP_OPT_REF_SMOOTH, 0.0},
                                     {MLR_CLEANUP_OPT_KEEP_TOTAL, 1.0}};
    mlr_diag d;
    ck_assert_msg(run(s, 1, o, 2, NULL, NULL, &d) == MLR_OK, "%s", d.message);
    fk_pts(s->oroot, s->orot, s->opos, s->opts);
    ck_assert_double_eq_tol(slide_of(s->opts, s->c), own, 1e-9 * ref); /* kept */
    ck_assert_msg(run(s, 1, o, 3, NULL, NULL, &d) == MLR_OK, "%s", d.message);
    fk_pts(s->oroot, s->orot, s->opos, s->opts);
    ck_assert_double_le(slide_of(s->opts, s->c), ref * (1.0 + 1e-6));
    free(s);
}
END_TEST

START_TEST(frames_far_from_every_constrained_frame_keep_the_input)
{
    synth *s = malloc(sizeof *s);
    pose_clip(0.01, 0.0, 0, 0, s->root, s->rot);
    pose_clip(0.0, 0.0, 0, 0, s->rroot, s->rrot);
    contacts_of(s->c);
    /* the ramps into and out of the pinned runs: at most 1 s = 60 frames (here, where the
       feet barely accelerate, that long); the smoothing's tail ~exp(-d / 1.2 frames): 40 more
       frames */
    const mlr_cleanup_option off = {MLR_CLEANUP_OPT_FLOOR, 0.0};
    for (int with_ref = 0; with_ref < 2; with_ref++) {
        mlr_diag d;
        ck_assert_msg(run(s, with_ref, &off, 1, NULL, NULL, &d) == MLR_OK, "%s", d.message);
        size_t kept = 0, moved_near = 0;
        for (size_t f = 0; f < N; f++) {
            /* distance to the nearest constrained frame of each leg */
            const size_t dl = f < 80 ? 80 - f : f >= 120 ? f - 119 : 0;
            const size_t dr = f < 180 ? 180 - f : f >= 220 ? f - 219 : 0;
            for (size_t j = 0; j < J; j++) {
                const int left = j >= 1 && j <= 4, right = j >= 5 && j <= 8;
                const size_t dd = left ? dl : right ? dr : (dl < dr ? dl : dr);
                double e = 0.0;
                for (int k = 0; k < 4; k++)
                    e = fmax(e, fabs(s->orot[4 * (f * J + j) + (size_t)k] -
                                     s->rot[4 * (f * J + j) + (size_t)k]));
                if (dd > 60 + 40) {
                    ck_assert_msg(e < 1e-12, "ref %d frame %zu joint %zu moved by %g", with_ref, f,
                                  j, e);
                    kept++;
                } else if (dd <= 6 && (left || right) && e > 1e-3) {
                    moved_near++;
                }
            }
            for (int k = 0; k < 3; k++)
                ck_assert(s->oroot[3 * f + (size_t)k] == s->root[3 * f + (size_t)k]);
        }
        ck_assert_uint_gt(kept, 600); /* 80 frames x 4 joints on each side */
        ck_assert_uint_gt(moved_near, 20);
    }
    free(s);
}
END_TEST

/* The lowest point of every frame against its limit: the worst shortfall. */
static double worst_below(const double *pts, const double *lim_ref, double floor_h)
{
    double worst = -INFINITY;
    for (size_t f = 0; f < N; f++)
        for (size_t c = 0; c < C; c++) {
            const double lim = lim_ref ? fmin(floor_h, lim_ref[3 * (f * C + c) + 1]) : floor_h;
            worst = fmax(worst, lim - pts[3 * (f * C + c) + 1]);
        }
    return worst;
}

START_TEST(the_floor_is_respected)
{
    synth *s = malloc(sizeof *s);
    /* the body dips by 0.6 on frames [140, 170), where no foot is in contact */
    pose_clip(0.01, 0.6, 140, 170, s->root, s->rot);
    pose_clip(0.0, 0.0, 0, 0, s->rroot, s->rrot);
    contacts_of(s->c);
    fk_pts(s->root, s->rot, s->pos, s->pts);
    double rp[3 * N * C], rpos[3 * N * J];
    fk_pts(s->rroot, s->rrot, rpos, rp);
    const double H = 10.55; /* toe to spine */
    for (int with_ref = 0; with_ref < 2; with_ref++) {
        mlr_cleanup_report rep;
        mlr_diag d;
        ck_assert_msg(run(s, with_ref, NULL, 0, &rep, NULL, &d) == MLR_OK, "%s", d.message);
        /* the floor: the 0.05 quantile of the contact heights (toes at 0, ankles at 0.8) */
        ck_assert_double_eq_tol(rep.floor_height, 0.0, 1e-9);
        ck_assert_uint_gt(rep.floor_frames, 10);
        ck_assert(worst_below(s->pts, with_ref ? rp : NULL, rep.floor_height) > 0.5);
        fk_pts(s->oroot, s->orot, s->opos, s->opts);
        const double w = worst_below(s->opts, with_ref ? rp : NULL, rep.floor_height);
        /* within the floor's dead zone: half a percent of the leg (hip to knee to ankle, 8) */
        ck_assert_msg(w <= 0.005 * 8.0 + 1e-3 * H, "ref %d: a point %g below its limit", with_ref,
                      w);
    }
    /* an explicit floor height replaces the estimate */
    const mlr_cleanup_option fh = {MLR_CLEANUP_OPT_FLOOR_HEIGHT, -0.3};
    mlr_cleanup_report rep;
    mlr_diag d;
    ck_assert_msg(run(s, 0, &fh, 1, &rep, NULL, &d) == MLR_OK, "%s", d.message);
    ck_assert(rep.floor_height == -0.3);
    fk_pts(s->oroot, s->orot, s->opos, s->opts);
    ck_assert(worst_below(s->opts, NULL, -0.3) <= 0.005 * 8.0 + 1e-3 * H); /* the dead zone */
    free(s);
}
END_TEST

static double flexion(const double *p, size_t f, int a, int b, int c)
{
    const double *pa = p + 3 * (f * J + (size_t)a), *pb = p + 3 * (f * J + (size_t)b),
                 *pc = p + 3 * (f * J + (size_t)c);
    double uu = 0, vv = 0, uv = 0;
    for (int k = 0; k < 3; k++) {
        const double u = pb[k] - pa[k], v = pc[k] - pb[k];
        uu += u * u, vv += v * v, uv += u * v;
    }
    const double cs = uv / sqrt(uu * vv);
    return acos(cs > 1 ? 1 : cs < -1 ? -1 : cs);
}

START_TEST(max_fold_moves_the_root_away_from_a_near_target)
{
    synth *s = malloc(sizeof *s);
    /* the body sinks by 2.5 during the left contact: pinned there, the knee would fold ~98 deg */
    pose_clip(0.0, 2.5, 70, 130, s->root, s->rot);
    pose_clip(0.0, 0.0, 0, 0, s->rroot, s->rrot);
    contacts_of(s->c);
    const double fold = 1.0;
    for (int limited = 0; limited < 2; limited++) {
        const mlr_cleanup_option o[2] = {{MLR_CLEANUP_OPT_FLOOR, 0.0},
                                         {MLR_CLEANUP_OPT_MAX_FOLD, fold}};
        mlr_cleanup_report rep;
        mlr_diag d;
        ck_assert_msg(run(s, 1, o, limited ? 2 : 1, &rep, NULL, &d) == MLR_OK, "%s", d.message);
        fk_pts(s->oroot, s->orot, s->opos, s->opts);
        double worst = 0.0;
        for (size_t f = 80; f < 120; f++)
            worst = fmax(worst, flexion(s->opos, f, 1, 2, 3));
        if (!limited) {
            ck_assert_msg(worst > fold + 0.3, "unlimited flexion %g", worst);
            ck_assert(rep.root_shift_max == 0.0);
        } else {
            ck_assert_msg(worst <= fold + 1e-3, "flexion %g past MAX_FOLD %g", worst, fold);
            ck_assert(rep.root_shift_max > 0.5);
            ck_assert(s->oroot[3 * 100 + 1] > s->root[3 * 100 + 1] + 0.5); /* away: up */
        }
    }
    free(s);
}
END_TEST

static double ref_quantile(double *v, size_t n, double q)
{
    for (size_t i = 1; i < n; i++) /* insertion sort */
        for (size_t k = i; k > 0 && v[k - 1] > v[k]; k--) {
            const double t = v[k];
            v[k] = v[k - 1], v[k - 1] = t;
        }
    const double pos = q * (double)(n - 1);
    const size_t i = (size_t)pos;
    return i + 1 < n ? v[i] + (pos - (double)i) * (v[i + 1] - v[i]) : v[n - 1];
}

START_TEST(floor_height_is_the_quantile_of_contact_heights)
{
    synth *s = malloc(sizeof *s);
    mlr_test_rng r;
    mlr_test_rng_seed(&r, 31);
    pose_clip(0.01, 0.0, 0, 0, s->root, s->rot);
    for (size_t f = 0; f < N; f++) { /* random heights and poses */
        s->root[3 * f + 1] += mlr_test_rng_normal(&r);
        for (size_t j = 1; j < J; j++)
            qx(0.4 * mlr_test_rng_normal(&r), s->rot + 4 * (f * J + j));
    }
    for (size_t i = 0; i < N * C; i++)
        s->c[i] = mlr_test_rng_uniform(&r) < 0.3;
    fk_pts(s->root, s->rot, s->pos, s->pts);
    mlr_rig rg = rig();
    double *v = malloc(N * C * sizeof(double));
    const double qs[5] = {0.0, 0.05, 0.37, 0.5, 1.0};
    for (int i = 0; i < 5; i++) {
        size_t k = 0;
        for (size_t p = 0; p < N * C; p++)
            if (s->c[p])
                v[k++] = s->pts[3 * p + 1];
        const double want = ref_quantile(v, k, qs[i]);
        double h;
        mlr_diag d;
        ck_assert_int_eq(mlr_cleanup_floor_height(&rg, N, s->root, s->rot, NULL, C, pj, NULL, s->c,
                                                  MLR_AXIS_Y, qs[i], &h, NULL, &d),
                         MLR_OK);
        ck_assert_double_eq_tol(h, want, 1e-12);
        /* and the cleanup reports the same floor (no reference: the motion's own contacts) */
        const mlr_cleanup_option o = {MLR_CLEANUP_OPT_FLOOR_QUANTILE, qs[i]};
        mlr_cleanup_report rep;
        ck_assert_msg(run(s, 0, &o, 1, &rep, NULL, &d) == MLR_OK, "%s", d.message);
        ck_assert_double_eq_tol(rep.floor_height, want, 1e-12);
    }
    /* the End Sites count as points too; no contact at all: NaN */
    const int32_t es[C] = {-1, 0, -1, 1};
    double h;
    memset(s->c, 0, N * C);
    ck_assert_int_eq(mlr_cleanup_floor_height(&rg, N, s->root, s->rot, NULL, C, pj, es, s->c,
                                              MLR_AXIS_Y, 0.5, &h, NULL, NULL),
                     MLR_OK);
    ck_assert(isnan(h));
    s->c[7 * C + 1] = 1; /* one End Site sample: its height */
    double wr[4 * N * J], ep[3 * N * C];
    ck_assert_int_eq(mlr_fk_arrays(N, J, parents, offsets, s->root, s->rot, 0, NULL, NULL, s->pos,
                                   wr, NULL, NULL),
                     MLR_OK);
    ck_assert_int_eq(mlr_rig_point_positions(&rg, N, s->pos, wr, C, pj, es, ep, NULL), MLR_OK);
    ck_assert_int_eq(mlr_cleanup_floor_height(&rg, N, s->root, s->rot, NULL, C, pj, es, s->c,
                                              MLR_AXIS_Y, 0.5, &h, NULL, NULL),
                     MLR_OK);
    ck_assert(h == ep[3 * (7 * C + 1) + 1]);
    free(v);
    free(s);
}
END_TEST

/* ---- real clips ---- */
static const char *clips[] = {"cmu_01_01_playground_jumps.bvh", "cmu_60_10_salsa_dance.bvh",
                              "lafan1_clip_a.bvh", "cmu_131_01_mj_style_walk.bvh"};

START_TEST(real_clips_pinned_and_above_the_floor)
{
    char path[4096];
    MLR_TEST_NEED_CLIP(clips[_i]);
    mlr_test_clip_path(clips[_i], path, sizeof path);
    mlr_motion *m;
    mlr_diag d;
    ck_assert_int_eq(mlr_bvh_read_file(path, NULL, &m, &d), MLR_OK);
    size_t n = mlr_motion_n_frames(m);
    n = n > 900 ? 900 : n;
    const size_t j = mlr_motion_n_joints(m);
    ck_assert_uint_eq(mlr_motion_n_trans(m), 0);
    const char **nm = malloc(j * sizeof *nm);
    for (size_t i = 0; i < j; i++)
        nm[i] = mlr_motion_joint_name(m, i);
    mlr_rig rg = {j,
                  mlr_motion_parents(m),
                  mlr_motion_offsets(m),
                  nm,
                  0,
                  NULL,
                  mlr_motion_n_end_sites(m),
                  mlr_motion_end_site_parents(m),
                  mlr_motion_end_site_offsets(m)};
    const double fps = 1.0 / mlr_motion_frame_time(m);
    const double *root = mlr_motion_root_pos(m), *rot = mlr_motion_rot(m);
    double *wp = malloc(3 * n * j * sizeof(double)), *wr = malloc(4 * n * j * sizeof(double));
    ck_assert_int_eq(
        mlr_fk_arrays(n, j, rg.parents, rg.offsets, root, rot, 0, NULL, NULL, wp, wr, NULL, NULL),
        MLR_OK);
    double H;
    ck_assert_int_eq(mlr_rig_body_height(n, j, wp, MLR_AXIS_Y, &H, NULL, &d), MLR_OK);
    int32_t *jt = malloc(2 * j * sizeof(int32_t)), *es = malloc(2 * j * sizeof(int32_t));
    size_t F, Cn = 0;
    ck_assert_int_eq(mlr_contacts_find_feet(&rg, n, wp, MLR_AXIS_Y, j, jt, es, &F, NULL, &d),
                     MLR_OK);
    for (size_t i = 0; i < 2 * F; i++)
        if (jt[i] >= 0)
            jt[Cn] = jt[i], es[Cn] = es[i], Cn++;
    uint8_t *c = malloc(n * Cn);
    ck_assert_int_eq(
        mlr_contacts_detect(&rg, fps, MLR_AXIS_Y, n, wp, wr, Cn, jt, es, NULL, 0, c, NULL, &d),
        MLR_OK);
    /* the synthesized motion: the layers at alpha 2 */
    mlr_layers *L;
    const mlr_layers_option lo = {MLR_LAYERS_OPT_FPS, fps};
    ck_assert_int_eq(mlr_layers_decompose(n, j, root, rot, &lo, 1, NULL, &L, &d), MLR_OK);
    double *sr = malloc(3 * n * sizeof(double)), *sq = malloc(4 * n * j * sizeof(double));
    const double alpha = 2.0;
    ck_assert_int_eq(mlr_layers_synthesize(L, 0, n, &alpha, 1, sr, 3 * n, sq, 4 * n * j, NULL),
                     MLR_OK);
    mlr_layers_destroy(L);
    double *orr = malloc(3 * n * sizeof(double)), *oq = malloc(4 * n * j * sizeof(double));
    mlr_cleanup_report rep;
    ck_assert_msg(mlr_cleanup_contacts(&rg, n, fps, MLR_AXIS_Y, sr, sq, NULL, root, rot, NULL, Cn,
                                       jt, es, c, NULL, 0, orr, oq, &rep, NULL, &d) == MLR_OK,
                  "%s: %s", clips[_i], d.message);
    ck_assert(isfinite(rep.floor_height));
    ck_assert_uint_gt(rep.contact_frames, n / 10);
    double *p_ref = malloc(3 * n * Cn * sizeof(double)),
           *p_in = malloc(3 * n * Cn * sizeof(double)),
           *p_out = malloc(3 * n * Cn * sizeof(double));
    ck_assert_int_eq(mlr_rig_point_positions(&rg, n, wp, wr, Cn, jt, es, p_ref, NULL), MLR_OK);
    double *pos2 = malloc(3 * n * j * sizeof(double)), *wr2 = malloc(4 * n * j * sizeof(double));
    for (int which = 0; which < 2; which++) {
        ck_assert_int_eq(mlr_fk_arrays(n, j, rg.parents, rg.offsets, which ? orr : sr,
                                       which ? oq : sq, 0, NULL, NULL, pos2, wr2, NULL, NULL),
                         MLR_OK);
        ck_assert_int_eq(
            mlr_rig_point_positions(&rg, n, pos2, wr2, Cn, jt, es, which ? p_out : p_in, NULL),
            MLR_OK);
    }
    /* sliding: over each contact run of each point, the largest horizontal distance of
       (point - reference point) from its value at the run's first frame; and the floor */
    double slide_in = 0.0, slide_out = 0.0, below_out = 0.0;
    for (size_t p = 0; p < Cn; p++) {
        size_t s0 = 0;
        for (size_t f = 0; f < n; f++) {
            if (!c[f * Cn + p])
                continue;
            if (f == 0 || !c[(f - 1) * Cn + p])
                s0 = f;
            double di = 0.0, dout = 0.0;
            for (int k = 0; k < 3; k += 2) {
                const size_t a = 3 * (f * Cn + p) + (size_t)k, b = 3 * (s0 * Cn + p) + (size_t)k;
                const double ei = (p_in[a] - p_ref[a]) - (p_in[b] - p_ref[b]);
                const double eo = (p_out[a] - p_ref[a]) - (p_out[b] - p_ref[b]);
                di += ei * ei, dout += eo * eo;
            }
            slide_in = fmax(slide_in, sqrt(di)), slide_out = fmax(slide_out, sqrt(dout));
        }
        for (size_t f = 0; f < n; f++) {
            const size_t a = 3 * (f * Cn + p) + 1;
            below_out = fmax(below_out, fmin(rep.floor_height, p_ref[a]) - p_out[a]);
        }
    }
    /* measured: drift 0.018 / 0.035 / 0.003 / 0.004 body heights out against 0.46 / 0.24 /
       0.34 / 0.45 in (cmu_01_01, salsa, lafan1, cmu_131_01, first 900 frames, alpha 2) */
    ck_assert_msg(slide_out < 0.2 * slide_in && slide_out < 0.05 * H,
                  "%s: drift %g body heights (the synthesized %g)", clips[_i], slide_out / H,
                  slide_in / H);
    ck_assert_msg(below_out < 0.005 * H, "%s: a point %g body heights below the floor", clips[_i],
                  below_out / H);
    for (size_t i = 0; i < n * j; i++) {
        const double *q = oq + 4 * i;
        ck_assert_double_eq_tol(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-12);
    }
    free(pos2), free(wr2), free(p_ref), free(p_in), free(p_out), free(orr), free(oq), free(sr);
    free(sq), free(c), free(jt), free(es), free(wp), free(wr), free(nm);
    mlr_motion_destroy(m);
}
END_TEST

START_TEST(bad_input_gets_the_right_status_and_message)
{
    synth *s = malloc(sizeof *s);
    pose_clip(0.01, 0.0, 0, 0, s->root, s->rot);
    pose_clip(0.0, 0.0, 0, 0, s->rroot, s->rrot);
    contacts_of(s->c);
    mlr_rig rg = rig();
    mlr_diag d;
#define CL(ROOT, ROT, RR, RQ, NP, JT, ES, CC, O, NO, FPS, UP)                                   \
    mlr_cleanup_contacts(&rg, N, FPS, UP, ROOT, ROT, NULL, RR, RQ, NULL, NP, JT, ES, CC, O, NO, \
                         s->oroot, s->orot, NULL, NULL, &d)
#define EXPECT(call, text)                                                                  \
    do {                                                                                    \
        ck_assert_int_eq(call, MLR_E_INVALID_ARG);                                          \
        ck_assert_msg(strstr(d.message, text) != NULL, "'%s' lacks '%s'", d.message, text); \
    } while (0)
    const int32_t bad_j[C] = {3, 4, 7, 12};
    EXPECT(CL(s->root, s->rot, NULL, NULL, C, bad_j, NULL, s->c, NULL, 0, 60.0, 1),
           "contact point 3: joint 12 names nothing");
    const int32_t es_wrong[C] = {-1, 1, -1, -1}; /* End Site 1 belongs to RightToe */
    EXPECT(CL(s->root, s->rot, NULL, NULL, C, pj, es_wrong, s->c, NULL, 0, 60.0, 1),
           "End Site 1 is not an End Site of joint 4");
    const int32_t es_out[C] = {-1, -1, -1, 5};
    EXPECT(CL(s->root, s->rot, NULL, NULL, C, pj, es_out, s->c, NULL, 0, 60.0, 1),
           "End Site 5 is not an End Site of joint 8");
    const int32_t twice[C] = {3, 4, 3, 8};
    EXPECT(CL(s->root, s->rot, NULL, NULL, C, twice, NULL, s->c, NULL, 0, 60.0, 1),
           "contact points 0 and 2 are the same point");
    EXPECT(CL(s->root, s->rot, NULL, NULL, C, NULL, NULL, s->c, NULL, 0, 60.0, 1),
           "joints is NULL");
    EXPECT(CL(s->root, s->rot, NULL, NULL, C, pj, NULL, NULL, NULL, 0, 60.0, 1), "contacts");
    /* a contact on a joint with no two-bone chain */
    const int32_t hipc[C] = {3, 4, 7, 1};
    EXPECT(CL(s->root, s->rot, NULL, NULL, C, hipc, NULL, s->c, NULL, 0, 60.0, 1),
           "'LeftUpLeg' has no two-bone chain");
    EXPECT(CL(s->root, s->rot, NULL, NULL, C, pj, NULL, s->c, NULL, 0, 0.0, 1), "fps 0");
    EXPECT(CL(s->root, s->rot, NULL, NULL, C, pj, NULL, s->c, NULL, 0, NAN, 1), "fps nan");
    EXPECT(CL(s->root, s->rot, NULL, NULL, C, pj, NULL, s->c, NULL, 0, 60.0, 3), "up axis 3");
    EXPECT(CL(NULL, s->rot, NULL, NULL, C, pj, NULL, s->c, NULL, 0, 60.0, 1),
           "motion: root_pos, rot is NULL");
    EXPECT(CL(s->root, s->rot, s->rroot, NULL, C, pj, NULL, s->c, NULL, 0, 60.0, 1),
           "reference: root_pos, rot is NULL");
    s->rot[4 * 17 + 2] = NAN;
    EXPECT(CL(s->root, s->rot, NULL, NULL, C, pj, NULL, s->c, NULL, 0, 60.0, 1),
           "motion contains NaN or infinite values");
    s->rot[4 * 17 + 2] = 0.0;
    s->rroot[5] = INFINITY;
    EXPECT(CL(s->root, s->rot, s->rroot, s->rrot, C, pj, NULL, s->c, NULL, 0, 60.0, 1),
           "reference contains NaN or infinite values");
    s->rroot[5] = 0.0;
    /* options */
    const struct {
        mlr_cleanup_option o[2];
        size_t n;
        const char *msg;
    } bad[] = {
        {{{0, 1.0}}, 1, "unknown option key 0"},
        {{{18, 1.0}}, 1, "unknown option key 18"},
        {{{MLR_CLEANUP_OPT_SOFT_REACH, 0.6}}, 1, "option soft_reach = 0.6 is not in [0, 0.5]"},
        {{{MLR_CLEANUP_OPT_SOFT_REACH, NAN}}, 1, "option soft_reach = nan is not finite"},
        {{{MLR_CLEANUP_OPT_ROOT_BOB, -1}}, 1, "option root_bob = -1 is not >= 0"},
        {{{MLR_CLEANUP_OPT_ROOT_BOB, NAN}}, 1, "option root_bob = nan is not finite"},
        {{{MLR_CLEANUP_OPT_STRAIGHT_SLACK, -1}}, 1, "option straight_slack = -1 is not >= 0"},
        {{{MLR_CLEANUP_OPT_STRAIGHT_SLACK, NAN}}, 1, "option straight_slack = nan is not finite"},
        {{{MLR_CLEANUP_OPT_RAMP_TRACK, 0.5}}, 1, "option ramp_track = 0.5 is not 0 or 1"},
        {{{MLR_CLEANUP_OPT_PIN_DETAIL, 1.5}}, 1, "option pin_detail = 1.5 is not in [0, 1]"},
        {{{MLR_CLEANUP_OPT_KEEP_TOTAL, 0.5}}, 1, "option keep_total = 0.5 is not 0 or 1"},
        {{{MLR_CLEANUP_OPT_BLEND, 0.1}, {MLR_CLEANUP_OPT_BLEND, 0.2}},
         2,
         "cleanup: option blend given twice"},
        {{{MLR_CLEANUP_OPT_BLEND, NAN}}, 1, "option blend = nan is not finite"},
        {{{MLR_CLEANUP_OPT_FLOOR_HEIGHT, INFINITY}}, 1, "option floor_height = inf is not finite"},
        {{{MLR_CLEANUP_OPT_MAX_FOLD, -INFINITY}}, 1, "option max_fold = -inf is not finite"},
        {{{MLR_CLEANUP_OPT_BLEND, 0.0}}, 1, "option blend = 0 is not > 0"},
        {{{MLR_CLEANUP_OPT_REACH, 1.5}}, 1, "option reach = 1.5 is not in (0, 1]"},
        {{{MLR_CLEANUP_OPT_PASSES, 2.5}}, 1, "option passes = 2.5 is not an integer in [1, 10]"},
        {{{MLR_CLEANUP_OPT_PASSES, 11}}, 1, "option passes = 11 is not an integer in [1, 10]"},
        {{{MLR_CLEANUP_OPT_FLOOR, 0.5}}, 1, "option floor = 0.5 is not 0 or 1"},
        {{{MLR_CLEANUP_OPT_FLOOR_QUANTILE, -0.1}},
         1,
         "option floor_quantile = -0.1 is not in [0, 1]"},
        {{{MLR_CLEANUP_OPT_REF_SMOOTH, -1}}, 1, "option ref_smooth = -1 is not >= 0"},
        {{{MLR_CLEANUP_OPT_PIN_SMOOTH, 0}}, 1, "option pin_smooth = 0 is not > 0"},
        {{{MLR_CLEANUP_OPT_ROOT, 2}}, 1, "option root = 2 is not 0 or 1"},
        {{{MLR_CLEANUP_OPT_MAX_FOLD, 0}}, 1, "option max_fold = 0 is not in (0, pi]"},
        {{{MLR_CLEANUP_OPT_MAX_FOLD, 3.2}}, 1, "option max_fold = 3.2 is not in (0, pi]"},
        {{{MLR_CLEANUP_OPT_KEEP_STILLER, 0.5}},
         1,
         "option keep_stiller = 0.5 is not 0 (off) or >= 1"},
        {{{MLR_CLEANUP_OPT_KEEP_STILLER, NAN}}, 1, "option keep_stiller = nan is not finite"},
    };
    for (size_t i = 0; i < MLR_COUNTOF(bad); i++)
        EXPECT(CL(s->root, s->rot, NULL, NULL, C, pj, NULL, s->c, bad[i].o, bad[i].n, 60.0, 1),
               bad[i].msg);
    EXPECT(CL(s->root, s->rot, NULL, NULL, C, pj, NULL, s->c, NULL, 2, 60.0, 1),
           "opts is NULL but n_opts is 2");
    ck_assert_int_eq(mlr_cleanup_contacts(NULL, N, 60.0, 1, s->root, s->rot, NULL, NULL, NULL,
                                          NULL, C, pj, NULL, s->c, NULL, 0, s->oroot, s->orot,
                                          NULL, NULL, &d),
                     MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_cleanup_contacts(&rg, N, 60.0, 1, s->root, s->rot, NULL, NULL, NULL, NULL,
                                          C, pj, NULL, s->c, NULL, 0, NULL, s->orot, NULL, NULL,
                                          &d),
                     MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "NULL outputs"));
    /* floor_height */
    double h;
    EXPECT(mlr_cleanup_floor_height(&rg, N, s->root, s->rot, NULL, C, bad_j, NULL, s->c, 1, 0.05,
                                    &h, NULL, &d),
           "joint 12 names nothing");
    EXPECT(mlr_cleanup_floor_height(&rg, N, s->root, s->rot, NULL, C, pj, NULL, s->c, 1, 1.5, &h,
                                    NULL, &d),
           "quantile 1.5 outside [0, 1]");
    EXPECT(mlr_cleanup_floor_height(&rg, N, s->root, s->rot, NULL, C, pj, NULL, s->c, 1, NAN, &h,
                                    NULL, &d),
           "quantile nan");
    EXPECT(mlr_cleanup_floor_height(&rg, N, s->root, s->rot, NULL, C, pj, NULL, s->c, -1, 0.05, &h,
                                    NULL, &d),
           "up axis -1");
    EXPECT(mlr_cleanup_floor_height(&rg, N, s->root, s->rot, NULL, C, pj, NULL, NULL, 1, 0.05, &h,
                                    NULL, &d),
           "contacts");
    EXPECT(mlr_cleanup_floor_height(&rg, 0, s->root, s->rot, NULL, C, pj, NULL, s->c, 1, 0.05, &h,
                                    NULL, &d),
           "no frames");
    s->root[4] = NAN;
    EXPECT(mlr_cleanup_floor_height(&rg, N, s->root, s->rot, NULL, C, pj, NULL, s->c, 1, 0.05, &h,
                                    NULL, &d),
           "motion contains NaN");
    free(s);
#undef CL
#undef EXPECT
}
END_TEST

/* The job (mlr_cleanup_job): the same bits as the long form, with and without a reference and
   a floor; the job's own field errors named; validate agrees with run. */
START_TEST(a_job_gives_the_long_forms_bits)
{
    synth *s = malloc(sizeof *s), *t = malloc(sizeof *t);
    pose_clip(0.01, 0.0, 0, 0, s->root, s->rot);
    pose_clip(0.0, 0.0, 0, 0, s->rroot, s->rrot);
    contacts_of(s->c);
    const mlr_rig rg = rig();
    for (int with_ref = 0; with_ref < 2; with_ref++) {
        mlr_cleanup_report r1, r2;
        mlr_diag d;
        ck_assert_msg(run(s, with_ref, NULL, 0, &r1, NULL, &d) == MLR_OK, "%s", d.message);
        mlr_cleanup_job job = {0};
        job.rig = &rg, job.fps = 60.0, job.up = MLR_AXIS_Y;
        job.motion = (mlr_frames){N, s->root, s->rot, NULL};
        if (with_ref)
            job.reference = (mlr_frames){N, s->rroot, s->rrot, NULL};
        job.points = (mlr_cleanup_points){C, pj, NULL, s->c};
        job.out_root_pos = t->oroot, job.out_rot = t->orot, job.report = &r2;
        ck_assert_int_eq(mlr_cleanup_job_validate(&job, &d), MLR_OK);
        ck_assert_msg(mlr_cleanup_job_run(&job, NULL, &d) == MLR_OK, "%s", d.message);
        ck_assert_int_eq(memcmp(t->oroot, s->oroot, sizeof s->oroot), 0);
        ck_assert_int_eq(memcmp(t->orot, s->orot, sizeof s->orot), 0);
        ck_assert(r1.contact_frames == r2.contact_frames && r1.floor_frames == r2.floor_frames);
        ck_assert(r1.floor_height == r2.floor_height && r1.root_shift_max == r2.root_shift_max);
        double h1, h2;
        ck_assert_int_eq(mlr_cleanup_floor_height(&rg, N, s->root, s->rot, NULL, C, pj, NULL, s->c,
                                                  MLR_AXIS_Y, 0.05, &h1, NULL, NULL),
                         MLR_OK);
        ck_assert_int_eq(mlr_cleanup_job_floor_height(&job, 0.05, &h2, NULL, NULL), MLR_OK);
        ck_assert(h1 == h2 && isfinite(h1));
        /* the job's own fields */
        job.reference.n_frames = with_ref ? N - 1 : 3;
        ck_assert_int_eq(mlr_cleanup_job_validate(&job, &d), MLR_E_INVALID_ARG);
        ck_assert_ptr_nonnull(strstr(d.message, "job.reference.n_frames"));
        ck_assert_int_eq(mlr_cleanup_job_run(&job, NULL, &d), MLR_E_INVALID_ARG);
        ck_assert_ptr_nonnull(strstr(d.message, "job.reference.n_frames"));
        job.reference.n_frames = with_ref ? N : 0;
        /* what the long form refuses, validate refuses with its message */
        job.fps = 0.0;
        ck_assert_int_eq(mlr_cleanup_job_validate(&job, &d), MLR_E_INVALID_ARG);
        ck_assert_ptr_nonnull(strstr(d.message, "fps 0 is not finite"));
        job.fps = 60.0, job.points.contacts = NULL;
        ck_assert_int_eq(mlr_cleanup_job_validate(&job, &d), MLR_E_INVALID_ARG);
        ck_assert_ptr_nonnull(strstr(d.message, "NULL outputs or contacts"));
    }
    mlr_diag d;
    ck_assert_int_eq(mlr_cleanup_job_validate(NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_ptr_nonnull(strstr(d.message, "NULL job"));
    ck_assert_int_eq(mlr_cleanup_job_run(NULL, NULL, &d), MLR_E_INVALID_ARG);
    ck_assert_int_eq(mlr_cleanup_job_floor_height(NULL, 0.05, NULL, NULL, &d), MLR_E_INVALID_ARG);
    free(s), free(t);
}
END_TEST

START_TEST(every_allocation_failure_returns_no_memory_without_leaks)
{
    synth *s = malloc(sizeof *s);
    /* every path: a reference (smoothed), the floor, the root shift (MAX_FOLD), the toes */
    pose_clip(0.01, 2.5, 70, 130, s->root, s->rot);
    pose_clip(0.0, 0.0, 0, 0, s->rroot, s->rrot);
    contacts_of(s->c);
    const mlr_cleanup_option o = {MLR_CLEANUP_OPT_MAX_FOLD, 1.0};
    mlr_cleanup_report ok_rep;
    ck_assert_int_eq(run(s, 1, &o, 1, &ok_rep, NULL, NULL), MLR_OK);
    ck_assert(ok_rep.root_shift_max > 0.0 && ok_rep.floor_frames > 0);
    double want_root[3 * N];
    memcpy(want_root, s->oroot, sizeof want_root);
    size_t fail_at = 0;
    for (;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        mlr_diag d;
        const mlr_status st = run(s, 1, &o, 1, NULL, &ta.base, &d);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (st == MLR_OK)
            break;
        ck_assert_int_eq(st, MLR_E_NO_MEMORY);
        ck_assert_msg(strstr(d.message, "memory") != NULL, "allocation %zu: %s", fail_at,
                      d.message);
    }
    ck_assert_uint_ge(fail_at, 20);
    ck_assert_int_eq(memcmp(want_root, s->oroot, sizeof want_root), 0);
    mlr_rig rg = rig();
    for (fail_at = 0;; fail_at++) {
        mlr_test_allocator ta;
        mlr_test_allocator_init(&ta, fail_at);
        double h;
        const mlr_status st = mlr_cleanup_floor_height(&rg, N, s->root, s->rot, NULL, C, pj, NULL,
                                                       s->c, 1, 0.05, &h, &ta.base, NULL);
        ck_assert_uint_eq(ta.live_blocks, 0);
        if (st == MLR_OK)
            break;
        ck_assert_int_eq(st, MLR_E_NO_MEMORY);
    }
    ck_assert_uint_ge(fail_at, 4);
    free(s);
}
END_TEST

START_TEST(a_rig_with_eight_feet_is_cleaned_up)
{
    /* a crab: the root with 8 legs (hip, knee, ankle); every ankle a contact point. Scratch
       blocks no longer grow with the number of feet (they did: 5 or more feet ran out of the
       arena's blocks and returned MLR_E_NO_MEMORY) */
    enum { L = 8, JC = 1 + 3 * L, NC = 120 };
    int32_t par[JC];
    double off[3 * JC];
    const char *nm[JC];
    char buf[JC][16];
    par[0] = -1, off[0] = off[1] = off[2] = 0.0, nm[0] = "Body";
    int32_t pts[L];
    for (int l = 0; l < L; l++) {
        const double a = 2.0 * PI * l / L;
        for (int b = 0; b < 3; b++) {
            const int j = 1 + 3 * l + b;
            par[j] = b == 0 ? 0 : j - 1;
            snprintf(buf[j], sizeof buf[j], "leg%d_%d", l, b);
            nm[j] = buf[j];
            off[3 * j] = b == 0 ? cos(a) : b == 1 ? 2.0 * cos(a) : 0.3 * cos(a);
            off[3 * j + 1] = b == 0 ? 0.0 : b == 1 ? 1.0 : -3.0;
            off[3 * j + 2] = b == 0 ? sin(a) : b == 1 ? 2.0 * sin(a) : 0.3 * sin(a);
        }
        pts[l] = 3 + 3 * l;
    }
    mlr_rig rg = {JC, par, off, nm, 0, NULL, 0, NULL, NULL};
    double *root = malloc(3 * NC * sizeof(double)), *rot = malloc(4 * NC * JC * sizeof(double));
    double *oroot = malloc(3 * NC * sizeof(double)), *orot = malloc(4 * NC * JC * sizeof(double));
    uint8_t *c = malloc(NC * L);
    for (size_t f = 0; f < NC; f++) {
        root[3 * f] = 0.01 * (double)f, root[3 * f + 1] = 2.0, root[3 * f + 2] = 0.0;
        for (size_t j = 0; j < JC; j++)
            qx(0.0, rot + 4 * (f * JC + j));
        for (int l = 0; l < L; l++)
            c[f * L + (size_t)l] = f >= 20 + 5 * (size_t)l && f < 60 + 5 * (size_t)l;
    }
    mlr_cleanup_report rep;
    mlr_diag d;
    ck_assert_msg(mlr_cleanup_contacts(&rg, NC, 60.0, MLR_AXIS_Y, root, rot, NULL, NULL, NULL,
                                       NULL, L, pts, NULL, c, NULL, 0, oroot, orot, &rep, NULL,
                                       &d) == MLR_OK,
                  "%s", d.message);
    ck_assert_uint_eq(rep.contact_frames, 75);
    /* every ankle pinned to its mean over its contact */
    double *pos = malloc(3 * NC * JC * sizeof(double)), *wr = malloc(4 * NC * JC * sizeof(double));
    double *pos0 = malloc(3 * NC * JC * sizeof(double));
    ck_assert_int_eq(
        mlr_fk_arrays(NC, JC, par, off, root, rot, 0, NULL, NULL, pos0, wr, NULL, NULL), MLR_OK);
    ck_assert_int_eq(
        mlr_fk_arrays(NC, JC, par, off, oroot, orot, 0, NULL, NULL, pos, wr, NULL, NULL), MLR_OK);
    for (int l = 0; l < L; l++) {
        const size_t lo = 20 + 5 * (size_t)l, a = (size_t)pts[l];
        double m[3] = {0, 0, 0};
        for (size_t f = lo; f < lo + 40; f++)
            for (int k = 0; k < 3; k++)
                m[k] += pos0[3 * (f * JC + a) + (size_t)k] / 40.0;
        for (size_t f = lo; f < lo + 40; f++)
            ck_assert_msg(dist(pos + 3 * (f * JC + a), m) < 1e-7, "leg %d frame %zu", l, f);
    }
    free(pos), free(wr), free(pos0), free(root), free(rot), free(oroot), free(orot), free(c);
}
END_TEST

static Suite *cleanup_suite(void)
{
    Suite *s = suite_create("cleanup");
    TCase *tc = tcase_create("cleanup");
    tcase_add_test(tc, a_sliding_foot_is_pinned_to_its_contact);
    tcase_add_test(tc, a_short_gap_where_the_foot_stays_is_closed);
    tcase_add_test(tc, soft_reach_bends_a_knee_whose_target_leaves_its_reach);
    tcase_add_test(tc, keep_total_caps_the_feet_sliding_at_the_references);
    tcase_add_test(tc, frames_far_from_every_constrained_frame_keep_the_input);
    tcase_add_test(tc, the_floor_is_respected);
    tcase_add_test(tc, max_fold_moves_the_root_away_from_a_near_target);
    tcase_add_test(tc, floor_height_is_the_quantile_of_contact_heights);
    tcase_add_loop_test(tc, real_clips_pinned_and_above_the_floor, 0, (int)MLR_COUNTOF(clips));
    tcase_add_test(tc, a_rig_with_eight_feet_is_cleaned_up);
    tcase_add_test(tc, bad_input_gets_the_right_status_and_message);
    tcase_add_test(tc, a_job_gives_the_long_forms_bits);
    tcase_add_test(tc, every_allocation_failure_returns_no_memory_without_leaks);
    suite_add_tcase(s, tc);
    return s;
}

int main(void) { return mlr_test_run(cleanup_suite()); }
