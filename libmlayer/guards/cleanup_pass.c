/*
 * One pass of the contact cleanup: forward kinematics of the frames that changed, the floor
 * frames, two-bone IK of the legs and the turn of the ankles for the toes, then the spread.
 */
#include "guards/cleanup_internal.h"
#include "guards/ik_internal.h"

#include <math.h>
#include <string.h>

void cleanup__find_chains(cleanup_state *cu)
{
    const size_t J = cu->J, nf = cu->nf;
    const mlr_rig *rig = cu->rig;
    const cleanup_foot *feet = cu->feet;
    int32_t *chains = cu->chains;
    int chained = 1;
    for (size_t k = 0; k < nf; k++) {
        const cleanup_foot *ft = &feet[k];
        if (!ft->active)
            continue;
        /* the chain bottom-up: the placed point's joint (or the anchor) to the hip */
        const int32_t bottom =
            ft->n_cols > ft->n_own ? cu->joints[ft->cols[ft->n_own]] : ft->anchor;
        size_t n = 0;
        int32_t j = bottom;
        for (; j >= 0 && n < J; j = rig->parents[j]) {
            chains[k * J + n++] = j;
            if (j == ft->hip)
                break;
        }
        if (j != ft->hip) {
            chained = 0;
            break;
        }
        for (size_t i = 0; i < n / 2; i++) { /* top-down */
            const int32_t t = chains[k * J + i];
            chains[k * J + i] = chains[k * J + n - 1 - i], chains[k * J + n - 1 - i] = t;
        }
        cu->chain_len[k] = n;
        /* ... and above the hip, up to the root: no other foot's hip, knee or anchor */
        for (size_t q = 0; chained && q < nf; q++) {
            if (q == k || !feet[q].active)
                continue;
            for (int32_t u = bottom; u >= 0; u = rig->parents[u])
                if (u == feet[q].hip || u == feet[q].knee || u == feet[q].anchor)
                    chained = 0;
        }
    }
    cu->chained = chained;
}

/* Frames from f to the nearest frame of a kept contact run of ft, at most cap. */
static double to_kept(const cleanup_foot *ft, size_t N, size_t f, double cap)
{
    const size_t c = (size_t)cap;
    for (size_t d = 0; d <= c; d++)
        if ((f >= d && ft->K[f - d]) || (f + d < N && ft->K[f + d]))
            return (double)d;
    return cap;
}

/* Floor frames of a pass: a point below its limit (less the dead zone), the foot not in
   contact (each foot's lift and F, anyF). Within the blend of a kept contact run (held as it
   is, not lifted, though a toe tip may be below its limit there) the lift enters by a
   smootherstep of the distance: a floor frame lifted in full next to a kept run's last frame
   raised the ankle by 2.6% of body height in one frame (CMU 131_01 at alpha 0.5). (A pinned
   run's ramps lift its neighbours as its offset leaves.) */
static void find_floor_frames(cleanup_state *cu)
{
    const size_t N = cu->N, C = cu->C;
    const int up = cu->up;
    const double *lim = cu->lim, *P2 = cu->P;
    const double fade = cu->cfg->blend * cu->fps;
    memset(cu->anyF, 0, N);
    for (size_t k = 0; k < cu->nf; k++) {
        cleanup_foot *ft = &cu->feet[k];
        if (!ft->active || !cu->floor_active)
            continue;
        const double slack = CLEANUP_FLOOR_SLACK * ft->leg;
        for (size_t f = 0; f < N; f++) {
            double lift = 0.0;
            for (size_t i = 0; i < ft->n_cols; i++) {
                const size_t c = ft->cols[i];
                lift =
                    common__fmax(lift, lim[f * C + c] - P2[3 * (f * C + c) + (size_t)up] - slack);
            }
            if (lift > 0.0 && !ft->U[f] && fade >= 1.0) {
                double x = to_kept(ft, N, f, fade) / fade;
                x = x > 1.0 ? 1.0 : x;
                lift *= x * x * x * (x * (6.0 * x - 15.0) + 10.0);
            }
            ft->lift[f] = lift;
            if (!ft->U[f] && lift > 0.0)
                ft->F[f] = 1;
            cu->anyF[f] |= ft->F[f] && lift > 0.0;
        }
    }
}

