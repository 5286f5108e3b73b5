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
mlr_status mlr_band_create(size_t n, size_t kd, const mlr_allocator *alloc, mlr_band **out,
                           mlr_diag *diag);
mlr_status mlr_band_factor(mlr_band *band, const double *ab, size_t ldab, mlr_diag *diag);
mlr_status mlr_band_solve(const mlr_band *band, double *x, size_t ldx, size_t m, mlr_diag *diag);
mlr_status mlr_band_inverse_diagonal(const mlr_band *band, double *var, size_t n, mlr_diag *diag);
void mlr_band_destroy(mlr_band *band);

/* mlr_lgs.h */
typedef struct mlr_lgs mlr_lgs;
typedef enum mlr_lgs_solver { MLR_LGS_BANDED = 0, MLR_LGS_CHOLMOD = 1 } mlr_lgs_solver;
int mlr_lgs_have_cholmod(void);
mlr_status mlr_lgs_create(size_t n_out, unsigned order, double lam, double sigma,
                          const double *t, size_t n_obs, mlr_lgs_solver solver,
                          const mlr_allocator *alloc, mlr_lgs **out, mlr_diag *diag);
mlr_status mlr_lgs_solve(const mlr_lgs *lgs, const double *y, size_t ldy, size_t m,
                         double *x, size_t ldx, mlr_diag *diag);
mlr_status mlr_lgs_solve_mt(const mlr_lgs *lgs, const double *y, size_t ldy, size_t m,
                            double *x, size_t ldx, size_t n_threads, mlr_diag *diag);
mlr_status mlr_lgs_variance(const mlr_lgs *lgs, double *var, size_t n_out, mlr_diag *diag);
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
mlr_status mlr_quat_normalize_array(const mlr_quat *q, size_t count, mlr_quat *out,
                                    mlr_diag *diag);
mlr_status mlr_quat_exp_array(const mlr_vec3 *v, size_t count, mlr_quat *out, mlr_diag *diag);
mlr_status mlr_quat_log_array(const mlr_quat *q, size_t count, mlr_vec3 *out, mlr_diag *diag);
mlr_status mlr_quat_slerp_array(const mlr_quat *a, const mlr_quat *b, const double *t,
                                size_t count, mlr_quat *out, mlr_diag *diag);
mlr_status mlr_quat_from_euler_array(const double *angles, size_t count,
                                     mlr_euler_order order, mlr_quat *out, mlr_diag *diag);
mlr_status mlr_quat_to_euler_array(const mlr_quat *q, size_t count,
                                   mlr_euler_order order, double *angles, mlr_diag *diag);
void mlr_quat_make_continuous(mlr_quat *q, size_t n_frames, size_t n_tracks);
mlr_status mlr_euler_order_parse(const char *name, mlr_euler_order *out, mlr_diag *diag);

/* mlr_bvh.h */
typedef struct mlr_motion mlr_motion;
typedef enum mlr_bvh_channel {
    MLR_BVH_XPOSITION = 0, MLR_BVH_YPOSITION = 1, MLR_BVH_ZPOSITION = 2,
    MLR_BVH_XROTATION = 3, MLR_BVH_YROTATION = 4, MLR_BVH_ZROTATION = 5
} mlr_bvh_channel;
mlr_status mlr_bvh_read_memory(const char *text, size_t len, const mlr_allocator *alloc,
                               mlr_motion **out, mlr_diag *diag);
mlr_status mlr_bvh_read_file(const char *path, const mlr_allocator *alloc,
                             mlr_motion **out, mlr_diag *diag);
mlr_status mlr_bvh_read_memory_mt(const char *text, size_t len, size_t n_threads,
                                  const mlr_allocator *alloc, mlr_motion **out, mlr_diag *diag);
mlr_status mlr_bvh_read_file_mt(const char *path, size_t n_threads, const mlr_allocator *alloc,
                                mlr_motion **out, mlr_diag *diag);
typedef int (*mlr_bvh_write_fn)(void *user, const char *data, size_t len);
mlr_status mlr_bvh_write(const mlr_motion *motion, mlr_bvh_write_fn fn, void *user, mlr_diag *diag);
mlr_status mlr_bvh_write_memory(const mlr_motion *motion, char *buf, size_t cap, size_t *len,
                                mlr_diag *diag);
mlr_status mlr_bvh_write_file(const mlr_motion *motion, const char *path, mlr_diag *diag);
mlr_status mlr_motion_create(size_t n_joints, const char *const *names,
                             const int32_t *parents, const double *offsets,
                             const char *const *channels, size_t n_end_sites,
                             const int32_t *end_parents, const double *end_offsets,
                             size_t n_frames, double frame_time,
                             const mlr_allocator *alloc, mlr_motion **out, mlr_diag *diag);
mlr_status mlr_motion_copy_frames(const mlr_motion *src, size_t begin, size_t count,
                                  mlr_motion **out, mlr_diag *diag);
void mlr_motion_destroy(mlr_motion *motion);
size_t mlr_motion_n_joints(const mlr_motion *motion);
size_t mlr_motion_n_frames(const mlr_motion *motion);
size_t mlr_motion_n_channels(const mlr_motion *motion);
double mlr_motion_frame_time(const mlr_motion *motion);
mlr_status mlr_motion_set_frame_time(mlr_motion *motion, double frame_time);
const char *mlr_motion_joint_name(const mlr_motion *motion, size_t j);
const int32_t *mlr_motion_parents(const mlr_motion *motion);
const double *mlr_motion_offsets(const mlr_motion *motion);
size_t mlr_motion_joint_n_channels(const mlr_motion *motion, size_t j);
size_t mlr_motion_joint_channel_codes(const mlr_motion *motion, size_t j,
                                      unsigned char *codes);
