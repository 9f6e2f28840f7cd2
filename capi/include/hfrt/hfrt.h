/* hfrt's stable C API (C99): compile HyperFun FRep models, evaluate them at points, over
 * boxes and with their gradient, and ray trace them into a caller's RGBA buffer.
 *
 *   hfrt_model* m = NULL;
 *   if (hfrt_model_compile_file("model.hf", NULL, &m) != HFRT_OK) {
 *     fprintf(stderr, "%s\n", hfrt_last_error_message());
 *     return 1;
 *   }
 *   double xs[3] = {1, 2, 3}, f;
 *   hfrt_model_eval_f64(m, 1, xs, 3, &f, 1, NULL, 0);
 *   hfrt_model_free(m);
 *
 * Conventions (the contract of every function):
 *  - Every function that can fail returns an hfrt_status; HFRT_OK (0) is success. On failure
 *    the calling thread's last error (hfrt_last_error_*) says what and where; it stays until
 *    the thread's next failing call. A successful call does not clear it.
 *  - No C++ exception and no abort crosses this API: null pointers, negative counts and
 *    buffers that are too small are reported as HFRT_ERROR_INVALID_ARGUMENT.
 *  - Handles are opaque. Evaluation and rendering are thread-safe on one handle (many
 *    threads at once); hfrt_model_set_params may be called concurrently with them too (it
 *    waits for running evaluations; it is a write lock).
 *  - Arrays of points are structures of arrays: coordinate k (x[k+1] in HyperFun) of point i
 *    is xs[k*n + i]; every length argument counts elements, not bytes.
 *  - Strings returned by the API are owned by it (see each function for how long they live).
 *
 * Link with `pkg-config --cflags --libs hfrt`, or find_package(hfrt) and hfrt::hfrt.
 */
#ifndef HFRT_HFRT_H
#define HFRT_HFRT_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/** The library's version, as compiled into the header and as linked (hfrt_version()). */
#define HFRT_VERSION_MAJOR 0
#define HFRT_VERSION_MINOR 1
#define HFRT_VERSION_PATCH 0

/** The version of the linked library, "MAJOR.MINOR.PATCH" (static storage). */
const char* hfrt_version(void);

/** What a call did. New codes may be added at the end; 0 is always success. */
typedef enum hfrt_status {
  HFRT_OK = 0,
  HFRT_ERROR_INVALID_ARGUMENT = 1, /**< null pointer, bad count, buffer too small, bad option */
  HFRT_ERROR_COMPILE = 2,          /**< the source has errors: see the diagnostics */
  HFRT_ERROR_IO = 3,               /**< a file cannot be read */
  HFRT_ERROR_NO_OBJECT = 4,        /**< the requested object is not in the source */
  HFRT_ERROR_RENDER = 5,           /**< the render could not be done (degenerate camera, ...) */
  HFRT_ERROR_INTERNAL = 6          /**< an unexpected failure inside hfrt (a bug: report it) */
} hfrt_status;

/** A short constant name for a status ("HFRT_ERROR_COMPILE"); never NULL. */
const char* hfrt_status_name(hfrt_status status);

/* ---- Errors and diagnostics ------------------------------------------------------------- */

typedef enum hfrt_severity {
  HFRT_SEVERITY_ERROR = 0,
  HFRT_SEVERITY_WARNING = 1,
  HFRT_SEVERITY_NOTE = 2
} hfrt_severity;

/** One located compile diagnostic. The strings live as long as their owner (the thread's
 * last error, or the model). line and column are 1-based; 0 when there is no location. */
typedef struct hfrt_diagnostic {
  hfrt_severity severity;
  const char* file;
  int32_t line;
  int32_t column;
  int32_t length; /**< bytes of source the diagnostic covers (0: a point) */
  const char* message;
  const char* hint; /**< how to fix it; "" when none */
} hfrt_diagnostic;

/** The status of the calling thread's last failing call (HFRT_OK if none failed yet). */
hfrt_status hfrt_last_error_status(void);
/** Its message: for compile errors every diagnostic rendered as text
 * (`file:line:col: error: message`, the source line, a caret, a hint); for argument errors
 * `function: what is wrong`. "" if none. Valid until the thread's next failing call. */
const char* hfrt_last_error_message(void);
/** Where the error is: the source file (or the name given to hfrt_model_compile_source),
 * line and column of the first error diagnostic; for other errors the file is the path or
 * the API function concerned and line/column are 0. Any pointer may be NULL. */