/* newr = out_rot where the pass reads it: everywhere, or each chain's joints (the leg's hip,
   knee, anchor) on the frames where its foot is constrained (U or F: the IK, the toes' turn
   and the spread read newr there only; the spread reads it on the frames the pass solves, and
   takes those it leaves, reached or kept, as unchanged: CLEANUP_HELD_SAME). */
static void copy_leg_rotations(const cleanup_state *cu)
{
    const size_t N = cu->N, J = cu->J;
    double *newr = cu->newr;
    const double *out_rot = cu->out_rot;
    if (!cu->chained) {
        memcpy(newr, out_rot, N * J * 4 * sizeof(double));
        return;
    }
    for (size_t k = 0; k < cu->nf; k++) {
        const cleanup_foot *ft = &cu->feet[k];
        const int32_t *chain = cu->chains + k * J;
        const size_t n = cu->chain_len[k];
        for (size_t f = 0; ft->active && f < N; f++) {
            if (!ft->U[f] && !ft->F[f])
                continue;
            for (size_t i = 0; i < n; i++) {
                const size_t j = (size_t)chain[i];
                memcpy(newr + 4 * (f * J + j), out_rot + 4 * (f * J + j), 4 * sizeof(double));
            }
        }
    }
}

/* Within REACHED times the leg's length of its targets, a leg is left as it is: IK would move
   it by rounding (the pass before put it there, to ~1e-10 of the leg's length). */
#define REACHED 1e-8

/* Do a - o and b - o point the same way, to within REACHED radians? (place_toes turns the
   anchor so that its placed point points at the target from it.) */
static int aligned(const double *a, const double *b, const double *o)
{
    const double u[3] = {a[0] - o[0], a[1] - o[1], a[2] - o[2]};
    const double v[3] = {b[0] - o[0], b[1] - o[1], b[2] - o[2]};
    const double c[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                         u[0] * v[1] - u[1] * v[0]};
    const double uv = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    const double c2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    const double n2 =
        (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    return uv > 0.0 && c2 <= REACHED * REACHED * n2;
}

/* The legs' rotations of the batch's frames f[i] into newr, from L's IK (its slow frames by
   ik__two_bone_1 first). */
static void finish_legs(const cleanup_state *cu, const cleanup_foot *ft, mlr_ik_lanes *L,
                        const size_t *fr, size_t m, int have_axis)
{
    const size_t J = cu->J;
    const size_t h = (size_t)ft->hip, kn = (size_t)ft->knee;
    const int32_t pk = cu->rig->parents[kn], ph = cu->rig->parents[h];
    for (size_t i = 0; i < m; i++) {
        const double *G = cu->wrot + 4 * fr[i] * J;
        double rh[4], rk[4];
        if (L->slow[i]) {
            const double a[3] = {L->a[0][i], L->a[1][i], L->a[2][i]},
                         b[3] = {L->b[0][i], L->b[1][i], L->b[2][i]},
                         c[3] = {L->c[0][i], L->c[1][i], L->c[2][i]},
                         t[3] = {L->t[0][i], L->t[1][i], L->t[2][i]},
                         ax[3] = {L->axis[0][i], L->axis[1][i], L->axis[2][i]};
            ik__two_bone_1(a, b, c, t, have_axis ? ax : NULL, MLR_IK_MAX_EXTENSION, rh, rk);
        } else {
            for (int k = 0; k < 4; k++)
                rh[k] = L->r_hip[k][i], rk[k] = L->r_knee[k][i];
        }
        ik__rotate_to_1(cu->newr + 4 * (fr[i] * J + kn), pk >= 0 ? G + 4 * (size_t)pk : NULL,
                        G + 4 * kn, rk);
        ik__rotate_to_1(cu->newr + 4 * (fr[i] * J + h), ph >= 0 ? G + 4 * (size_t)ph : NULL,
                        G + 4 * h, rh);
    }
}

/* A contact target that asks a straight leg to shorten by a hair (MLR_CLEANUP_OPT_STRAIGHT_SLACK,
   zone in leg lengths; the guards' 0.002): the part of the correction
   d along the hip-anchor line, l, becomes l x^2 / (1 + x^2), x = |l| / zone, on a leg whose
   bones are within STRAIGHT_FROM of straight (the sine of the angle between them), blended
   back into the whole correction by STRAIGHT_TO. On a straight leg a hair is no small thing:
   the IK bent the knee of CMU 01_03's climbing leg by 2 degrees (0.58% of body height at the
   knee) to take its foot 0.03% of body height closer to the hip, on a capture the cleanup
   should leave as it is. What is left along the line is at most zone / 2;
   across it (a slide) the correction is whole: the same zone on the whole correction let a
   slow walk's planted foot wobble (Xia's depressed walk at alpha 3: a pop of 1.8x). */
#define STRAIGHT_FROM 0.02
#define STRAIGHT_TO 0.1
static void pin_dead_zone(const double *hip, const double *knee, const double *now, double zone,
                          double *target)
{
    const double u[3] = {knee[0] - hip[0], knee[1] - hip[1], knee[2] - hip[2]};
    const double v[3] = {now[0] - knee[0], now[1] - knee[1], now[2] - knee[2]};
    const double c[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                         u[0] * v[1] - u[1] * v[0]};
    const double uv = sqrt((u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) *
                           (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]));
    double e[3] = {now[0] - hip[0], now[1] - hip[1], now[2] - hip[2]};
    const double en = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    if (!(uv > 0.0) || !(en > 0.0) || !(zone > 0.0))
        return;
    const double sb = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) / uv;
    const double w =
        1.0 -
        common__fmin(1.0, common__fmax(0.0, (sb - STRAIGHT_FROM) / (STRAIGHT_TO - STRAIGHT_FROM)));
    if (w <= 0.0)
        return;
    double l = 0.0;
    for (int k = 0; k < 3; k++) {
        e[k] /= en;
        l += (target[k] - now[k]) * e[k];
    }
    const double s = 1.0 - w + w * l * l / (l * l + zone * zone);
    for (int k = 0; k < 3; k++)
        target[k] += (s - 1.0) * l * e[k];
}

