/* The guards' input as the passes that compare with it take it: the motion and its forward
 * kinematics, computed once per apply (guards.c) rather than once per pass. Not installed. */
#ifndef MLR_GUARDS_INPUT_INTERNAL_H
#define MLR_GUARDS_INPUT_INTERNAL_H

typedef struct guards_input {
    const double *root;  /* N x 3: the root's positions */
    const double *rot;   /* N x J x 4: the joints' local rotations (unit) */
    const double *trans; /* N x n_trans x 3: the translated joints' offsets, or NULL */
    const double *pos;   /* N x J x 3: the joints' world positions */
    const double *wrot;  /* N x J x 4: the joints' world rotations */
} guards_input;

#endif /* MLR_GUARDS_INPUT_INTERNAL_H */