void hfrt_last_error_location(const char** file, int32_t* line, int32_t* column);
/** The API function that failed, e.g. "hfrt_model_eval_f64"; "" if none. */
const char* hfrt_last_error_function(void);
/** The diagnostics of the thread's last failed compile (errors, warnings and notes). */
int32_t hfrt_last_error_diagnostic_count(void);
/** Copies diagnostic `index` (0-based) of the last failed compile into *out. */
hfrt_status hfrt_last_error_diagnostic(int32_t index, hfrt_diagnostic* out);

/* ---- Compiling ------------------------------------------------------------------------- */

typedef enum hfrt_precision { HFRT_PRECISION_F64 = 0, HFRT_PRECISION_F32 = 1 } hfrt_precision;
typedef enum hfrt_backend { HFRT_BACKEND_JIT = 0, HFRT_BACKEND_INTERP = 1 } hfrt_backend;

/** Compile options. Initialise with hfrt_compile_options_init() and then set fields, so that
 * fields added in later versions keep their defaults. */
typedef struct hfrt_compile_options {
  uint32_t struct_size; /**< sizeof(hfrt_compile_options), set by init */
  const char* object;   /**< object to evaluate; NULL or "": `my_model`, else the first */
  const double* params; /**< initial a[1..num_params] (copied); NULL: all zeros */
  int32_t num_params;
  hfrt_precision precision; /**< which scalar evaluator is compiled eagerly */
  hfrt_backend backend;     /**< JIT (default) or the reference interpreter */
  /* Limits on hostile input (docs/limits.md; hfrt::ModelLimits), each at least 1; init sets
   * the defaults. A caller compiled against an older header (a smaller struct_size) gets the
   * defaults. An out-of-range value is HFRT_ERROR_INVALID_ARGUMENT. */
  int64_t max_loop_iterations; /**< while iterations per point (<= 2^24); beyond: NaN */
  int64_t max_array_size;      /**< elements of one array */
  int64_t max_slots;           /**< variables and array elements, inlined calls included */
  int64_t max_model_size;      /**< operations once object calls are inlined */
  int64_t max_source_bytes;    /**< bytes of the source file */
  int64_t max_mesh_bytes;      /**< bytes of a mesh or patch file; non-regular files refused */
  int64_t max_mesh_triangles;  /**< triangles (and vertices) of one mesh */
  /* Added after the limits above: a caller whose struct_size ends before it gets the default. */
  int64_t max_exact_curves; /**< open border curves of a patch set for its exact field;
                                 beyond, its field is tessellated (not an error) */
} hfrt_compile_options;

/** Fills *options with the defaults (no-op for NULL). */
void hfrt_compile_options_init(hfrt_compile_options* options);

/** An opaque compiled model. */
typedef struct hfrt_model hfrt_model;

/** Compiles HyperFun source text; `name` (may be NULL: "<input>") is the file name used in
 * diagnostics. `options` may be NULL (the defaults). On success *out is a new model to free
 * with hfrt_model_free; on failure *out is NULL and the last error holds the diagnostics. */
hfrt_status hfrt_model_compile_source(const char* source, const char* name,
                                      const hfrt_compile_options* options, hfrt_model** out);
/** Reads and compiles a file (HFRT_ERROR_IO when it cannot be read). */
hfrt_status hfrt_model_compile_file(const char* path, const hfrt_compile_options* options,
                                    hfrt_model** out);
/** Frees a model (NULL is a no-op). No call may use the model at the same time. */
void hfrt_model_free(hfrt_model* model);

/** The shape of the object: the sizes of x (inputs), a (parameters) and s (attributes). */
hfrt_status hfrt_model_info(const hfrt_model* model, int32_t* num_inputs, int32_t* num_params,
                            int32_t* num_attributes);
/** The evaluated object's name (owned by the model, valid until it is freed). */
const char* hfrt_model_object_name(const hfrt_model* model);
/** The warnings of a successful compile. */
int32_t hfrt_model_diagnostic_count(const hfrt_model* model);
hfrt_status hfrt_model_diagnostic(const hfrt_model* model, int32_t index, hfrt_diagnostic* out);

/** Sets a[1..count] without recompiling (missing ones are 0). count must not exceed the
 * object's a size. */
hfrt_status hfrt_model_set_params(hfrt_model* model, const double* params, int32_t count);

/** Sets the time: x[4] of an object with four or more inputs, for the calls that take points in
 * three coordinates (hfrt_render_model). Default 0. A number, never a recompile; concurrent with
 * evaluations like hfrt_model_set_params. The eval calls take every input from the caller. */
hfrt_status hfrt_model_set_time(hfrt_model* model, double time);