/* A target farther from the hip than b = L (1 - soft) drawn in along the hip-target line
   to b + soft L (1 - exp(-(d - b) / (soft L))), but no nearer than the leg's extension now
   (MLR_CLEANUP_OPT_SOFT_REACH; L the leg's length): the soft IK of game runtimes. Near full
   reach the knee's bend turns fast with the target's distance (d = L cos(bend / 2) for equal
   bones: 1% nearer bends it by 16 degrees), so a target that passes full reach for a few
   frames snapped the knee straight and back. The curve leaves d as it is up to b, is C1 there
   and stays below L; the leg's own extension as a floor keeps a straight leg asked to move a
   hair straight (it is not bent for the softness). */
static void soft_reach(const double *hip, double len, double d_now, double soft, double *target)
{
    if (!(soft > 0.0) || !(len > 0.0))
        return;
    double e[3] = {target[0] - hip[0], target[1] - hip[1], target[2] - hip[2]};
    const double d = sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    const double s = soft * len, b = len - s;
    if (!(d > b))
        return;
    const double d2 = common__fmax(b + s * (1.0 - exp(-(d - b) / s)), common__fmin(d, d_now));
    for (int k = 0; k < 3; k++)
        target[k] = hip[k] + e[k] * (d2 / d);
}

/* Two-bone IK of each leg on its constrained frames (contact targets, or the ankle raised
   above the floor), into newr; where the anchor (and on contact frames the placed point) is
   already within REACHED of its target, the leg is left as it is (ft->S). The frames to
   solve go by batches of MLR_IK_LANES through ik__two_bone_lanes. */