const char *mlr_motion_joint_channels(const mlr_motion *motion, size_t j);
int mlr_motion_joint_has_position(const mlr_motion *motion, size_t j);
mlr_euler_order mlr_motion_joint_euler_order(const mlr_motion *motion, size_t j);
size_t mlr_motion_joint_names_packed(const mlr_motion *motion, char *buf, size_t cap);
size_t mlr_motion_joint_channels_packed(const mlr_motion *motion, char *buf, size_t cap);
size_t mlr_motion_joint_euler_orders(const mlr_motion *motion, int32_t *out);
size_t mlr_motion_n_end_sites(const mlr_motion *motion);
const int32_t *mlr_motion_end_site_parents(const mlr_motion *motion);
const double *mlr_motion_end_site_offsets(const mlr_motion *motion);
const double *mlr_motion_root_pos(const mlr_motion *motion);
double *mlr_motion_root_pos_mut(mlr_motion *motion);
const double *mlr_motion_rot(const mlr_motion *motion);
double *mlr_motion_rot_mut(mlr_motion *motion);
size_t mlr_motion_n_trans(const mlr_motion *motion);
const int32_t *mlr_motion_trans_joints(const mlr_motion *motion);
const double *mlr_motion_trans(const mlr_motion *motion);
double *mlr_motion_trans_mut(mlr_motion *motion);

/* mlr_fk.h */
mlr_status mlr_fk_arrays(size_t n_frames, size_t n_joints, const int32_t *parents,
                         const double *offsets, const double *root_pos,
                         const double *rot, size_t n_trans,
                         const int32_t *trans_joints, const double *trans,
                         double *world_pos, double *world_rot,
                         const mlr_allocator *alloc, mlr_diag *diag);
mlr_status mlr_fk_motion(const mlr_motion *motion, size_t begin, size_t count,
                         double *world_pos, double *world_rot, mlr_diag *diag);

/* mlr_quat.h: predictive sign continuity */
void mlr_quat_continue_sign(const mlr_quat *prev, size_t n_prev, const mlr_quat *q,
                            mlr_quat *out);
void mlr_quat_make_continuous_predictive(mlr_quat *q, size_t n_frames, size_t n_tracks);

/* mlr_resample.h; MLR_RESAMPLE_AUTO is -1.0, KAPPA_DOWN 0.5, KAPPA_UP 0.01,
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
                           double *out, size_t out_len, size_t *n_ready, mlr_diag *diag);
mlr_status mlr_stream_flush(mlr_stream *st, double *out, size_t out_len, size_t *n_written,
                            mlr_diag *diag);
void mlr_stream_reset(mlr_stream *st);
mlr_status mlr_stream_set_alpha(mlr_stream *st, double alpha_trans, const double *alpha,
                                size_t n_joints, mlr_diag *diag);
size_t mlr_stream_frame_size(const mlr_stream *st);
size_t mlr_stream_lag(const mlr_stream *st);
size_t mlr_stream_n_pushed(const mlr_stream *st);
size_t mlr_stream_pending(const mlr_stream *st);
double mlr_stream_decay_rate(double lam, double sigma);
void mlr_stream_destroy(mlr_stream *st);

/* mlr_layers.h */
typedef struct mlr_layers mlr_layers;
typedef enum mlr_layers_key {
    MLR_LAYERS_OPT_GAMMA = 1, MLR_LAYERS_OPT_LAM_B = 2, MLR_LAYERS_OPT_SIGMA_B = 3,
    MLR_LAYERS_OPT_LAM_C = 4, MLR_LAYERS_OPT_SIGMA_C = 5, MLR_LAYERS_OPT_BASE_S_MIN = 6,
    MLR_LAYERS_OPT_BASE_S_MAX = 7, MLR_LAYERS_OPT_CONTROL_S_MIN = 8,
    MLR_LAYERS_OPT_CONTROL_S_MAX = 9, MLR_LAYERS_OPT_FPS = 10, MLR_LAYERS_OPT_BASE_CUTOFF = 11,
    MLR_LAYERS_OPT_BODY_JOINT = 12,
    MLR_LAYERS_OPT_ROBUST = 13,
    MLR_LAYERS_OPT_BODY_HEIGHT = 14,
    MLR_LAYERS_OPT_ROBUST_ANGLE = 15
} mlr_layers_key;
typedef struct mlr_layers_option { int key; double value; } mlr_layers_option;
typedef enum mlr_layers_param {
    MLR_LAYERS_PARAM_BASE_S = 0, MLR_LAYERS_PARAM_BASE_LAM = 1, MLR_LAYERS_PARAM_BASE_SIGMA = 2,
    MLR_LAYERS_PARAM_BASE_MAX_ANGLE = 3, MLR_LAYERS_PARAM_CONTROL_S = 4,
    MLR_LAYERS_PARAM_CONTROL_LAM = 5, MLR_LAYERS_PARAM_CONTROL_SIGMA = 6,
    MLR_LAYERS_PARAM_CONTROL_GCV = 7, MLR_LAYERS_PARAM_CONTROL_DOF = 8
} mlr_layers_param;
mlr_status mlr_layers_decompose(size_t n_frames, size_t n_joints, const double *root_pos,
                                const double *rot, const mlr_layers_option *opts, size_t n_opts,
                                const mlr_allocator *alloc, mlr_layers **out, mlr_diag *diag);
size_t mlr_layers_n_frames(const mlr_layers *layers);
size_t mlr_layers_n_joints(const mlr_layers *layers);
mlr_status mlr_layers_get_base(const mlr_layers *layers, double *root_pos, size_t n_root_pos,
                               double *rot, size_t n_rot);
mlr_status mlr_layers_get_control(const mlr_layers *layers, double *out, size_t count);
mlr_status mlr_layers_get_residual(const mlr_layers *layers, double *out, size_t count);
mlr_status mlr_layers_get_param(const mlr_layers *layers, mlr_layers_param which, double *out,
                                size_t count);
