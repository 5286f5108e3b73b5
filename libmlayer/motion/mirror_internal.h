/* Private helpers of the mirror subject (mirror.c), shared with root_motion.c. Not installed. */
#ifndef MLR_MIRROR_INTERNAL_H
#define MLR_MIRROR_INTERNAL_H

#include "common/mlr_internal.h"

/* Where the candidate names of a joint name have got to: rule 1 (left/right words) first,
 * then the L/R letter tokens of rules 2, 3 and 4 at each position (mlr_mirror.h). */
typedef struct mlr_mirror_cursor {
    int rule;   /* 0 before rule 1; 2..4 the letter rules; 5 done */
    size_t pos; /* next position for the letter rules */
} mlr_mirror_cursor;

/* The next name that a rule turns name (len characters) into, written to buf (2 len + 2
 * bytes), and the side of name by that rule (+1 left, -1 right); 0 when there is none left.
 * Start with cur = {0, 0}. */
int mirror__next_candidate(const char *name, size_t len, mlr_mirror_cursor *cur, char *buf,
                           int *side);

/* mlr_mirror_pairs without its checks of the permutation (rig already checked): the pairs
 * by the given names and the rules, for uses that need no mirror (the body's left side). */
mlr_status mirror__find_pairs(const mlr_rig *rig, const char *const *given, size_t n_given,
                              unsigned flags, int32_t *partner, int8_t *side, size_t *n_pairs,
                              const mlr_allocator *alloc, mlr_diag *diag);

/* Row of joint j in rig->trans_joints (strictly increasing), or -1. */
static inline long mirror__rig_trans_row(const mlr_rig *rig, int32_t j)
{
    size_t lo = 0, hi = rig->n_trans;
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        if (rig->trans_joints[mid] < j)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < rig->n_trans && rig->trans_joints[lo] == j ? (long)lo : -1;
}

/* The checks of mlr_mirror_pairs on a partner table (involution, root unpaired, hierarchy,
 * position channels, End Sites); rig already checked. */
mlr_status mirror__check_partner(const mlr_rig *rig, const int32_t *partner, mlr_diag *diag);

/* Rest position of joint j: the OFFSETs summed from below the root up to j (all rotations
 * identity, the root at the origin). */
void mirror__rest_position(const mlr_rig *rig, size_t j, double *out);

#endif