static void solve_legs(const cleanup_state *cu)
{
    const size_t N = cu->N, J = cu->J, C = cu->C;
    const int up = cu->up;
    const double *pos = cu->pos, *wrot = cu->wrot, *P = cu->P;
    mlr_ik_lanes L;
    size_t fr[MLR_IK_LANES];
    for (size_t k = 0; k < cu->nf; k++) {
        cleanup_foot *ft = &cu->feet[k];
        if (!ft->active)
            continue;
        memset(ft->S, 0, N);
        const int has_toe = ft->n_cols > ft->n_own;
        const size_t toe = has_toe ? ft->cols[ft->n_own] : 0;
        const size_t h = (size_t)ft->hip, kn = (size_t)ft->knee, a = (size_t)ft->anchor;
        double local[3] = {0, 0, 0};
        mlr_ik_bend_axis_local(N, J, pos, wrot, ft->hip, ft->knee, ft->anchor, local, NULL);
        const int have_local = local[0] != 0.0 || local[1] != 0.0 || local[2] != 0.0;
        size_t m = 0;
        for (size_t f = 0; f < N; f++) {
            if ((!ft->U[f] && !ft->F[f]) || ft->K[f])
                continue;
            const double *Pf = pos + 3 * f * J, *G = wrot + 4 * f * J;
            double target[3];
            const double len =
                cleanup__dist3(Pf + 3 * h, Pf + 3 * kn) + cleanup__dist3(Pf + 3 * kn, Pf + 3 * a);
            if (ft->U[f]) {
                memcpy(target, ft->at + 3 * f, sizeof target);
                pin_dead_zone(Pf + 3 * h, Pf + 3 * kn, Pf + 3 * a, cu->cfg->straight_slack * len,
                              target);
            } else {
                memcpy(target, Pf + 3 * a, sizeof target);
                target[up] += common__fmax(ft->lift[f], 0.0);
            }
            soft_reach(Pf + 3 * h, len, cleanup__dist3(Pf + 3 * h, Pf + 3 * a),
                       cu->cfg->soft_reach, target);
            const double eps = REACHED * len;
            if (cleanup__dist3(Pf + 3 * a, target) <= eps &&
                (!ft->U[f] || !has_toe ||
                 aligned(P + 3 * (f * C + toe), ft->tt + 3 * f, Pf + 3 * a))) {
                ft->S[f] = 1; /* newr holds the leg's rotations as they are */
                continue;
            }
            double ax[3] = {0, 0, 0};
            if (have_local)
                ik__qrot(G + 4 * h, local, ax);
            for (int d = 0; d < 3; d++) {
                L.a[d][m] = Pf[3 * h + (size_t)d], L.b[d][m] = Pf[3 * kn + (size_t)d];
                L.c[d][m] = Pf[3 * a + (size_t)d], L.t[d][m] = target[d], L.axis[d][m] = ax[d];
            }
            fr[m++] = f;
            if (m == MLR_IK_LANES) {
                ik__two_bone_lanes(&L, m, have_local, MLR_IK_MAX_EXTENSION);
                finish_legs(cu, ft, &L, fr, m, have_local);
                m = 0;
            }
        }
        if (m) {
            ik__two_bone_lanes(&L, m, have_local, MLR_IK_MAX_EXTENSION);
            finish_legs(cu, ft, &L, fr, m, have_local);
        }
    }
}

/* One foot's placed point (toe) on frame f by turning its ankle, into newr, with its chain's
   forward kinematics of newr in pos2, wrot2 (one frame, J joints). */
static void place_toe_frame(const cleanup_state *cu, const cleanup_foot *ft, size_t f,
                            const double *pos2, const double *wrot2)
{
    const size_t J = cu->J;
    const mlr_rig *rig = cu->rig;
    const int32_t *joints = cu->joints, *end_sites = cu->end_sites;
    const size_t a = (size_t)ft->anchor;
    const int32_t pa = rig->parents[a];
    const size_t c = ft->cols[ft->n_own];
    const int32_t e = end_sites ? end_sites[c] : -1;
    const size_t j = (size_t)joints[c];
    const double *ga = wrot2 + 4 * a;
    const double *gp = pa >= 0 ? wrot2 + 4 * (size_t)pa : NULL;
    double r[4];
    if (ft->U[f]) {
        double now[3], u[3], v[3];
        if (e >= 0)
            ik__qrot(wrot2 + 4 * j, rig->end_site_offsets + 3 * (size_t)e, now);
        else
            now[0] = now[1] = now[2] = 0.0;
        for (int d = 0; d < 3; d++) {
            now[d] += pos2[3 * j + (size_t)d];
            u[d] = now[d] - pos2[3 * a + (size_t)d];
            v[d] = ft->tt[3 * f + (size_t)d] - pos2[3 * a + (size_t)d];
        }
        ik__from_to_1(u, v, r);
    } else { /* r * ga = the old world rotation */
        const double *gold = cu->wrot + 4 * (f * J + a);
        const double cg[4] = {ga[0], -ga[1], -ga[2], -ga[3]};
        ik__qmul4(gold, cg, r);
    }
    ik__rotate_to_1(cu->newr + 4 * (f * J + a), gp, ga, r);
}

/* Is foot k's toe placed on frame f (constrained, not kept, not reached)? */
static int toe_frame(const cleanup_foot *ft, size_t f)
{
    return (ft->U[f] || ft->F[f]) && !ft->K[f] && !ft->S[f];
}