mlr_status mlr_layers_synthesize(const mlr_layers *layers, size_t begin, size_t count,
                                 const double *alpha, size_t n_alpha, double *root_pos,
                                 size_t n_root_pos, double *rot, size_t n_rot, mlr_diag *diag);
mlr_status mlr_layers_synthesize_frames(const mlr_layers *layers, size_t begin, size_t count,
                                        const double *alpha, size_t n_alpha, double *root_pos,
                                        size_t n_root_pos, double *rot, size_t n_rot,
                                        mlr_diag *diag);
mlr_status mlr_alpha_keys_check(const double *times, const double *values, size_t n_keys,
                                mlr_diag *diag);
mlr_status mlr_alpha_keys_eval(const double *times, const double *values, size_t n_keys,
                               const double *t, size_t count, double *out, mlr_diag *diag);
mlr_status mlr_layers_reconstruct(const mlr_layers *layers, size_t begin, size_t count,
                                  double *root_pos, size_t n_root_pos, double *rot, size_t n_rot,
                                  mlr_diag *diag);
void mlr_layers_destroy(mlr_layers *layers);
/* mlr_kmeans.h */
typedef struct mlr_kmeans mlr_kmeans;
enum {
    MLR_KMEANS_MAX_ITER = 1, MLR_KMEANS_TOL = 2, MLR_KMEANS_N_INIT = 3, MLR_KMEANS_SEED = 4,
    MLR_KMEANS_N_THREADS = 5, MLR_KMEANS_ALGORITHM = 6
};
enum { MLR_KMEANS_AUTO = 0, MLR_KMEANS_LLOYD = 1, MLR_KMEANS_HAMERLY = 2 };
mlr_status mlr_kmeans_create(size_t k, size_t dim, const mlr_allocator *alloc,
                             mlr_kmeans **out, mlr_diag *diag);
mlr_status mlr_kmeans_set(mlr_kmeans *km, int option, double value, mlr_diag *diag);
mlr_status mlr_kmeans_fit(mlr_kmeans *km, const double *x, size_t n, size_t ldx,
                          const double *init, size_t ldinit, int32_t *labels, mlr_diag *diag);
mlr_status mlr_kmeans_predict(const mlr_kmeans *km, const double *x, size_t n, size_t ldx,
                              int32_t *labels, double *dist2, mlr_diag *diag);
mlr_status mlr_kmeans_set_centers(mlr_kmeans *km, const double *c, size_t ldc, mlr_diag *diag);
const double *mlr_kmeans_centers(const mlr_kmeans *km);
double mlr_kmeans_inertia(const mlr_kmeans *km);
size_t mlr_kmeans_n_iter(const mlr_kmeans *km);
size_t mlr_kmeans_n_skipped(const mlr_kmeans *km);
size_t mlr_kmeans_k(const mlr_kmeans *km);
size_t mlr_kmeans_dim(const mlr_kmeans *km);
void mlr_kmeans_destroy(mlr_kmeans *km);

/* mlr_markov.h */
typedef struct mlr_rng {
    uint64_t s[4];
} mlr_rng;
void mlr_rng_seed(mlr_rng *rng, uint64_t seed);
uint64_t mlr_rng_u64(mlr_rng *rng);
double mlr_rng_uniform(mlr_rng *rng);
size_t mlr_rng_below(mlr_rng *rng, size_t n);
typedef struct mlr_markov mlr_markov;
mlr_status mlr_markov_create(size_t n_states, const double *jumps, const double *run_length,
                             unsigned order, size_t min_count, size_t n_contexts,
                             const int64_t *context_keys, const double *context_seen,
                             const double *context_probs, const mlr_allocator *alloc,
                             mlr_markov **out, mlr_diag *diag);
size_t mlr_markov_n_states(const mlr_markov *mk);
unsigned mlr_markov_order(const mlr_markov *mk);
mlr_status mlr_markov_next(const mlr_markov *mk, const int64_t *history, size_t len, int rank,
                           mlr_rng *rng, int64_t *next, mlr_diag *diag);
double mlr_markov_step_frames(const mlr_markov *mk, int64_t a, int64_t b);
mlr_status mlr_markov_path(const mlr_markov *mk, const int64_t *history, size_t n_history,
                           int64_t start, size_t n_frames, int rank, mlr_rng *rng, int64_t *path,
                           size_t cap, size_t *len, mlr_diag *diag);
void mlr_markov_destroy(mlr_markov *mk);
double mlr_rng_gamma(mlr_rng *rng, double shape);
mlr_status mlr_markov_perturb(const mlr_markov *mk, double noise, int allow_unseen, mlr_rng *rng,
                              const mlr_allocator *alloc, mlr_markov **out, mlr_diag *diag);

/* mlr_generate.h */
#define MLR_GEN_FORMAT_VERSION 1
typedef struct mlr_gen_model mlr_gen_model;
mlr_status mlr_gen_model_load(const mlr_allocator *alloc, const void *bytes, size_t size,
                              const mlr_motion *skeleton, mlr_gen_model **out, mlr_diag *diag);
mlr_status mlr_gen_model_load_file(const mlr_allocator *alloc, const char *path,
                                   const mlr_motion *skeleton, mlr_gen_model **out,
                                   mlr_diag *diag);
