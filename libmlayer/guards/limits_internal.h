/* Joint limits: private parts shared by limits.c, limits_human.c and stream.c. */
#ifndef MLR_LIMITS_INTERNAL_H
#define MLR_LIMITS_INTERNAL_H

#include <math.h>

#include "mlayer/mlr_limits.h"
#include "mlayer/mlr_quat.h"

/* Anatomical class of a joint, from the rig's structure and names (limits_human.c). */
typedef enum mlr_limits_class {
    MLR_LIMITS_CLASS_OTHER = 0, /* no table entry: ranges from the input */
    MLR_LIMITS_CLASS_FREE,      /* root segment, pelvis */
    MLR_LIMITS_CLASS_LEG_HINGE, /* knee */
    MLR_LIMITS_CLASS_ARM_HINGE, /* elbow */
    MLR_LIMITS_CLASS_HIP,
    MLR_LIMITS_CLASS_ANKLE,
    MLR_LIMITS_CLASS_TOE,
    MLR_LIMITS_CLASS_SHOULDER,
    MLR_LIMITS_CLASS_CLAVICLE,
    MLR_LIMITS_CLASS_WRIST,
    MLR_LIMITS_CLASS_SPINE,
    MLR_LIMITS_CLASS_NECK,
    MLR_LIMITS_CLASS_COUNT
} mlr_limits_class;

typedef struct mlr_limits_joint {
    mlr_limits_range range;
    mlr_quat centre;
    mlr_vec3 axis;     /* hinge axis (parent frame), unit or zero */
    mlr_vec3 bone_in;  /* a: the joint's translation */
    mlr_vec3 bone_out; /* b: main child's translation (joint frame), or zero */
    double stats[4];   /* min phi, max phi, max swing, max |twist| */
    int cls;           /* an mlr_limits_class */
} mlr_limits_joint;

struct mlr_limits {
    mlr_allocator alloc;
    size_t n_joints;
    int human;
    double soft, rev_soft;
    mlr_limits_joint *joints;
};

/* Is the name (NULL allowed) a hinge name, and which kind: 0 none, 1 leg, 2 arm. */
int limits__hinge_name(const char *name);
/* Is it a free (pelvis/root) name. */
int limits__free_name(const char *name);
/* Classify every joint (cls[J]) from the structure and names, given the hinge flags
 * (is_hinge[J]: 1 leg, 2 arm, 0 not); joint 0 is FREE. */
void limits__classify(const mlr_rig *rig, const int *is_hinge, const int32_t *main_child,
                      int *cls);
/* Table swing and twist half-ranges (radians) of a class, shared among n joints of the class
 * for the spine and the neck; returns 0 when the class has no table entry. */
int limits__table(int cls, size_t n_of_class, double *swing, double *twist);

/* The soft saturation: identity up to k = b - w, then k + w tanh((x - k) / w) (< b). */
static inline double limits__soft(double x, double b, double w)
{
    const double k = b - w;
    if (x <= k)
        return x;
    /* tanh(u) = 1 - 2 / (exp(2 u) + 1): within 2.3e-16 of libm's tanh in absolute terms and
       monotone (all that k + w tanh needs: the angle's own rounding is as large), at half its
       cost (6.7 against 13.8 ns a call measured here) */
    return k + w * (1.0 - 2.0 / (exp(2.0 * ((x - k) / w)) + 1.0));
}

/* mlr_limits_apply on the joints of one kind (an mlr_limits_kind) only, in place, on unit
 * quaternions, with arguments the caller has checked; counts (J, or NULL) are added to. */
void limits__apply_kind(const mlr_limits *lim, size_t n_frames, mlr_quat *rot, const double *alpha,
                        size_t n_alpha, size_t *counts, int kind);
/* limits__apply_kind on the quaternions marked in mask (n_frames x J, nonzero: limit it;
 * NULL: all) only: a joint's angles are unwrapped in time along the runs of marked frames.
 * hard (hinges only): an angle within [lo, hi] is left as it is and one outside is set to the
 * bound it passed, instead of the soft saturation (which also moves angles near a bound).
 * joints: the only joints mask marks (n_joints of them; NULL: any joint), so the others are
 * not looked at. */
void limits__apply_kind_masked(const mlr_limits *lim, size_t n_frames, mlr_quat *rot,
                               const double *alpha, size_t n_alpha, size_t *counts, int kind,
                               const uint8_t *mask, const int32_t *joints, size_t n_joints,
                               int hard);
/* Limit the J unit quaternions of one frame in place; joint j's alpha is alpha[stride * j]
 * (alpha NULL: 1). counts[j] (optional) is incremented where the joint changed. */
void limits__apply_frame(const mlr_limits *lim, mlr_quat *q, const double *alpha, size_t stride,
                         size_t *counts);

/* mlr_limits_create with no options on clips whose rotations are unit quaternions the caller
 * made (the guards' normalized input): the same limits, without checking them again. */
mlr_status limits__create_unit(const mlr_rig *rig, const mlr_limits_clip *clips, size_t n_clips,
                               const mlr_allocator *alloc, mlr_limits **out, mlr_diag *diag);
/* mlr_limits_apply with arguments the caller has checked (alpha, counts: J zeroed, or NULL) and
 * rot_in not overlapping rot_out: rot_in normalized into rot_out (which holds no meaning after a
 * failure) and limited, in one pass over rot_in. MLR_E_INVALID_ARG, with no message, when a
 * quaternion is zero or not finite (limits__rot_error says which). */
mlr_status limits__apply_normalized(const mlr_limits *lim, size_t n_frames, const double *rot_in,
                                    double *rot_out, const double *alpha, size_t n_alpha,
                                    size_t *counts);
/* The error of mlr_limits_apply for rotations that hold a zero or non-finite quaternion (the
 * first one named); MLR_OK when there is none. */
mlr_status limits__rot_error(const mlr_limits *lim, size_t n_frames, const double *rot,
                             mlr_diag *diag);

/* The look-ahead easing of limits_ease.c, shared with floor_chains.c: k[0..r] the halves of a
 * Gaussian of sigma frames cut at 2.5 sigma, summing to 1 over -r..r (k: at least
 * 2.5 sigma + 2 values); returns r. y = x through a running maximum of radius r and then that
 * Gaussian, the edge values repeated (tmp: n scratch; y may not alias x or tmp): at least x
 * wherever x is, and smooth. */
size_t limits__ease_kernel(double sigma, double *k);
void limits__ease_lookahead(const double *x, size_t n, const double *k, size_t r, double *tmp,
                            double *y);
/* The limits' corrections eased in time (limits_ease.c): lim (n_frames x J unit quaternions,
 * the limits of raw, which may be unnormalized) is rewritten as exp(e) * raw, e the correction
 * lim * conj(raw) as a rotation vector, each component's positive and negative part through a
 * running maximum and a Gaussian of 40 ms (where a joint's parts of both signs overlap, a
 * frame can be left short of its own correction: a hinge then a little outside its range; the
 * guards ease that excess again and clamp what is left); joints with counts[j] == 0 (counts may be NULL) are
 * left as they are, and so are frames with no correction within 100 ms. MLR_E_NO_MEMORY or
 * MLR_E_OVERFLOW leave lim as it was. */
mlr_status limits__ease(const double *raw, double *lim, size_t n_frames, size_t J, double fps,
                        const size_t *counts, const mlr_allocator *alloc);

#endif /* MLR_LIMITS_INTERNAL_H */