/* The chained case: foot by foot (no foot's leg joints lie on another's chain), the chain's
   forward kinematics of newr by blocks of MLR_FK_BLOCK frames from the hip's parent where a
   run of the foot's frames allows (fk__list_block_from: the same bits as
   cleanup__fk_chain_frame, which the frames short of a block take), then each frame's toe. */
static void place_toes_chained(const cleanup_state *cu)
{
    const size_t N = cu->N, J = cu->J, P = cu->rig->n_trans;
    enum { B = MLR_FK_BLOCK };
    for (size_t k = 0; k < cu->nf; k++) {
        const cleanup_foot *ft = &cu->feet[k];
        if (!ft->active || ft->n_cols == ft->n_own)
            continue;
        const int32_t *chain = cu->chains + k * J;
        const size_t n = cu->chain_len[k];
        const int32_t seed = cu->rig->parents[chain[0]];
        const mlr_fk_list fl = cleanup__fk_list_of(cu->rig, chain, n, cu->tidx);
        size_t run = 0;
        for (size_t f = 0; f <= N; f++) {
            if (f < N && toe_frame(ft, f)) {
                if (++run < B || seed < 0)
                    continue;
                const size_t f0 = f + 1 - B, sj = (size_t)seed;
                for (size_t l = 0; l < B; l++) {
                    memcpy(cu->blk_pos + 3 * (J * l + sj), cu->pos + 3 * (J * (f0 + l) + sj),
                           3 * sizeof(double));
                    memcpy(cu->blk_rot + 4 * (J * l + sj), cu->wrot + 4 * (J * (f0 + l) + sj),
                           4 * sizeof(double));
                }
                fk__list_block_from(&fl, sj, cu->newr + 4 * J * f0,
                                    P ? cu->trans + 3 * P * f0 : NULL, cu->blk_pos, cu->blk_rot,
                                    cu->fk_s);
                for (size_t l = 0; l < B; l++)
                    place_toe_frame(cu, ft, f0 + l, cu->blk_pos + 3 * J * l,
                                    cu->blk_rot + 4 * J * l);
                run = 0;
                continue;
            }
            for (size_t g = f - run; g < f; g++) {
                cleanup__fk_chain_frame(cu->rig, g, chain, n, cu->tidx, cu->newr, cu->trans,
                                        cu->pos + 3 * J * g, cu->wrot + 4 * J * g, cu->pos2,
                                        cu->wrot2);
                place_toe_frame(cu, ft, g, cu->pos2, cu->wrot2);
            }
            run = 0;
        }
    }
}

/* Placed points (toes) by turning the ankle, into newr; on floor frames the ankle keeps its
   world rotation, so the whole foot rises with it (only on the frames where some foot with a
   placed point is constrained). */
static void place_toes(const cleanup_state *cu)
{
    if (cu->chained) {
        place_toes_chained(cu);
        return;
    }
    const size_t N = cu->N, nf = cu->nf;
    const cleanup_foot *feet = cu->feet;
    uint8_t *fk_frames = cu->fk_frames;
    memset(fk_frames, 0, N);
    for (size_t k = 0; k < nf; k++)
        if (feet[k].active && feet[k].n_cols > feet[k].n_own)
            for (size_t f = 0; f < N; f++)
                fk_frames[f] |= (uint8_t)toe_frame(&feet[k], f);
    for (size_t f = 0; f < N; f++) {
        if (!fk_frames[f])
            continue;
        cleanup__fk_masked_frame(cu->rig, f, cu->need_list, cu->n_need, cu->tidx, cu->out_root_pos,
                                 cu->newr, cu->trans, cu->pos2, cu->wrot2);
        for (size_t k = 0; k < nf; k++)
            if (feet[k].active && feet[k].n_cols > feet[k].n_own && toe_frame(&feet[k], f))
                place_toe_frame(cu, &feet[k], f, cu->pos2, cu->wrot2);
    }
}

/* The hook on the legs' rotations a pass set: each leg's hip and knee, and its anchor where
   it has a placed point. Before the spread (stage HOOK_IK) on the constrained frames
   solve_legs and place_toes solved, in newr; after it (HOOK_BLEND) on the frames of its blend
   only (the others of the frames the spread changed), in out_rot; in the passes that do not
   limit the IK (HOOK_RAMPS), on the ramps' frames alone, in newr, eased in from the run's edge:
   a ramp's target need not be met exactly, its legs within their ranges do (without, the
   second pass's IK took the dog's front legs 100 degrees past their swing range at alpha 3). */