size_t mlr_gen_model_n_joints(const mlr_gen_model *model);
const char *mlr_gen_model_joint_name(const mlr_gen_model *model, size_t joint);
size_t mlr_gen_model_body_joint(const mlr_gen_model *model);
size_t mlr_gen_model_n_points(const mlr_gen_model *model);
size_t mlr_gen_model_n_primitives(const mlr_gen_model *model);
double mlr_gen_model_frame_time(const mlr_gen_model *model);
size_t mlr_gen_model_frame_size(const mlr_gen_model *model);
void mlr_gen_model_destroy(mlr_gen_model *model);
typedef enum mlr_generate_key {
    MLR_GEN_OPT_FRAMES = 1, MLR_GEN_OPT_START_FRAME = 2, MLR_GEN_OPT_START = 3,
    MLR_GEN_OPT_RANK = 4, MLR_GEN_OPT_SMOOTH = 5, MLR_GEN_OPT_NOISE = 6,
    MLR_GEN_OPT_ALLOW_UNSEEN = 7, MLR_GEN_OPT_PIN_FEET = 8
} mlr_generate_key;
typedef struct mlr_generate_option {
    int key;
    double value;
} mlr_generate_option;
typedef struct mlr_generator mlr_generator;
mlr_status mlr_generator_create(const mlr_allocator *alloc, const mlr_gen_model *model,
                                uint64_t seed, const mlr_generate_option *opts, size_t n_opts,
                                mlr_generator **out, mlr_diag *diag);
mlr_status mlr_generator_next(mlr_generator *gen, double *pose, mlr_diag *diag);
uint64_t mlr_generator_frame(const mlr_generator *gen);
void mlr_generator_point(const mlr_generator *gen, double point[2]);
int64_t mlr_generator_primitive(const mlr_generator *gen);
int64_t mlr_generator_start_frame(const mlr_generator *gen);
void mlr_generator_destroy(mlr_generator *gen);

/* mlr_som.h */
typedef struct mlr_som mlr_som;
enum {
    MLR_SOM_SEED = 1, MLR_SOM_N_THREADS = 2, MLR_SOM_SIGMA0 = 3, MLR_SOM_SIGMA1 = 4,
    MLR_SOM_ALPHA0 = 5, MLR_SOM_ALPHA1 = 6, MLR_SOM_CUTOFF = 7
};
enum { MLR_SOM_BATCH = 0, MLR_SOM_ONLINE = 1 };
mlr_status mlr_som_create(size_t rows, size_t cols, size_t dim, const mlr_allocator *alloc,
                          mlr_som **out, mlr_diag *diag);
mlr_status mlr_som_set(mlr_som *som, int option, double value, mlr_diag *diag);
mlr_status mlr_som_init_random(mlr_som *som, const double *x, size_t n, size_t ldx,
                               mlr_diag *diag);
mlr_status mlr_som_train(mlr_som *som, const double *x, size_t n, size_t ldx, size_t epochs,
                         int mode, mlr_diag *diag);
mlr_status mlr_som_bmu(const mlr_som *som, const double *x, size_t n, size_t ldx, int32_t *bmu,
                       double *dist, int32_t *second, mlr_diag *diag);
mlr_status mlr_som_errors(const mlr_som *som, const double *x, size_t n, size_t ldx, double *qe,
                          double *te, mlr_diag *diag);
const double *mlr_som_codebook(const mlr_som *som);
mlr_status mlr_som_set_codebook(mlr_som *som, const double *w, size_t ldw, mlr_diag *diag);
size_t mlr_som_rows(const mlr_som *som);
size_t mlr_som_cols(const mlr_som *som);
size_t mlr_som_dim(const mlr_som *som);
size_t mlr_som_export_size(const mlr_som *som);
mlr_status mlr_som_export(const mlr_som *som, void *buf, size_t size, mlr_diag *diag);
mlr_status mlr_som_import(const void *buf, size_t size, const mlr_allocator *alloc,
                          mlr_som **out, mlr_diag *diag);
void mlr_som_destroy(mlr_som *som);

/* mlr_grbf.h */
enum { MLR_GRBF_THIN_PLATE = 0, MLR_GRBF_GAUSSIAN = 1 };
mlr_status mlr_grbf_basis(int kernel, double width, const double *centers, size_t n_centers,
                          size_t ldc, const double *x, size_t n, size_t ldx, size_t dim, int poly,
                          size_t n_threads, double *out, size_t ldo, const mlr_allocator *alloc,
                          mlr_diag *diag);
mlr_status mlr_grbf_eval(int kernel, double width, const double *centers, size_t n_centers,
                         size_t ldc, const double *coef, size_t ldcoef, size_t n_out,
                         const double *x, size_t n, size_t ldx, size_t dim, size_t n_threads,
                         double *out, size_t ldo, const mlr_allocator *alloc, mlr_diag *diag);
mlr_status mlr_grbf_fit_lattice(int kernel, double width, const double *xs, size_t rows,
                                const double *ys, size_t cols, const double *y, size_t ldy,
                                size_t n_out, size_t n_threads, double *coef, size_t ldcoef,
                                const mlr_allocator *alloc, mlr_diag *diag);

/* mlr_rig.h */
typedef struct mlr_rig {
    size_t n_joints;
    const int32_t *parents;
    const double *offsets;
    const char *const *names;
    size_t n_trans;
    const int32_t *trans_joints;
    size_t n_end_sites;
    const int32_t *end_site_parents;
    const double *end_site_offsets;
} mlr_rig;
typedef struct mlr_frames {
    size_t n_frames;
    const double *root_pos;
    const double *rot;
    const double *trans;
} mlr_frames;
typedef enum mlr_axis { MLR_AXIS_X = 0, MLR_AXIS_Y = 1, MLR_AXIS_Z = 2 } mlr_axis;
mlr_status mlr_rig_check(const mlr_rig *rig, mlr_diag *diag);
mlr_status mlr_rig_depth_first_order(size_t n_joints, const int32_t *parents,
                                     const char *const *names, int32_t *order,
                                     const mlr_allocator *alloc, mlr_diag *diag);
mlr_status mlr_rig_find_point(const mlr_rig *rig, const char *name, int32_t *joint,
                              int32_t *end_site, mlr_diag *diag);
