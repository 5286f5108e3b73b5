/* cffi declarations of the mlayer C API (API mode: compiled against the real headers, so any
 * drift from include/mlayer/ breaks the build). No macros here; one block per header. */

/* mlr_common.h */
typedef int mlr_status;
enum {
    MLR_OK = 0,
    MLR_E_INVALID_ARG = -10,
    MLR_E_NO_MEMORY = -20,
    MLR_E_OVERFLOW = -21,
    MLR_E_SINGULAR = -30,
    MLR_E_BAD_STATE = -40,
    MLR_E_UNSUPPORTED = -41,
    MLR_E_PARSE = -50,
    MLR_E_IO = -51,
    MLR_W_ILL_CONDITIONED = 10,
    MLR_W_MAX_ITER = 20
};
const char *mlr_status_name(mlr_status s);
const char *mlr_status_string(mlr_status s);
const char *mlr_version_string(void);
int mlr_version_number(void);
typedef struct mlr_allocator {
    void *(*allocate)(void *user, size_t size, size_t align);
    void (*release)(void *user, void *ptr, size_t size);
    void *user;
} mlr_allocator;
typedef struct mlr_diag {
    size_t line, column;
    char message[160];
} mlr_diag;

/* mlr_band.h */
typedef struct mlr_band mlr_band;
mlr_status mlr_band_create(size_t n, size_t kd, const mlr_allocator *alloc, mlr_band **out);
mlr_status mlr_band_factor(mlr_band *band, const double *ab, size_t ldab);
mlr_status mlr_band_solve(const mlr_band *band, double *x, size_t ldx, size_t m);
mlr_status mlr_band_inverse_diagonal(const mlr_band *band, double *var, size_t n);
void mlr_band_destroy(mlr_band *band);

/* mlr_lgs.h */
typedef struct mlr_lgs mlr_lgs;
typedef enum mlr_lgs_solver { MLR_LGS_BANDED = 0, MLR_LGS_CHOLMOD = 1 } mlr_lgs_solver;
int mlr_lgs_have_cholmod(void);
mlr_status mlr_lgs_create(size_t n_out, unsigned order, double lam, double sigma,
                          const double *t, size_t n_obs, mlr_lgs_solver solver,
                          const mlr_allocator *alloc, mlr_lgs **out, mlr_diag *diag);
mlr_status mlr_lgs_solve(const mlr_lgs *lgs, const double *y, size_t ldy, size_t m,
                         double *x, size_t ldx);
mlr_status mlr_lgs_variance(const mlr_lgs *lgs, double *var, size_t n_out);
size_t mlr_lgs_n_out(const mlr_lgs *lgs);
size_t mlr_lgs_n_obs(const mlr_lgs *lgs);
void mlr_lgs_destroy(mlr_lgs *lgs);

/* mlr_quat.h */
typedef struct mlr_quat { double w, x, y, z; } mlr_quat;
typedef struct mlr_vec3 { double x, y, z; } mlr_vec3;
typedef enum mlr_euler_order {
    MLR_EULER_XYZ = 0, MLR_EULER_XZY = 1, MLR_EULER_YXZ = 2,
    MLR_EULER_YZX = 3, MLR_EULER_ZXY = 4, MLR_EULER_ZYX = 5
} mlr_euler_order;
void mlr_quat_mul(const mlr_quat *a, const mlr_quat *b, mlr_quat *out);
void mlr_quat_rotate(const mlr_quat *q, const mlr_vec3 *v, mlr_vec3 *out);
void mlr_quat_mul_array(const mlr_quat *a, const mlr_quat *b, size_t count, mlr_quat *out);
void mlr_quat_conj_array(const mlr_quat *q, size_t count, mlr_quat *out);
mlr_status mlr_quat_normalize_array(const mlr_quat *q, size_t count, mlr_quat *out);
mlr_status mlr_quat_exp_array(const mlr_vec3 *v, size_t count, mlr_quat *out);
mlr_status mlr_quat_log_array(const mlr_quat *q, size_t count, mlr_vec3 *out);
mlr_status mlr_quat_slerp_array(const mlr_quat *a, const mlr_quat *b, const double *t,
                                size_t count, mlr_quat *out);
mlr_status mlr_quat_from_euler_array(const double *angles, size_t count,
                                     mlr_euler_order order, mlr_quat *out);
mlr_status mlr_quat_to_euler_array(const mlr_quat *q, size_t count,
                                   mlr_euler_order order, double *angles);
void mlr_quat_make_continuous(mlr_quat *q, size_t n_frames, size_t n_tracks);
mlr_status mlr_euler_order_parse(const char *name, mlr_euler_order *out);

/* mlr_quat.h: predictive sign continuity (MLAYER_0.3) */
void mlr_quat_continue_sign(const mlr_quat *prev, size_t n_prev, const mlr_quat *q,
                            mlr_quat *out);
void mlr_quat_make_continuous_predictive(mlr_quat *q, size_t n_frames, size_t n_tracks);

/* mlr_resample.h (MLAYER_0.3); MLR_RESAMPLE_AUTO is -1.0, KAPPA_DOWN 0.5, KAPPA_UP 0.01,
 * MAX_FACTOR 100 (floating-point macros are not visible through cffi) */
enum { MLR_RESAMPLE_ALLOW_EXTREME = 1, MLR_RESAMPLE_NEAREST_SIGN = 2 };
mlr_status mlr_resample_n_out(size_t n_frames, double fps_in, double fps_out, unsigned flags,
                              size_t *n_out, mlr_diag *diag);
mlr_status mlr_timemap_validate(const double *t, size_t n_frames, size_t n_out, unsigned flags,
                                mlr_diag *diag);
double mlr_resample_auto_smoothness(size_t n_frames, size_t n_out);
mlr_status mlr_resample_arrays(size_t n_frames, size_t n_joints, size_t n_trans,
                               const double *root_pos, const double *rot, const double *trans,
                               const double *t, size_t n_out, double lam, double sigma,
                               unsigned flags, double *root_out, double *rot_out,
                               double *trans_out, double *var_out, const mlr_allocator *alloc,
                               mlr_diag *diag);
mlr_status mlr_slerp_resample_arrays(size_t n_frames, size_t n_joints, size_t n_trans,
                                     const double *root_pos, const double *rot,
                                     const double *trans, const double *t, size_t n_out,
                                     unsigned flags, double *root_out, double *rot_out,
                                     double *trans_out, mlr_diag *diag);
mlr_status mlr_timewarp_speed(size_t n_frames, size_t n_joints, const double *root_pos,
                              const double *rot, const double *joint_weights,
                              double root_weight, double *speed, mlr_diag *diag);
mlr_status mlr_timewarp_map(size_t n_frames, size_t n_joints, const double *root_pos,
                            const double *rot, const double *joint_weights, double root_weight,
                            double strength, double smooth_frames, size_t n_out, unsigned flags,
                            double *t, const mlr_allocator *alloc, mlr_diag *diag);
