#pragma once
// hfrt's embedding API: compile HyperFun source to a Model and evaluate it, one point or a
// batch, in double or single precision, with the LLVM JIT or the reference interpreter.
//
//   auto compiled = hfrt::Model::compile(source);
//   if (!compiled.ok()) { std::cerr << compiled.rendered; return 1; }
//   hfrt::Model& model = *compiled.model;
//   hfrt::PointValue v = model.eval({1.0, 2.0, 3.0});   // v.f, v.s, v.error
//
// Self-contained: only the standard library here (no LLVM, no hfrt internals), so an
// embedder needs nothing but this header and the hfrt::jit library.

#include <cstdint>
#include <initializer_list>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hfrt {

namespace jit {
class HostKernels;  // jit/nvptx.h
class Tape;         // jit/tape.h
}  // namespace jit

/// Which evaluator runs the model. Both give the same f64 values (the interpreter is the
/// reference); the JIT is vectorised machine code, the interpreter can explain errors.
enum class Backend { kJit, kInterp };

enum class Precision { kF64, kF32 };

/// Limits on what one model may cost (docs/limits.md): hostile or broken input stops with a
/// clear error instead of hanging or exhausting memory. Every field must be at least 1;
/// Model::compile fails (CompileResult::error) otherwise.
struct ModelLimits {
  /// While-loop iterations per evaluation of one point, all loops together (inlined objects'
  /// included); beyond it the point has no value (NaN, "Loop iteration limit exceeded" at
  /// the loop). At most 16777216 (single precision counts exactly up to 2^24).
  int64_t max_loop_iterations = 1'000'000;
  /// Elements of one array (x, a, s in a header; `array` declarations): a located error.
  int64_t max_array_size = 8192;
  /// Slots of the model: its variables and array elements with their "assigned" flags, and
  /// those of every object call (calls are inlined).
  int64_t max_slots = 32768;
  /// Operations of the model once object calls are inlined (expression and statement nodes,
  /// array elements copied): objects that call the previous one twice double at each level.
  int64_t max_model_size = 4'000'000;
  /// Bytes of the source file (Model::compile_file).
  int64_t max_source_bytes = int64_t{64} << 20;
  /// Bytes of a mesh or patch file (hfMesh, hfBezierSurface); other than regular files
  /// (devices such as /dev/zero, pipes) are refused.
  int64_t max_mesh_bytes = int64_t{256} << 20;
  /// Triangles, and vertices, of one mesh; for patches, their tessellation's triangles.
  int64_t max_mesh_triangles = 10'000'000;
  /// Open border curves of a patch set up to which its field is exact (no tessellation);
  /// beyond, it goes through a tessellation (faster, off by its measured error), not an error.
  int64_t max_exact_curves = 64;
};

/// "" when every limit is in range, else what is wrong ("max_slots must be at least 1 (got
/// 0)"); Model::compile reports the same as CompileResult::error.
std::string check_model_limits(const ModelLimits& limits);