mlr_status mlr_rig_point_positions(const mlr_rig *rig, size_t n_frames,
                                   const double *world_pos, const double *world_rot,
                                   size_t n_points, const int32_t *joints,
                                   const int32_t *end_sites, double *out, mlr_diag *diag);
mlr_status mlr_rig_body_height(size_t n_frames, size_t n_joints, const double *world_pos,
                               int up, double *height, const mlr_allocator *alloc,
                               mlr_diag *diag);
mlr_status mlr_rig_body_translation_joint(const mlr_rig *rig, size_t n_frames,
                                          const double *root_pos, const double *trans,
                                          int32_t *joint, mlr_diag *diag);
typedef struct mlr_up_guess {
    int axis;
    int sign;
    double confidence;
    int method;
} mlr_up_guess;
mlr_status mlr_rig_up_axis(const mlr_rig *rig, size_t n_frames, const double *world_pos,
                           mlr_up_guess *out, const mlr_allocator *alloc, mlr_diag *diag);

/* mlr_trim.h */
typedef struct mlr_trim_lead {
    size_t n_frames;
    size_t n_held;
    double distance;
} mlr_trim_lead;
mlr_status mlr_trim_lead_in(const mlr_rig *rig, size_t n_frames, const double *root_pos,
                            const double *rot, const double *trans, int up, mlr_trim_lead *out,
                            const mlr_allocator *alloc, mlr_diag *diag);

/* mlr_contacts.h */
mlr_status mlr_contacts_find_feet(const mlr_rig *rig, size_t n_frames, const double *world_pos,
                                  int up, size_t capacity, int32_t *joints, int32_t *end_sites,
                                  size_t *n_feet, const mlr_allocator *alloc, mlr_diag *diag);
typedef enum mlr_contacts_key {
    MLR_CONTACTS_OPT_SPEED = 1,
    MLR_CONTACTS_OPT_HEIGHT = 2,
    MLR_CONTACTS_OPT_MIN_DURATION = 3
} mlr_contacts_key;
typedef struct mlr_contacts_option {
    int key;
    double value;
} mlr_contacts_option;
mlr_status mlr_contacts_detect(const mlr_rig *rig, double fps, int up, size_t n_frames,
                               const double *world_pos, const double *world_rot,
                               size_t n_points, const int32_t *joints, const int32_t *end_sites,
                               const mlr_contacts_option *opts, size_t n_opts,
                               uint8_t *contacts, const mlr_allocator *alloc, mlr_diag *diag);

/* mlr_limits.h */
typedef struct mlr_limits mlr_limits;
typedef enum mlr_limits_kind {
    MLR_LIMITS_FREE = 0,
    MLR_LIMITS_HINGE = 1,
    MLR_LIMITS_SWING_TWIST = 2
} mlr_limits_kind;
typedef enum mlr_limits_source {
    MLR_LIMITS_SOURCE_NONE = 0,
    MLR_LIMITS_SOURCE_TABLE = 1,
    MLR_LIMITS_SOURCE_INPUT = 2,
    MLR_LIMITS_SOURCE_USER = 3
} mlr_limits_source;
typedef struct mlr_limits_range {
    int kind;
    double lo;
    double hi;
    double swing;
    double twist;
    int widen;
    int source;
} mlr_limits_range;
typedef struct mlr_limits_clip {
    size_t n_frames;
    const double *rot;
    const double *trans;
} mlr_limits_clip;
typedef enum mlr_limits_key {
    MLR_LIMITS_OPT_HUMAN = 1,
    MLR_LIMITS_OPT_FOLD = 2,
    MLR_LIMITS_OPT_SOFT = 3,
    MLR_LIMITS_OPT_REVERSAL_SOFT = 4
} mlr_limits_key;
typedef struct mlr_limits_option {
    int key;
    double value;
} mlr_limits_option;
mlr_status mlr_limits_create(const mlr_rig *rig, const mlr_limits_clip *clips, size_t n_clips,
                             const mlr_limits_option *opts, size_t n_opts,
                             const mlr_allocator *alloc, mlr_limits **out, mlr_diag *diag);
size_t mlr_limits_n_joints(const mlr_limits *lim);
int mlr_limits_is_human(const mlr_limits *lim);
mlr_status mlr_limits_get_range(const mlr_limits *lim, size_t joint, mlr_limits_range *out);
mlr_status mlr_limits_set_range(mlr_limits *lim, size_t joint, const mlr_limits_range *range,
                                mlr_diag *diag);
mlr_status mlr_limits_get_geometry(const mlr_limits *lim, size_t joint, double *centre,
                                   double *axis, double *bone_in, double *bone_out,
                                   double *stats);
mlr_status mlr_limits_apply(const mlr_limits *lim, size_t n_frames, const double *rot_in,
                            double *rot_out, const double *alpha, size_t n_alpha,
                            size_t *counts, size_t n_counts, mlr_diag *diag);
void mlr_limits_destroy(mlr_limits *lim);
/* mlr_generate.h, after mlr_rig and mlr_limits */
mlr_status mlr_generator_set_guards(mlr_generator *gen, const mlr_rig *rig, const double *rest,
                                    const mlr_limits *limits, mlr_diag *diag);
mlr_status mlr_stream_set_limits(mlr_stream *st, const mlr_limits *limits, mlr_diag *diag);

/* mlr_ik.h */
mlr_status mlr_ik_two_bone(size_t n, const double *hip, const double *knee, const double *end,
                           const double *target, const double *bend_axis, double max_extension,
                           double *r_hip, double *r_knee, mlr_diag *diag);
mlr_status mlr_ik_from_to(size_t n, const double *u, const double *v, double *out);
mlr_status mlr_ik_leg_chain(const mlr_rig *rig, int32_t end, int32_t *hip, int32_t *knee,
                            mlr_diag *diag);