enum { HOOK_IK = 0, HOOK_BLEND = 1, HOOK_RAMPS = 2 };

/* The angle between unit quaternions a and b (radians, in [0, pi]). */
static double quat_angle(const double *a, const double *b)
{
    const double d = fabs(a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]);
    return 2.0 * acos(d > 1.0 ? 1.0 : d);
}

/* The hook's correction of one solved rotation, q (hooked: its hooked value, into q), cut to
   what the pass added to the correction the rotation it started from, p (p_hooked), would have
   taken: with e(r) the angle from r to its hooked value, q is turned toward its hooked value
   by e(q) - e(p), a part of the way, or left as the pass solved it when e(q) <= e(p). Where
   the pass started inside the limits (e(p) = 0, the usual case) that is the whole correction,
   as it was. Where the eased limits (limits__ease) left the rotation outside them, it is
   what keeps the solved frames continuous with the frames around them, which the pass did
   not solve and the hook does not see: the whole correction there (from the far side of the
   range, the nearest bound is the other one) turned a thigh of CMU 60_10 by 166 degrees on
   the frames the contact IK solved at alpha 3 where the IK had moved it by 2. */
static void hook_excess(const double *p, const double *p_hooked, const double *q, double *hooked)
{
    const double ep = quat_angle(p, p_hooked);
    if (!(ep > 0.0))
        return; /* the whole correction, as the hook gave it */
    const double eq = quat_angle(q, hooked);
    if (!(eq > ep)) {
        memcpy(hooked, q, 4 * sizeof(double));
        return;
    }
    /* slerp from q toward hooked by the part t of the way */
    const double t = (eq - ep) / eq;
    const double d = q[0] * hooked[0] + q[1] * hooked[1] + q[2] * hooked[2] + q[3] * hooked[3];
    const double sg = d < 0.0 ? -1.0 : 1.0, th = 0.5 * eq, sth = sin(th);
    const double wa = sin((1.0 - t) * th) / sth, wb = sg * sin(t * th) / sth;
    double r[4], n = 0.0;
    for (int c = 0; c < 4; c++) {
        r[c] = wa * q[c] + wb * hooked[c];
        n += r[c] * r[c];
    }
    n = sqrt(n);
    for (int c = 0; c < 4; c++)
        hooked[c] = r[c] / n;
}
static void run_hook(const cleanup_state *cu, int stage)
{
    const int blend = stage == HOOK_BLEND;
    const size_t N = cu->N, J = cu->J;
    const uint8_t *dirty = cu->w->dirty;
    uint8_t *mask = cu->hook_mask;
    int32_t joints[3 * 64]; /* (cleanup_feet: at most 64 feet) */
    size_t n_joints = 0;
    memset(mask, 0, N * J);
    for (size_t k = 0; k < cu->nf; k++) {
        const cleanup_foot *ft = &cu->feet[k];
        if (!ft->active)
            continue;
        const int has_toe = ft->n_cols > ft->n_own;
        const uint8_t bit = k < 7 ? (uint8_t)(1u << k) : (uint8_t)CLEANUP_DIRTY_ALL;
        const int32_t leg[3] = {ft->hip, ft->knee, ft->anchor};
        for (int i = 0; i < 2 + has_toe; i++) {
            size_t q = 0;
            while (q < n_joints && joints[q] != leg[i])
                q++;
            if (q == n_joints)
                joints[n_joints++] = leg[i];
        }
        for (size_t f = 0; f < N; f++) {
            const int constrained = ft->U[f] || ft->F[f];
            if (blend ? constrained || !(dirty[f] & bit)
                      : !(stage == HOOK_RAMPS ? ft->R[f] : constrained) || ft->K[f] || ft->S[f])
                continue;
            uint8_t *m = mask + f * J;
            m[ft->hip] = m[ft->knee] = 1;
            if (has_toe)
                m[ft->anchor] = 1;
        }
    }
    /* the rotations the pass gives (newr, or after the spread out_rot) and the ones it
       started from (out_rot, or before the spread hook_pre), each through the hook; then only
       the excess (hook_excess) */
    double *rot = blend ? cu->out_rot : cu->newr;
    for (size_t i = 0; i < N * J; i++)
        if (mask[i]) {
            memcpy(cu->hook_prev + 4 * i, rot + 4 * i, 4 * sizeof(double));
            memcpy(cu->hook_pre + 4 * i, blend ? cu->hook_snap + 4 * i : cu->out_rot + 4 * i,
                   4 * sizeof(double));
        }
    cu->hook->fn(cu->hook->ctx, N, J, cu->hook_pre, mask, joints, n_joints, 0);
    cu->hook->fn(cu->hook->ctx, N, J, rot, mask, joints, n_joints, 1);
    for (size_t i = 0; i < N * J; i++)
        if (mask[i] && cu->hook->excess && cu->hook->excess[i % J])
            hook_excess(blend ? cu->hook_snap + 4 * i : cu->out_rot + 4 * i, cu->hook_pre + 4 * i,
                        cu->hook_prev + 4 * i, rot + 4 * i);
    if (stage != HOOK_RAMPS)
        return;
    /* the limits' correction of a ramp frame's hip and knee faded in from the run's edge by
       1 - the weight of the run's offset there: the run's own frames are not limited in these
       passes, and a ramp limited in full from its first frame met them in a corner where the
       limited leg could not reach (PyMO's walk at alpha 3: the toe 7.7x the base acceleration,
       2.8x so; over 108 clips the judge's pop target at alpha 2 and 3 went from 105 and 99 to
       106 and 101). The ankle's limits stay in full: faded too, the dog's paw went 1.9
       degrees past its swing range at alpha 3. */
    for (size_t k = 0; k < cu->nf; k++) {
        const cleanup_foot *ft = &cu->feet[k];
        if (!ft->active)
            continue;
        const int32_t leg[2] = {ft->hip, ft->knee};
        for (size_t f = 0; f < N; f++) {
            const double w = ft->rw[f];
            if (!ft->R[f] || !(w > 0.0))
                continue;
            for (int i = 0; i < 2; i++) {
                const size_t at = f * J + (size_t)leg[i];
                if (!mask[at])
                    continue;
                double *q = cu->newr + 4 * at;
                const double *p = cu->hook_prev + 4 * at;
                const double d = q[0] * p[0] + q[1] * p[1] + q[2] * p[2] + q[3] * p[3];
                const double s = d < 0.0 ? -w : w;
                double n = 0.0;
                for (int c = 0; c < 4; c++) {
                    q[c] = (1.0 - w) * q[c] + s * p[c];
                    n += q[c] * q[c];
                }
                n = sqrt(n);
                for (int c = 0; c < 4; c++)
                    q[c] /= n;
            }
        }
    }
}