struct ModelOptions {
  std::string object;  ///< object to evaluate; empty: `my_model`, else the first
  Backend backend = Backend::kJit;
  int opt_level = 2;  ///< LLVM pipeline O0..O3 (JIT backend)
  int lanes = 0;      ///< JIT SIMD lanes per block (power of two); 0 = host width
  /// Precisions the JIT compiles inside compile(); the others compile on first use. (An eager
  /// f32 compile of a large object of exact arithmetic starts in the background instead:
  /// background_point_min_insts.)
  bool eager_f64 = true;
  bool eager_f32 = false;
  /// The interval evaluator is compiled by the JIT only for objects whose weight
  /// (ModelStats::domain_jit_weight: IR instructions, a dynamic table or array access
  /// counting one per element) is at most this; heavier ones use the tape VM (jit/tape_vm.h)
  /// when the object has a tape form (straight-line code), else the interval interpreter.
  /// The interval JIT's compile time grows faster than linearly with the weight (about 100 s
  /// for the 14k-instruction `prospero` corpus model, and as much for a 337-instruction model
  /// with 30 noise-table loads) while the interpreter starts at once: below the threshold the
  /// JIT pays for itself within one render, above it the compile would dominate. Raise it when
  /// the domain JITs compile faster; -1 means always the JIT, 0 never (the tape VM or the
  /// interpreter).
  /// (JIT backend only.)
  int interval_jit_max_insts = 2000;
  /// The same for the gradient evaluator.
  int gradient_jit_max_insts = 2000;
  /// Model::start_interval_compile compiles the interval JIT in the background (the tape VM
  /// answering until it is ready) for objects of at least this many IR instructions; -1:
  /// never. Measured on 2 cores (bench/README.md, "Interval code compiled in the
  /// background"): a 551-instruction model's render, whose interval compile takes 0.4-0.5 s,
  /// starts ~0.3 s sooner and ends ~0.35 s sooner; c1_gear (255 instructions, 0.27 s of
  /// interval compile for a 0.26 s render) gains nothing, since the render threads and the
  /// compile then share the two cores and the tape VM's boxes cost more than the JIT's.
  int background_interval_min_insts = 500;
  /// The same for Model::start_gradient_compile: the gradient JIT compiles in the background
  /// (the tape VM's gradient pass answering with the same bits until it is ready) for objects
  /// of at least this many IR instructions whose tape has a gradient form
  /// (TapeVm::is_exact: straight-line exact arithmetic); -1: never. A 993-instruction
  /// model's f32 gradient compile takes ~130-150 ms on 2 cores (bench/README.md, "The compile
  /// time of a 1000-instruction model").
  int background_gradient_min_insts = 500;
  /// The same for the f32 point code (Model::start_point_compile, and eager_f32 inside
  /// compile()): for an object of at least this many instructions whose tape is exact
  /// arithmetic, the f32 JIT compiles in the background while the tape VM's float pass answers
  /// eval_batch (f32, without attributes) with the same bits; -1: never. With the interval and
  /// gradient code also in the background, a render or a mesh of such an object starts without
  /// waiting for any LLVM compile (a 993-instruction model: ~45 ms of f32 compile on 2 cores).
  int background_point_min_insts = 500;
  /// Boxes per SIMD block of the interval JIT (a power of two; 0 = the host's f64 width).
  /// The host's width by default: a block costs about the same at 1 and 8 lanes (s3_blend:
  /// 133 ns and 143 ns), so batches of boxes (the renderer's) go up to 8x faster, and a single
  /// box costs no more (the libm-based ops, run lane by lane, compute a padded copy once).
  int interval_lanes = 0;
  /// Compile the numbers of the source that only feed arithmetic as hidden parameters
  /// (jit::hoist_constants): the code then serves every source that differs from this one
  /// only in such numbers, and Model::share_code lets a model compiled from an edited
  /// source reuse another's code instead of compiling its own (the REPL: an edit of a radius
  /// costs no JIT compile). The same values as without it, bit for bit.
  bool hoist_constants = false;
  /// Limits on hostile input (docs/limits.md).
  ModelLimits limits;
};

/// One compile-time diagnostic (error, warning or note), located in the source.
struct SourceDiagnostic {
  enum class Severity { kError, kWarning, kNote };
  Severity severity = Severity::kError;
  std::string file;
  int line = 0;  ///< 1-based; 0 when the diagnostic has no location
  int col = 0;   ///< 1-based byte column
  int length = 0;
  std::string message;
  std::string hint;  ///< how to fix it (may be empty)
};

/// The value at one point. When a run-time error happened (division by zero, ...), `f` and
/// `s` are NaN and `error` holds the message of the first error with its location.
struct PointValue {
  double f = 0;
  std::vector<double> s;
  std::string error;  ///< e.g. "Division by zero"; empty when the point has a value
  int error_line = 0;
  int error_col = 0;
  bool ok() const { return error.empty(); }
};

/// An enclosure of F over a box: every value the f64 scalar evaluator computes at a point of
/// the box is in [lo, hi], or is NaN (no value: a run-time error) and then `maybe_nan` is
/// set. Outward rounding: the enclosure is sound, not tight (it may be [-inf, inf]).
struct IntervalValue {
  double lo = 0;
  double hi = 0;
  bool maybe_nan = false;
  bool contains(double v) const { return v != v ? maybe_nan : (lo <= v && v <= hi); }
};