mlr_status mlr_ik_bend_axis_local(size_t n, size_t n_joints, const double *world_pos,
                                  const double *world_rot, int32_t hip, int32_t knee,
                                  int32_t end, double axis[3], mlr_diag *diag);
mlr_status mlr_ik_rotate_to(size_t n, size_t n_joints, const int32_t *parents, double *rot,
                            const double *world_rot, int32_t joint, const double *r_world,
                            mlr_diag *diag);
mlr_status mlr_ik_apply_leg(size_t n, size_t n_joints, const int32_t *parents, double *rot,
                            const double *world_pos, const double *world_rot, int32_t hip,
                            int32_t knee, int32_t end, const double *target,
                            const double *bend_axis, mlr_diag *diag);

/* mlr_cleanup.h */
typedef enum mlr_cleanup_key {
    MLR_CLEANUP_OPT_BLEND = 1,
    MLR_CLEANUP_OPT_REACH = 2,
    MLR_CLEANUP_OPT_PASSES = 3,
    MLR_CLEANUP_OPT_FLOOR = 4,
    MLR_CLEANUP_OPT_FLOOR_HEIGHT = 5,
    MLR_CLEANUP_OPT_FLOOR_QUANTILE = 6,
    MLR_CLEANUP_OPT_REF_SMOOTH = 7,
    MLR_CLEANUP_OPT_PIN_SMOOTH = 8,
    MLR_CLEANUP_OPT_ROOT = 9,
    MLR_CLEANUP_OPT_MAX_FOLD = 10,
    MLR_CLEANUP_OPT_KEEP_STILLER = 11,
    MLR_CLEANUP_OPT_KEEP_TOTAL = 12,
    MLR_CLEANUP_OPT_PIN_DETAIL = 13,
    MLR_CLEANUP_OPT_RAMP_TRACK = 14,
    MLR_CLEANUP_OPT_ROOT_BOB = 15,
    MLR_CLEANUP_OPT_STRAIGHT_SLACK = 16,
    MLR_CLEANUP_OPT_SOFT_REACH = 17
} mlr_cleanup_key;
typedef struct mlr_cleanup_option {
    int key;
    double value;
} mlr_cleanup_option;
typedef struct mlr_cleanup_report {
    double floor_height;
    size_t contact_frames;
    size_t floor_frames;
    double root_shift_max;
} mlr_cleanup_report;
mlr_status mlr_cleanup_floor_height(const mlr_rig *rig, size_t n_frames,
                                    const double *root_pos, const double *rot,
                                    const double *trans, size_t n_points,
                                    const int32_t *joints, const int32_t *end_sites,
                                    const uint8_t *contacts, int up, double quantile,
                                    double *height, const mlr_allocator *alloc,
                                    mlr_diag *diag);
mlr_status mlr_cleanup_contacts(const mlr_rig *rig, size_t n_frames, double fps, int up,
                                const double *root_pos, const double *rot, const double *trans,
                                const double *ref_root_pos, const double *ref_rot,
                                const double *ref_trans, size_t n_points,
                                const int32_t *joints, const int32_t *end_sites,
                                const uint8_t *contacts, const mlr_cleanup_option *opts,
                                size_t n_opts, double *out_root_pos, double *out_rot,
                                mlr_cleanup_report *report, const mlr_allocator *alloc,
                                mlr_diag *diag);
typedef struct mlr_cleanup_points {
    size_t n_points;
    const int32_t *joints;
    const int32_t *end_sites;
    const uint8_t *contacts;
} mlr_cleanup_points;
typedef struct mlr_cleanup_job {
    const mlr_rig *rig;
    double fps;
    int up;
    mlr_frames motion;
    mlr_frames reference;
    mlr_cleanup_points points;
    const mlr_cleanup_option *opts;
    size_t n_opts;
    double *out_root_pos;
    double *out_rot;
    mlr_cleanup_report *report;
} mlr_cleanup_job;
mlr_status mlr_cleanup_job_validate(const mlr_cleanup_job *job, mlr_diag *diag);
mlr_status mlr_cleanup_job_run(const mlr_cleanup_job *job, const mlr_allocator *alloc,
                               mlr_diag *diag);
mlr_status mlr_cleanup_job_floor_height(const mlr_cleanup_job *job, double quantile,
                                        double *height, const mlr_allocator *alloc,
                                        mlr_diag *diag);


/* mlr_guards.h */
typedef struct mlr_guards mlr_guards;
typedef enum mlr_guards_limits_mode {
    MLR_GUARDS_LIMITS_OFF = 0,
    MLR_GUARDS_LIMITS_AUTO = 1,
    MLR_GUARDS_LIMITS_ALWAYS = 2
} mlr_guards_limits_mode;
typedef enum mlr_guards_key {
    MLR_GUARDS_OPT_UP = 1,
    MLR_GUARDS_OPT_LIMITS = 2,
    MLR_GUARDS_OPT_KEEP_CONTACTS = 3,
    MLR_GUARDS_OPT_FLOOR = 4,
    MLR_GUARDS_OPT_FLOOR_HEIGHT = 5,
    MLR_GUARDS_OPT_FOLLOW = 6
} mlr_guards_key;
typedef struct mlr_guards_option {
    int key;
    double value;
} mlr_guards_option;
typedef struct mlr_guards_report {
    int limits_applied;
    size_t limited_joints;
    size_t limited_frames;
    size_t contact_frames;
    size_t floor_frames;
    double floor_height;
    double root_shift_max;
    size_t floor_raised;
} mlr_guards_report;
mlr_status mlr_guards_create(const mlr_rig *rig, double fps, size_t n_frames,
                             const double *root_pos, const double *rot, const double *trans,
                             const mlr_guards_option *opts, size_t n_opts,
                             const mlr_allocator *alloc, mlr_guards **out, mlr_diag *diag);