/* The forward kinematics of the frames where only legs' rotations changed (dirty with foot
   k's bit and not CLEANUP_DIRTY_ALL): each such leg's joints at and below its hip, from its
   hip's parent as pos and wrot hold it, by blocks of MLR_FK_BLOCK frames where a run of them
   allows (fk__list_block_from), else frame by frame: the same values either way. */
static void fk_legs(const cleanup_state *cu)
{
    const size_t N = cu->N, J = cu->J, P = cu->rig->n_trans;
    const uint8_t *dirty = cu->w->dirty;
    for (size_t k = 0; k < cu->nf && k < 7; k++) {
        if (!cu->feet[k].active || cu->n_sub[k] == 0)
            continue;
        const uint8_t bit = (uint8_t)(1u << k);
        const int32_t seed = cu->rig->parents[cu->sub[k * J]];
        const mlr_fk_list fl =
            cleanup__fk_list_of(cu->rig, cu->sub + k * J, cu->n_sub[k], cu->tidx);
        size_t run = 0; /* frames of foot k's leg alone before f */
        for (size_t f = 0; f <= N; f++) {
            if (f < N && (dirty[f] & bit) && !(dirty[f] & CLEANUP_DIRTY_ALL)) {
                if (++run < MLR_FK_BLOCK || seed < 0)
                    continue;
                const size_t f0 = f + 1 - MLR_FK_BLOCK;
                fk__list_block_from(&fl, (size_t)seed, cu->out_rot + 4 * J * f0,
                                    P ? cu->trans + 3 * P * f0 : NULL, cu->pos + 3 * J * f0,
                                    cu->wrot + 4 * J * f0, cu->fk_s);
                run = 0;
                continue;
            }
            for (size_t g = f - run; g < f; g++) /* the run's frames short of a block */
                cleanup__fk_list_frame(cu->rig, g, cu->sub + k * J, cu->n_sub[k], cu->tidx,
                                       cu->out_rot, cu->trans, cu->pos + 3 * J * g,
                                       cu->wrot + 4 * J * g);
            run = 0;
        }
    }
}