/// F and its gradient at a point, by forward-mode automatic differentiation (exact chain
/// rule, not finite differences). `f` is the scalar evaluator's value; where F is not
/// differentiable the derivative is the one-sided one of the branch taken (abs, min/max,
/// if). A point without a value (run-time error) has NaN in all four.
struct GradientValue {
  double f = 0;
  double d[3] = {0, 0, 0};  ///< dF/dx[1], dF/dx[2], dF/dx[3] (0 beyond num_inputs)
};

/// Which implementation evaluates a domain (interval or gradient) of a Model.
enum class DomainEngine {
  kJit,     ///< LLVM code, compiled on first use
  kInterp,  ///< the interpreter (backend kInterp, a large object, or a failed JIT compile)
  /// The tape VM (jit/tape_vm.h), in place of the interpreter for an object above
  /// ModelOptions::interval_jit_max_insts / gradient_jit_max_insts (or whose JIT failed) that
  /// has a tape form (for gradients: one of exact arithmetic, TapeVm::is_exact).
  kTapeVm,
};

/// One mesh or patch surface of the object (hfMesh, hfTriangles, hfBezierSurface,
/// hfBezierPatches), for `hfrt render --stats`.
struct SurfaceStats {
  std::string source;    ///< the file, or the inline function's name
  size_t triangles = 0;  ///< triangles (for patches: of the field's tessellation, if any)
  size_t patches = 0;
  size_t pieces = 0;           ///< patches: the flat pieces rays are solved in
  size_t boundary_curves = 0;  ///< patches: its open border curves (exact field asked for)
  bool exact_field = false;    ///< patches: the field from the patches, no tessellation
  size_t degenerate_skipped = 0;
  size_t bvh_nodes = 0;
  int bvh_depth = 0;
  double build_seconds = 0;
  size_t memory_bytes = 0;
  /// How many leaves of the object use this one loaded surface (> 1: instancing).
  int leaves = 0;
  /// Meshes: whether every edge pairs with its reverse (geom::SurfaceTopology), and how many
  /// directed edges do not. Patches are never closed (their seams are not watertight) and
  /// their edges are not counted.
  bool closed = false;
  size_t boundary_edges = 0;
  /// Patches: the border curves in cracks sealed (PatchSurface::Options::seal_tolerance),
  /// and the widest sealed crack measured.
  size_t sealed_curves = 0;
  double crack_gap = 0;
};

/// A mesh leaf of the analytic root search's skeleton whose mesh is not closed: inside and
/// outside then come from a winding number at every ray candidate instead of from the ray's
/// crossings (Model::open_surface_leaves).
struct OpenSurfaceLeaf {
  std::string source;         ///< the mesh file, or the inline function's name
  size_t boundary_edges = 0;  ///< directed edges without their opposite partner
  int line = 0, col = 0;      ///< the leaf's call in the source (1-based; 0 when unknown)
};

/// Compile-latency figures, in milliseconds.
struct ModelStats {
  double frontend_ms = 0;  ///< parse + semantic checks
  double lower_ms = 0;     ///< AST -> hfrt IR
  int ir_insts = 0;
  /// The weight that ModelOptions::interval_jit_max_insts / gradient_jit_max_insts compare.
  int64_t domain_jit_weight = 0;
  struct Jit {
    bool compiled = false;
    /// (f32) Compiled, or being compiled, on a thread of its own while the tape VM answered
    /// (Model::start_point_compile).
    bool background = false;
    int lanes = 0;
    double emit_ms = 0, optimize_ms = 0, codegen_ms = 0;
    size_t llvm_insts_before = 0, llvm_insts_after = 0;
    size_t llvm_calls = 0;      ///< calls in the emitted code's busiest function (one per lane)
    bool fast_codegen = false;  ///< compiled without machine optimisation (too many calls)
  };
  Jit jit_f64, jit_f32;
  /// The interval and gradient JITs, once compiled (their compile time in total).
  struct Domain {
    bool compiled = false;
    int lanes = 0;
    double compile_ms = 0;
    /// Compiled (or, while !compiled, being compiled) on a thread of its own while another
    /// engine answered (Model::start_interval_compile, Model::start_gradient_compile).
    bool background = false;
  };
  Domain interval, gradient_f64, gradient_f32;
  /// The polynomial JIT (analytic ray tracing), once compiled on the first ray_polynomials.
  Domain polynomial;
};

