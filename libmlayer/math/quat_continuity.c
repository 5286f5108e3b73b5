/* Sign continuity of quaternion tracks: the nearest-sign rule (mlr_quat_make_continuous) and the
 * predictive rule that keeps fast rotations (mlr_quat_continue_sign and its array forms).
 * Nothing here allocates, prints or keeps state. */
#include "math/quat_internal.h"

void mlr_quat_make_continuous(mlr_quat *q, size_t n_frames, size_t n_tracks)
{
    if (!q || n_frames < 2 || n_tracks == 0)
        return;
    for (size_t f = 1; f < n_frames; f++) {
        const mlr_quat *prev = &q[(f - 1) * n_tracks];
        mlr_quat *cur = &q[f * n_tracks];
        for (size_t j = 0; j < n_tracks; j++) {
            const double d = prev[j].w * cur[j].w + prev[j].x * cur[j].x + prev[j].y * cur[j].y +
                             prev[j].z * cur[j].z;
            if (d < 0.0) {
                cur[j].w = -cur[j].w;
                cur[j].x = -cur[j].x;
                cur[j].y = -cur[j].y;
                cur[j].z = -cur[j].z;
            }
        }
    }
}

/* Thresholds of the predictive sign rule, as cosines of angles between unit quaternions
 * (half the rotation angles): a step below 60 degrees of rotation is always short (30 deg);
 * a step of at most 300 degrees (150 deg) may be long; the prediction must be within 90
 * degrees of rotation (45 deg), and so must the change of step (acceleration check). */
#define CONT_COS_FAST 0.86602540378443865 /* cos 30 deg */
#define CONT_COS_MAX_STEP -0.86602540378443865 /* cos 150 deg */
#define CONT_COS_PRED 0.70710678118654752 /* cos 45 deg */

static double quat_dot(const mlr_quat *a, const mlr_quat *b)
{
    return a->w * b->w + a->x * b->x + a->y * b->y + a->z * b->z;
}

static void quat_neg(const mlr_quat *q, mlr_quat *out)
{
    out->w = -q->w;
    out->x = -q->x;
    out->y = -q->y;
    out->z = -q->z;
}

/* conj(a) * b */
static void quat_conj_mul(const mlr_quat *a, const mlr_quat *b, mlr_quat *out)
{
    const mlr_quat ca = {a->w, -a->x, -a->y, -a->z};
    mlr_quat_mul(&ca, b, out);
}

void mlr_quat_continue_sign(const mlr_quat *prev, size_t n_prev, const mlr_quat *q, mlr_quat *out)
{
    if (!q || !out)
        return;
    if (n_prev == 0 || !prev) {
        *out = *q;
        return;
    }
    if (n_prev > 3) {
        prev += n_prev - 3;
        n_prev = 3;
    }
    const mlr_quat *p1 = &prev[n_prev - 1];
    const double d = quat_dot(q, p1);
    const double nn = quat_dot(q, q) * quat_dot(p1, p1);
    /* nearest sign: the fallback, and the answer for any step below 60 degrees */
    mlr_quat c = *q;
    if (d < 0.0)
        quat_neg(q, &c);
    if (n_prev < 2 || d * d >= CONT_COS_FAST * CONT_COS_FAST * nn) {
        *out = c;
        return;
    }
    mlr_quat u1, u2, uc, step, pred;
    if (!quat__unit(p1, &u1) || !quat__unit(&prev[n_prev - 2], &u2) || !quat__unit(&c, &uc)) {
        *out = c;
        return;
    }
    if (quat_dot(&u1, &u2) < CONT_COS_MAX_STEP) { /* previous step above 300 degrees */
        *out = c;
        return;
    }
    quat_conj_mul(&u2, &u1, &step); /* previous step, in the frame of u2 */
    mlr_quat_mul(&u1, &step, &pred);
    /* the longer representative is -uc: it must be near the prediction */
    if (-quat_dot(&uc, &pred) < CONT_COS_PRED) {
        *out = c;
        return;
    }
    if (n_prev >= 3) {
        mlr_quat u3, step_before;
        if (!quat__unit(&prev[0], &u3)) {
            *out = c;
            return;
        }
        quat_conj_mul(&u3, &u2, &step_before);
        if (quat_dot(&step, &step_before) < CONT_COS_PRED) {
            *out = c;
            return;
        }
    }
    quat_neg(&c, out);
}

void common__quat_continue_frame(mlr_quat *q, size_t f, size_t n_tracks)
{
    const size_t n_prev = f < 3 ? f : 3;
    mlr_quat *cur = &q[f * n_tracks];
    for (size_t j = 0; j < n_tracks; j++) {
        mlr_quat hist[3];
        for (size_t k = 0; k < n_prev; k++) /* oldest first */
            hist[k] = q[(f - n_prev + k) * n_tracks + j];
        mlr_quat_continue_sign(hist, n_prev, &cur[j], &cur[j]);
    }
}

void mlr_quat_make_continuous_predictive(mlr_quat *q, size_t n_frames, size_t n_tracks)
{
    if (!q || n_frames < 2 || n_tracks == 0)
        return;
    for (size_t f = 1; f < n_frames; f++)
        common__quat_continue_frame(q, f, n_tracks);
}