mlr_status cleanup__pass(cleanup_state *cu)
{
    const size_t N = cu->N, J = cu->J, C = cu->C;
    uint8_t *dirty = cu->w->dirty, *mask = cu->mask;
    mlr_status st;
    fk_legs(cu);
    /* the frames whose root moved: all the needed joints, MLR_FK_BLOCK frames at a time where
       a run of them allows (the same values as frame by frame) */
    const mlr_fk_list fl = cleanup__fk_list_of(cu->rig, cu->need_list, cu->n_need, cu->tidx);
    const size_t P = cu->rig->n_trans;
    for (size_t f = 0; f < N;) {
        if (!dirty[f]) {
            f++;
            continue;
        }
        size_t e = f, run = 0; /* the run of dirty frames [f, e); of those moved, not done */
        for (; e <= N; e++) {
            if (e < N && (dirty[e] & CLEANUP_DIRTY_ALL)) {
                if (++run < MLR_FK_BLOCK)
                    continue;
                const size_t g0 = e + 1 - MLR_FK_BLOCK;
                fk__list_block(&fl, cu->out_root_pos + 3 * g0, cu->out_rot + 4 * J * g0,
                               P ? cu->trans + 3 * P * g0 : NULL, cu->pos + 3 * J * g0,
                               cu->wrot + 4 * J * g0, cu->fk_s);
                run = 0;
                continue;
            }
            for (size_t g = e - run; g < e; g++)
                cleanup__fk_masked_frame(cu->rig, g, cu->need_list, cu->n_need, cu->tidx,
                                         cu->out_root_pos, cu->out_rot, cu->trans,
                                         cu->pos + 3 * J * g, cu->wrot + 4 * J * g);
            run = 0;
            if (e == N || !dirty[e])
                break;
        }
        if ((st = mlr_rig_point_positions(cu->rig, e - f, cu->pos + 3 * J * f,
                                          cu->wrot + 4 * J * f, C, cu->joints, cu->end_sites,
                                          cu->P + 3 * C * f, NULL)) != MLR_OK)
            return st;
        f = e;
    }
    memset(dirty, 0, N);
    find_floor_frames(cu);
    copy_leg_rotations(cu);
    solve_legs(cu);
    place_toes(cu);
    if (cu->hook_on & 1)
        run_hook(cu, HOOK_IK);
    else if (cu->hook_on & 4)
        run_hook(cu, HOOK_RAMPS);
    if (cu->hook_on & 2) /* the rotations before the spread, for the blends' hook (which
                            reads the active legs' hip, knee and anchor only) */
        for (size_t k = 0; k < cu->nf; k++) {
            const cleanup_foot *ft = &cu->feet[k];
            const int32_t leg[3] = {ft->hip, ft->knee, ft->anchor};
            const int n_leg = 2 + (ft->n_cols > ft->n_own); /* run_hook's */
            for (size_t f = 0; ft->active && f < N; f++)
                for (int i = 0; i < n_leg; i++) {
                    const size_t at = 4 * (f * J + (size_t)leg[i]);
                    memcpy(cu->hook_snap + at, cu->out_rot + at, 4 * sizeof(double));
                }
        }
    /* spread per leg */
    for (size_t k = 0; k < cu->nf; k++) {
        const cleanup_foot *ft = &cu->feet[k];
        if (!ft->active)
            continue;
        size_t cnt = 0;
        for (size_t f = 0; f < N; f++) {
            mask[f] = !(ft->U[f] | ft->F[f]) ? 0 : ft->K[f] || ft->S[f] ? CLEANUP_HELD_SAME : 1;
            cnt += mask[f] != 0;
        }
        if (!cnt)
            continue;
        int32_t js[3] = {ft->hip, ft->knee, ft->anchor};
        cu->w->dirty_bit = k < 7 ? (uint8_t)(1u << k) : (uint8_t)CLEANUP_DIRTY_ALL;
        if ((st = cleanup__spread_rotations(cu->w, cu->out_rot, cu->newr, js,
                                            ft->n_cols > ft->n_own ? 3 : 2, mask)) != MLR_OK)
            return st;
    }
    if (cu->hook_on & 2)
        run_hook(cu, HOOK_BLEND);
    return MLR_OK;
}