/// Whether the object can be ray traced by analytic roots (docs/api.md, docs/rendering.md):
/// F is a set-operation skeleton (min, max, unary minus, the R-function operators |, &, \, `if` on
/// constants) over leaves that are polynomials of degree <= 4 in x along any ray (x entering
/// affinely), or library primitives with an algebraic zero set (hfTorusX/Y/Z, hfBlock, ...:
/// a leaf A + B sqrt(C) is replaced by A^2 - B^2 C, which has the same zeros and maybe more).
struct AnalyticInfo {
  bool qualifies = false;
  int num_leaves = 0;  ///< polynomial leaves (ray_polynomials)
  int max_degree = 0;  ///< the highest leaf degree along a ray (<= 4)
  /// Mesh and patch leaves (hfMesh, ... under x or an affine map of x) whose crossings with a
  /// ray are candidates too (ray_surface_crossings).
  int num_surface_leaves = 0;
  /// When it does not qualify: the first construct that is not polynomial or not a set
  /// operation ("'sqrt' is not a polynomial", "division by a variable", "'hfBlendUni' is not
  /// a set operation nor a polynomial (...)") and its 1-based location (0 when unknown).
  std::string reason;
  int line = 0, col = 0;
};

struct CompileResult;

/// A compiled HyperFun object. Evaluation is const and thread-safe (many threads may call
/// eval/eval_batch at once); select_object/set_params are not (call them before sharing).
class Model {
 public:
  /// Compiles source text. `name` is the file name used in diagnostics.
  static CompileResult compile(std::string_view source, const ModelOptions& options = {},
                               std::string name = "<input>");
  /// Reads and compiles a file.
  static CompileResult compile_file(const std::string& path, const ModelOptions& options = {});

  Model(Model&&) noexcept;
  Model& operator=(Model&&) noexcept;
  ~Model();

  /// Names of every object in the file, and the one evaluated.
  std::vector<std::string> object_names() const;
  const std::string& object_name() const;
  /// Where the evaluated object's name stands in its definition's header (1-based line and
  /// byte column; 0, 0 when unknown): the place that messages about the object as a whole,
  /// such as `hfrt mesh`'s "no surface in the box", point at.
  std::pair<int, int> object_location() const;
  /// Switches to another object (re-lowers it and recompiles; the old code is freed).
  /// Returns false and leaves the model as it was when there is no such object or the JIT
  /// fails; `error` says why.
  bool select_object(std::string_view name, std::string* error = nullptr);

  /// Identifies the compiled code: equal for two models compiled with the same options from
  /// objects that differ at most in hoisted numbers (ModelOptions::hoist_constants).
  const std::string& code_key() const;
  /// Makes this model use `other`'s code, compiled or still to be compiled, in every domain,
  /// when their code_key() is equal; this model keeps its own numbers and parameters. Returns
  /// false (and changes nothing) when the keys differ. Not thread-safe, like set_params.
  bool share_code(const Model& other);
  /// True when this model runs code compiled for another (share_code): its JIT statistics
  /// are that compile's.
  bool shares_code() const;

  Backend backend() const;
  int num_inputs() const;      ///< x size of the object's header
  int num_params() const;      ///< a size
  int num_attributes() const;  ///< s size (0 without s)

  /// Parameter values a[1..]; missing ones are 0 (the default is all zeros).
  void set_params(std::vector<double> a);
  const std::vector<double>& params() const;

  /// Time: the value of x[4] for the evaluators that take points or rays in three
  /// coordinates (ray_polynomials, ray_surface_crossings; and the renderer and mesher, which
  /// pack x[4] = time() into the points they pass). Default 0, the original tools'
  /// convention for coordinates beyond the third; x[5..] stay 0. Calls that take all
  /// num_inputs() coordinates (eval, eval_batch, ...) use theirs. A number, never a recompile:
  /// set it per frame. Not thread-safe, like set_params.
  void set_time(double t);
  double time() const;