size_t mlr_guards_n_points(const mlr_guards *g);
mlr_status mlr_guards_get_contacts(const mlr_guards *g, int32_t *joints, int32_t *end_sites,
                                   uint8_t *contacts);
mlr_status mlr_guards_set_contacts(mlr_guards *g, size_t n_points, const int32_t *joints,
                                   const int32_t *end_sites, const uint8_t *contacts,
                                   mlr_diag *diag);
mlr_status mlr_guards_set_limits(mlr_guards *g, const mlr_limits *limits, mlr_diag *diag);
mlr_status mlr_guards_apply(const mlr_guards *g, const double *alpha, size_t n_alpha,
                            const double *ref_root_pos, const double *ref_rot,
                            const double *ref_trans, double *root_pos, double *rot,
                            const double *trans, size_t *limited, size_t n_limited,
                            mlr_guards_report *report, mlr_diag *diag);
mlr_status mlr_guards_apply_trans(const mlr_guards *g, const double *alpha, size_t n_alpha,
                                  const double *ref_root_pos, const double *ref_rot,
                                  const double *ref_trans, double *root_pos, double *rot,
                                  double *trans, size_t *limited, size_t n_limited,
                                  mlr_guards_report *report, mlr_diag *diag);
typedef struct mlr_guards_input {
    const mlr_rig *rig;
    double fps;
    mlr_frames frames;
    const mlr_guards_option *opts;
    size_t n_opts;
} mlr_guards_input;
mlr_status mlr_guards_create_from(const mlr_guards_input *input, const mlr_allocator *alloc,
                                  mlr_guards **out, mlr_diag *diag);
typedef struct mlr_guards_job {
    const double *alpha;
    size_t n_alpha;
    mlr_frames reference;
    double *root_pos;
    double *rot;
    double *trans;
    int body_on_trans;
    size_t *limited;
    size_t n_limited;
    mlr_guards_report *report;
} mlr_guards_job;
mlr_status mlr_guards_job_validate(const mlr_guards *g, const mlr_guards_job *job,
                                   mlr_diag *diag);
mlr_status mlr_guards_run(const mlr_guards *g, const mlr_guards_job *job, mlr_diag *diag);
void mlr_guards_destroy(mlr_guards *g);

/* Exact retiming (issue 20). */
enum { MLR_RESAMPLE_OPEN_END = 4 };
mlr_status mlr_resample_rate_map(size_t n_frames, double fps_in, double fps_out,
                                 unsigned flags, double *t, size_t *n_out, mlr_diag *diag);

/* Lenient BVH reading with warnings (issue 20). */
typedef enum mlr_bvh_read_key {
    MLR_BVH_OPT_STRICT = 1, MLR_BVH_OPT_KEEP_TRUNCATED = 2
} mlr_bvh_read_key;
typedef struct mlr_bvh_read_option { int key; double value; } mlr_bvh_read_option;
typedef enum mlr_bvh_warning_code {
    MLR_BVH_WARN_EXTRA_FRAMES = 1, MLR_BVH_WARN_MISSING_FRAMES = 2,
    MLR_BVH_WARN_TRAILING_DATA = 3, MLR_BVH_WARN_NO_FINAL_NEWLINE = 4,
    MLR_BVH_WARN_TRUNCATED = 5
} mlr_bvh_warning_code;
typedef struct mlr_bvh_warning {
    int32_t code;
    size_t line, column;
    char message[160];
} mlr_bvh_warning;
typedef struct mlr_bvh_warnings {
    size_t count;
    mlr_bvh_warning first[8];
} mlr_bvh_warnings;
mlr_status mlr_bvh_read_memory_opts(const char *text, size_t len, size_t n_threads,
                                    const mlr_bvh_read_option *opts, size_t n_opts,
                                    const mlr_allocator *alloc, mlr_motion **out,
                                    mlr_bvh_warnings *warnings, mlr_diag *diag);
mlr_status mlr_bvh_read_file_opts(const char *path, size_t n_threads,
                                  const mlr_bvh_read_option *opts, size_t n_opts,
                                  const mlr_allocator *alloc, mlr_motion **out,
                                  mlr_bvh_warnings *warnings, mlr_diag *diag);

/* Robust layers (issue 20) */
mlr_status mlr_layers_get_outliers(const mlr_layers *layers, unsigned char *out, size_t count);
mlr_status mlr_layers_get_end_runs(const mlr_layers *layers, size_t *head, size_t *tail);
mlr_status mlr_layers_repair(const mlr_layers *layers, size_t begin, size_t count,
                             double *root_pos, size_t n_root_pos, double *rot, size_t n_rot,
                             size_t *n_repaired, mlr_diag *diag);

/* mlr_mirror.h */
typedef enum mlr_mirror_flag {
    MLR_MIRROR_GIVEN_ONLY = 1,
    MLR_MIRROR_KEEP_SKELETON = 2
} mlr_mirror_flag;
enum { MLR_MIRROR_PLANE_AUTO = -1 };
mlr_status mlr_mirror_pairs(const mlr_rig *rig, const char *const *given, size_t n_given,
                            unsigned flags, int32_t *partner, int8_t *side, size_t *n_pairs,
                            const mlr_allocator *alloc, mlr_diag *diag);
mlr_status mlr_mirror_plane(const mlr_rig *rig, const int32_t *partner, int plane, int *axis,
                            mlr_diag *diag);
mlr_status mlr_mirror_motion(const mlr_rig *rig, const int32_t *partner, int axis,
                             unsigned flags, size_t n_frames, const double *root_pos,
                             const double *rot, const double *trans, double *out_root_pos,
                             double *out_rot, double *out_trans, double *out_offsets,
                             double *out_end_site_offsets, mlr_diag *diag);