/* ---- Evaluating ------------------------------------------------------------------------ */
/* Each takes n >= 0 points (n = 0 is a no-op), coordinates xs as a structure of arrays of
 * num_inputs rows (xs_len >= num_inputs * n), and output buffers with their lengths. Points
 * where F has no value (a run-time error such as a division by zero) get NaN. */

/** F at n points in double precision; s[k+1] of point i to out_s[k*n + i] when out_s is not
 * NULL (s_len >= num_attributes * n). */
hfrt_status hfrt_model_eval_f64(const hfrt_model* model, int64_t n, const double* xs,
                                int64_t xs_len, double* out_f, int64_t f_len, double* out_s,
                                int64_t s_len);
/** The same in single precision (the f32 JIT code, compiled on first use). */
hfrt_status hfrt_model_eval_f32(const hfrt_model* model, int64_t n, const float* xs, int64_t xs_len,
                                float* out_f, int64_t f_len, float* out_s, int64_t s_len);
/** Encloses F over n boxes: box i is [lo[k*n + i], hi[k*n + i]] for each coordinate k
 * (lo <= hi). Every value F takes in the box is in [out_lo[i], out_hi[i]], or is NaN and then
 * out_maybe_nan[i] = 1 (out_maybe_nan may be NULL). */
hfrt_status hfrt_model_eval_interval(const hfrt_model* model, int64_t n, const double* lo,
                                     const double* hi, int64_t bounds_len, double* out_lo,
                                     double* out_hi, uint8_t* out_maybe_nan, int64_t out_len);
/** F and its gradient at n points: out[c*n + i] is F (c = 0) and dF/dx[c] (c = 1..3), by
 * automatic differentiation (out_len >= 4 * n). */
hfrt_status hfrt_model_gradient_f64(const hfrt_model* model, int64_t n, const double* xs,
                                    int64_t xs_len, double* out, int64_t out_len);

/* ---- Rendering ------------------------------------------------------------------------- */

typedef enum hfrt_root_search {
  HFRT_ROOT_AUTO = 0, /**< choose per model (as `hfrt render --root auto`) */
  HFRT_ROOT_SIGN = 1,
  HFRT_ROOT_INTERVAL = 2,
  HFRT_ROOT_ANALYTIC = 3
} hfrt_root_search;

/** How to render. Initialise with hfrt_render_options_init(). The camera fields left unset
 * (has_* = 0) are found as `hfrt render` finds them: the solid's extent inside bbox is
 * searched and framed from a three-quarter view. */
typedef struct hfrt_render_options {
  uint32_t struct_size;
  int32_t width, height; /**< pixels (default 512 x 512) */
  int32_t has_eye, has_look_at, has_up;
  double eye[3], look_at[3], up[3];
  double fov_deg;     /**< vertical field of view; 0: 35 degrees */
  double ortho_width; /**< > 0: orthographic with this view width */
  double bbox[6];     /**< xmin, ymin, zmin, xmax, ymax, zmax (default +-10) */
  hfrt_root_search root;
  int32_t spp;     /**< samples per pixel (default 1) */
  int32_t threads; /**< 0: all cores */
  int32_t shadows; /**< default 1 */
  double background[3];
} hfrt_render_options;

/** Fills *options with the defaults (no-op for NULL). */
void hfrt_render_options_init(hfrt_render_options* options);

/** Ray traces the model into `rgba`: width * height pixels, row-major from the top-left, 4
 * floats each (linear RGB and the alpha coverage), rgba_len >= 4 * width * height.
 * HFRT_ERROR_RENDER when the camera is degenerate or HFRT_ROOT_ANALYTIC is asked for a model
 * that does not qualify (the message is then located in the source).
 * Scene files: hfrt_render_scene_file(). */
hfrt_status hfrt_render_model(const hfrt_model* model, const hfrt_render_options* options,
                              float* rgba, int64_t rgba_len);

/** Traces a scene file (docs/scenes.md: placed models with materials and lights, reflection,
 * refraction, soft shadows, depth of field) into `rgba` as hfrt_render_model does, with the
 * scene's settings except the size (width x height) and `threads` (0: all cores).
 * HFRT_ERROR_RENDER with the located message for a bad scene file or a model that does not
 * compile; HFRT_ERROR_INVALID_ARGUMENT for a NULL or small buffer or a bad size. */
hfrt_status hfrt_render_scene_file(const char* path, int32_t width, int32_t height, int32_t threads,
                                   float* rgba, int64_t rgba_len);

#ifdef __cplusplus
}
#endif

#endif /* HFRT_HFRT_H */