  /// Evaluates one point; missing coordinates are 0, extra ones are ignored. With the JIT
  /// backend a point whose value is NaN because of a run-time error is evaluated again by
  /// the interpreter to fill `error` with the message and location.
  PointValue eval(std::span<const double> x) const;
  PointValue eval(std::initializer_list<double> x) const {
    return eval(std::span<const double>(x.begin(), x.size()));
  }

  /// Evaluates n points, structure of arrays: x[k+1] of point i is xs[k*n + i] for
  /// k < num_inputs(); F goes to out_f[i], s[k+1] to out_s[k*n + i] (out_s may be null).
  /// Points with a run-time error get NaN (use eval() for the message).
  void eval_batch(int64_t n, const double* xs, double* out_f, double* out_s = nullptr) const;
  void eval_batch(int64_t n, const float* xs, float* out_f, float* out_s = nullptr) const;

  // --- The interval domain ----------------------------------------------------------------
  // Engine: the JIT (compiled lazily, on the first interval call or prepare_interval(), by
  // whichever thread comes first while the others wait) unless the backend is kInterp or
  // the object has more than ModelOptions::interval_jit_max_insts IR instructions; then the
  // tape VM (DomainEngine::kTapeVm: the object's straight-line tape, its batched pass for
  // eval_interval_batch, ~15x the interpreter's boxes per second on prospero) or, for an
  // object with control flow, tables or surfaces (and for calls that ask for the trace of
  // choices), the interval interpreter (a pool of instances, one per concurrent caller). All
  // give the same results. Const and thread-safe like eval().

  /// F over the box x[k+1] in [lo[k], hi[k]] (missing coordinates are the point 0; lo <= hi).
  /// When `choices` is non-null it receives the min/max/select trace: one byte per IR
  /// instruction of ir_text() (kChoice bits: 1 = the left operand / then-value decides
  /// somewhere in the box, 2 = the right one, 0 = not a min/max/select or not reached), so
  /// that a caller can prune the program for the box (libfive / fidget style).
  IntervalValue eval_interval(std::span<const double> lo, std::span<const double> hi,
                              std::vector<uint8_t>* choices = nullptr) const;
  IntervalValue eval_interval(std::initializer_list<double> lo,
                              std::initializer_list<double> hi) const {
    return eval_interval(std::span<const double>(lo.begin(), lo.size()),
                         std::span<const double>(hi.begin(), hi.size()));
  }
  /// n boxes, structure of arrays: coordinate k of box i is [lo[k*n + i], hi[k*n + i]] for
  /// k < num_inputs(). Results to out_lo/out_hi and out_nan (0 or 1). `choices`, when
  /// non-null, has ir_insts bytes and gets the trace bits OR-ed over all n boxes.
  void eval_interval_batch(int64_t n, const double* lo, const double* hi, double* out_lo,
                           double* out_hi, uint8_t* out_nan, uint8_t* choices = nullptr) const;

  // --- The gradient domain ----------------------------------------------------------------
  // Engine: the gradient JIT of the precision (lazily compiled, like the scalar one) unless
  // the backend is kInterp or the object has more than gradient_jit_max_insts instructions;
  // then the tape VM's gradient pass in the precision when the object's tape has a gradient
  // form (TapeVm::is_exact), else the gradient interpreter (f64; f32 batches are
  // converted).

  /// F and dF/dx[1..3] at one point, in f64 (missing coordinates are 0).
  GradientValue eval_gradient(std::span<const double> x) const;
  GradientValue eval_gradient(std::initializer_list<double> x) const {
    return eval_gradient(std::span<const double>(x.begin(), x.size()));
  }
  /// n points, structure of arrays as eval_batch; out[c*n + i] gets F (c = 0) and dF/dx[c]
  /// (c = 1..3). A point without a value gets NaN in all four.
  void eval_gradient_batch(int64_t n, const double* xs, double* out) const;
  void eval_gradient_batch(int64_t n, const float* xs, float* out) const;