/* mlr_retarget.h */
#define MLR_RETARGET_MAX_SPINE 8
#define MLR_RETARGET_MAX_NECK 4
enum { MLR_ROLE_COUNT = 30 };
const char *mlr_role_name(int role);
mlr_status mlr_retarget_roles(const mlr_rig *rig, int32_t *role_joint, const mlr_allocator *alloc,
                              mlr_diag *diag);
typedef struct mlr_retarget_info {
    double scale;
    size_t n_matched;
    double to_source[9];
} mlr_retarget_info;
mlr_status mlr_retarget(const mlr_rig *source, size_t n_frames, const double *root_pos,
                        const double *rot, const double *trans, const mlr_rig *target,
                        int source_up, int target_up, const char *const *map, size_t n_map,
                        double *out_root_pos, double *out_rot, double *out_trans, mlr_retarget_info *info,
                        const mlr_allocator *alloc, mlr_diag *diag);
mlr_status mlr_retarget_feet(const mlr_rig *source, size_t n_frames, double fps, int up,
                             const double *root_pos, const double *rot, const double *trans,
                             const mlr_rig *target, int target_up, const char *const *map,
                             size_t n_map, double *out_root_pos, double *out_rot,
                             const double *out_trans,
                             mlr_cleanup_report *report, const mlr_allocator *alloc,
                             mlr_diag *diag);

/* mlr_root_motion.h */
typedef enum mlr_root_motion_mode {
    MLR_ROOT_MOTION_GROUND = 0,
    MLR_ROOT_MOTION_POSITION = 1
} mlr_root_motion_mode;
typedef enum mlr_root_motion_key {
    MLR_ROOT_MOTION_OPT_SMOOTH = 1,
    MLR_ROOT_MOTION_OPT_BODY_JOINT = 2
} mlr_root_motion_key;
typedef struct mlr_root_motion_option {
    int key;
    double value;
} mlr_root_motion_option;
mlr_status mlr_root_motion_extract(const mlr_rig *rig, double fps, int up, int mode,
                                   size_t n_frames, const double *root_pos, const double *rot,
                                   const double *trans, const mlr_root_motion_option *opts,
                                   size_t n_opts, double *track_pos, double *track_heading,
                                   double *out_root_pos, double *out_root_rot, size_t ld_out_rot,
                                   const mlr_allocator *alloc, mlr_diag *diag);
mlr_status mlr_root_motion_apply(int up, size_t n_frames, const double *track_pos,
                                 const double *track_heading, const double *root_pos,
                                 const double *root_rot, size_t ld_root_rot,
                                 double *out_root_pos, double *out_root_rot, size_t ld_out_rot,
                                 mlr_diag *diag);

/* mlr_pipeline.h */
typedef struct mlr_pipeline mlr_pipeline;
typedef enum mlr_pipeline_param {
    MLR_PIPELINE_ALPHA = 1,
    MLR_PIPELINE_ROOT_ALPHA = 2,
    MLR_PIPELINE_UP = 3,
    MLR_PIPELINE_TRIM = 4,
    MLR_PIPELINE_UNITS = 5,
    MLR_PIPELINE_GUARDS = 6,
    MLR_PIPELINE_LIMITS = 7,
    MLR_PIPELINE_FLOOR = 8,
    MLR_PIPELINE_FLOOR_HEIGHT = 9,
    MLR_PIPELINE_KEEP_CONTACTS = 10,
    MLR_PIPELINE_ROBUST = 11,
    MLR_PIPELINE_GAMMA = 12,
    MLR_PIPELINE_LAM_C = 13,
    MLR_PIPELINE_SIGMA_C = 14,
    MLR_PIPELINE_LAM_B = 15,
    MLR_PIPELINE_SIGMA_B = 16,
    MLR_PIPELINE_BASE_CUTOFF = 17,
    MLR_PIPELINE_BODY_HEIGHT = 18,
    MLR_PIPELINE_KEEP_MEMORY = 19,
    MLR_PIPELINE_INFO_UP = 100,
    MLR_PIPELINE_INFO_TRIMMED = 101,
    MLR_PIPELINE_INFO_FRAMES = 102,
    MLR_PIPELINE_INFO_BODY_JOINT = 103,
    MLR_PIPELINE_INFO_BODY_HEIGHT = 104
} mlr_pipeline_param;
mlr_status mlr_pipeline_create(const mlr_allocator *alloc, mlr_pipeline **out, mlr_diag *diag);
mlr_status mlr_pipeline_set(mlr_pipeline *p, mlr_pipeline_param param, double value,
                            mlr_diag *diag);
mlr_status mlr_pipeline_get(const mlr_pipeline *p, mlr_pipeline_param param, double *value);
mlr_status mlr_pipeline_set_joint_alpha(mlr_pipeline *p, const char *pattern, double alpha,
                                        mlr_diag *diag);
mlr_status mlr_pipeline_set_alpha_keys(mlr_pipeline *p, const char *pattern, const double *times,
                                       const double *values, size_t n_keys, mlr_diag *diag);
void mlr_pipeline_clear_joint_alphas(mlr_pipeline *p);
mlr_status mlr_pipeline_prepare(mlr_pipeline *p, const mlr_motion *in, const mlr_layers *layers,
                                mlr_diag *diag);
mlr_status mlr_pipeline_synthesize(mlr_pipeline *p, mlr_motion **out, mlr_diag *diag);
mlr_status mlr_pipeline_run(mlr_pipeline *p, const mlr_motion *in, mlr_motion **out,
                            mlr_diag *diag);
mlr_status mlr_pipeline_report(const mlr_pipeline *p, mlr_guards_report *report, size_t *limited,
                               size_t n_limited);
const mlr_layers *mlr_pipeline_layers(const mlr_pipeline *p);
mlr_guards *mlr_pipeline_guards(mlr_pipeline *p);
void mlr_pipeline_destroy(mlr_pipeline *p);
