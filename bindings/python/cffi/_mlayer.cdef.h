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

/* mlr_stream.h */
typedef struct mlr_stream mlr_stream;
mlr_status mlr_stream_create(size_t n_joints, int root, size_t n_trans, double lam,
                             double sigma, size_t lag, const mlr_allocator *alloc,
                             mlr_stream **out, mlr_diag *diag);
mlr_status mlr_stream_create_layered(size_t n_joints, int root, size_t n_trans,
                                     double lam, double sigma, double lam_base,
                                     double sigma_base, size_t lag,
                                     const mlr_allocator *alloc, mlr_stream **out,
                                     mlr_diag *diag);
mlr_status mlr_stream_push(mlr_stream *st, const double *frame, size_t n_values,
                           double *out, size_t out_len, size_t *n_ready);
mlr_status mlr_stream_flush(mlr_stream *st, double *out, size_t out_len, size_t *n_written);
void mlr_stream_reset(mlr_stream *st);
mlr_status mlr_stream_set_alpha(mlr_stream *st, double alpha_trans, const double *alpha,
                                size_t n_joints);
size_t mlr_stream_frame_size(const mlr_stream *st);
size_t mlr_stream_lag(const mlr_stream *st);
size_t mlr_stream_n_pushed(const mlr_stream *st);
size_t mlr_stream_pending(const mlr_stream *st);
double mlr_stream_decay_rate(double lam, double sigma);
void mlr_stream_destroy(mlr_stream *st);