  /// Which engine evaluates intervals / gradients of the precision (never compiles).
  DomainEngine interval_engine() const;
  DomainEngine gradient_engine(Precision precision = Precision::kF64) const;
  /// Compiles the interval / gradient JIT now instead of on first use (no-op with the
  /// interpreter engine). False (with `error`) when the JIT fails; evaluation then uses
  /// the interpreter.
  bool prepare_interval(std::string* error = nullptr) const;
  bool prepare_gradient(Precision precision, std::string* error = nullptr) const;
  /// Starts the interval JIT's compile on a thread of its own and returns at once, for an
  /// object of at least ModelOptions::background_interval_min_insts instructions with a
  /// tape form. Until the code is ready, intervals come from the tape VM (or, for a trace of
  /// choices, the interval interpreter), whose results are the JIT's bit for bit: a caller's
  /// decisions do not depend on which engine answered. interval_engine() says kJit meanwhile.
  /// False when nothing was started (the JIT is not wanted, is compiled already, or the
  /// object is small or has no tape form): prepare_interval() then compiles as usual. The
  /// Model's (last sharer's) destructor waits for the compile.
  bool start_interval_compile() const;

  /// The same for the f32 point code (ModelOptions::background_point_min_insts): until it is
  /// ready, f32 eval_batch without attributes answers from the tape VM's float pass with the
  /// JIT's bits (an exact tape: TapeVm::is_exact); calls that ask for attributes, and
  /// prepare(kF32), wait for it. compile() with eager_f32 starts it so for such an object.
  /// False when nothing was started (compiled already, the interpreter backend, a small object
  /// or one whose tape is not exact arithmetic): prepare(kF32) then compiles as usual.
  bool start_point_compile() const;

  /// The same for the gradient JIT of a precision (ModelOptions::background_gradient_min_insts):
  /// until its code is ready, gradients come from the tape VM's gradient pass, the JIT's bits
  /// (TapeVm::eval_gradient); gradient_engine() says kJit meanwhile. False when nothing was
  /// started (the JIT is not wanted, is compiled already, or the object is small or its tape
  /// has ops the gradient pass does not run): prepare_gradient() then compiles as usual.
  bool start_gradient_compile(Precision precision) const;

  /// Compiles the JIT code of a precision now instead of on first use. Returns false (with
  /// `error`) when the JIT fails; evaluation then falls back to the interpreter.
  bool prepare(Precision precision, std::string* error = nullptr) const;

  // --- The polynomial domain (analytic ray tracing) -----------------------------------------

  /// The compile-time analysis of the object (computed once, on first call; thread-safe).
  AnalyticInfo analytic_info() const;
  /// For the ray x = o + t d: the coefficients of every leaf, out[5*i + k] = coefficient of
  /// t^k of leaf i (analytic_info().num_leaves * 5 doubles). F's zero crossings along the ray
  /// are among the leaves' real roots. Requires analytic_info().qualifies. Const and
  /// thread-safe. Engine: the polynomial JIT with the JIT backend (compiled on the first
  /// call, like the other domains; the interpreter when that compile fails), else the
  /// reference polynomial interpreter; both give the same values.
  void ray_polynomials(const double o[3], const double d[3], double* out) const;
  /// Compiles the polynomial JIT now instead of on the first ray_polynomials call (no-op with
  /// the interpreter backend or an object that does not qualify). False (with `error`) when
  /// the JIT fails; ray_polynomials then uses the interpreter.
  bool prepare_polynomial(std::string* error = nullptr) const;
  /// For the ray x = o + t d: appends to `out` every t in (t0, t1) where a mesh or patch leaf
  /// of the skeleton (AnalyticInfo::num_surface_leaves) crosses its surface; the ray is
  /// mapped into the leaf's own space by the leaf's affine map (t is unchanged). With
  /// ray_polynomials' roots these are all the places where F may change sign. Requires
  /// analytic_info().qualifies. Const and thread-safe.
  /// The mesh leaves (not patches) on the analytic skeleton whose meshes are not closed, in
  /// the order of the skeleton: what `hfrt render` warns about, with their locations. Empty
  /// when the object does not qualify.
  std::vector<OpenSurfaceLeaf> open_surface_leaves() const;

  void ray_surface_crossings(const double o[3], const double d[3], double t0, double t1,
                             std::vector<double>* out) const;
  /// Traces the mesh and patch leaves' crossings of n rays o + t d, t in [t0, t1], ahead, all
  /// rays of a surface together (meshes in packets of eight: coherent rays such as a tile's
  /// camera rays share their BVH nodes and triangles), on this thread: the calls of
  /// ray_surface_crossings that follow for the same rays and segments, in the same order (some
  /// may be skipped), take them from there, with the same results. o and d hold 3 n values.
  /// Replaces this thread's earlier prefetch.
  void prefetch_ray_surface_crossings(const double* o, const double* d, const double* t0,
                                      const double* t1, size_t n) const;
  /// Forgets this thread's prefetched crossings (prefetch_ray_surface_crossings).
  static void clear_prefetched_surface_crossings();

  /// The mesh and patch surfaces of the object (empty for most models).
  std::vector<SurfaceStats> surface_stats() const;
  /// Like the f32 eval_batch (no attributes), except that each mesh or patch leaf gives +1
  /// inside and -1 outside instead of its signed distance: the winding number without the
  /// distance query, several times cheaper. When analytic_info().qualifies, F's sign is a
  /// function of the leaves' signs (set operations), so these values have exactly F's sign
  /// (what the analytic root search samples). Without mesh or patch leaves, or with the
  /// interpreter backend, this is eval_batch. The JIT code is compiled on first use.
  void eval_batch_sign(int64_t n, const float* xs, float* out_f) const;

  /// The object's hfrt IR as text (`hfrt ir`).
  std::string ir_text() const;

  // --- The GPU path (docs/gpu.md) ---
  /// The object's kernels for NVIDIA GPUs (gpu/kernel_abi.h: the point evaluator and the ray
  /// caster) as PTX text for architecture `sm` ("sm_60": any GPU since Pascal, the driver
  /// compiles it for newer ones), made by LLVM's NVPTX back end from the same IR as the CPU
  /// code. False with `error` when the object cannot run on the GPU (mesh and patch leaves)
  /// or LLVM lacks the NVPTX back end.
  /// With `eval_only`, only the point evaluator (kEvalEntry): smaller PTX, a quicker build.
  bool device_ptx(std::string* ptx, std::string* error, const std::string& sm = "sm_60",
                  bool eval_only = false) const;
  /// The same kernels (the same LLVM code) compiled for this CPU: what the GPU computes,
  /// without a GPU (tests, the device check's expectations, `--device cuda-host`). Null with
  /// `error` as for device_ptx. Each call compiles anew.
  std::shared_ptr<const jit::HostKernels> device_kernels_on_host(std::string* error) const;
  /// The object as a tape for the pruning VMs (jit/tape.h, docs/tape_vm.md), with the current
  /// parameters and hoisted numbers as constants; null, with `why` (when given) saying what
  /// tapes do not support, for objects with control flow, tables or mesh/patch leaves. Each
  /// call builds anew (rebuild after set_params); the tape does not refer to the model.
  /// Shared and const, as device_kernels_on_host: the caller does not need jit/tape.h to hold
  /// or drop it (the deleter is captured where it is built).
  std::shared_ptr<const jit::Tape> tape(std::string* why = nullptr) const;
  /// a[] as the compiled code and the kernels take it: the parameters padded to the object's
  /// count, then the hoisted numbers.
  std::vector<float> code_params_f32() const;
  /// The optimised LLVM IR of a precision ("" for the interpreter backend): compiled again for
  /// the text, which the evaluators do not keep (a debugging aid).
  std::string llvm_ir(Precision precision) const;
  /// Warnings of the compilation (also in CompileResult::diagnostics).
  const std::vector<SourceDiagnostic>& warnings() const;
  ModelStats stats() const;

 private:
  struct Impl;
  explicit Model(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// What Model::compile returns: a model, or the reasons there is none. `diagnostics` also
/// holds the warnings of a successful compilation.
struct CompileResult {
  std::optional<Model> model;
  std::vector<SourceDiagnostic> diagnostics;
  std::string rendered;  ///< all diagnostics as text (`file:line:col: error: ...` + source)
  std::string error;     ///< an environment failure (unreadable file, JIT unavailable), or ""
  bool ok() const { return model.has_value(); }
};

}  // namespace hfrt
