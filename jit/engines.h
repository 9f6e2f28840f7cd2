#pragma once
// The evaluators of one lowered object, one engine per arithmetic domain (Fidget's
// one-evaluator-per-arithmetic-type shape): each engine owns its choice between LLVM code
// (compiled at most once, on first use or eagerly, then shared read-only by all threads) and
// the reference interpreter (the interpreter backend, a large object, or a failed compile),
// so that hfrt::Model (model.cpp) only forwards. Internal to jit/: embedders see hfrt/model.h.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "base/interval.h"
#include "base/once.h"
#include "base/timer.h"
#include "ir/ir.h"
#include "jit/gradient.h"
#include "jit/interpreter.h"
#include "jit/interval.h"
#include "jit/llvm_jit.h"
#include "jit/poly.h"
#include "jit/tape.h"
#include "jit/tape_vm.h"

namespace hfrt::jit {

using namespace ::hfrt::ir;

/// Instances of a stateful evaluator (the interval and gradient interpreters own their
/// scratch memory, so one instance serves one thread at a time). A caller leases one and gives
/// it back; the pool grows to the largest number of concurrent callers seen.
template <typename T>
class Pool {
 public:
  class Lease {
   public:
    Lease(Pool* pool, std::unique_ptr<T> item) : pool_(pool), item_(std::move(item)) {}
    Lease(Lease&&) = default;
    ~Lease() {
      if (item_) pool_->give_back(std::move(item_));
    }
    T* operator->() const { return item_.get(); }

   private:
    Pool* pool_;
    std::unique_ptr<T> item_;
  };

  explicit Pool(const Function& fn) : fn_(fn) {}

  Lease take() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!free_.empty()) {
        std::unique_ptr<T> item = std::move(free_.back());
        free_.pop_back();
        return Lease(this, std::move(item));
      }
    }
    return Lease(this, std::make_unique<T>(fn_));
  }

 private:
  void give_back(std::unique_ptr<T> item) {
    std::lock_guard<std::mutex> lock(mutex_);
    free_.push_back(std::move(item));
  }

  const Function& fn_;
  std::mutex mutex_;
  std::vector<std::unique_ptr<T>> free_;
};

/// Lazily compiled code: compiled at most once, by the first thread that needs it (the others
/// wait for it), then shared read-only. `state` lets readers that must not compile (stats,
/// engine queries) look without a data race.
template <typename Code>
struct LazySlot {
  SettledOnce once;
  std::unique_ptr<Code> code;
  std::string error;
  double compile_ms = 0;
  std::atomic<int> state{0};  ///< 0 not compiled yet, 1 compiled, 2 failed

  template <typename Compile>
  const Code* get(Compile&& compile) {
    once.call([&] {
      const auto t0 = Clock::now();
      auto r = compile();
      compile_ms = ms_since(t0);
      if (r.ok()) {
        code = std::move(r.value());
        state.store(1, std::memory_order_release);
      } else {
        error = r.error().message;
        state.store(2, std::memory_order_release);
      }
    });
    return code.get();
  }
  /// The code if it is compiled already (never compiles).
  const Code* peek() const {
    return state.load(std::memory_order_acquire) == 1 ? code.get() : nullptr;
  }
};

/// The object's tape (jit/tape.h) for a parameter vector, built on first use and again when
/// the parameters change, shared by the interval and gradient engines (the tape VM answers for
/// them). Render threads read it on every call without a lock: the entry is swapped whole; a
/// build takes the mutex.
class TapeCache {
 public:
  explicit TapeCache(const Function& fn) : fn_(fn) {}
  /// The tape for `a`, or null when the object has no tape form.
  std::shared_ptr<const Tape> get(const std::vector<double>& a) const;
  /// Whether the object's tape is exact arithmetic (TapeVm::is_exact: the VM's point and
  /// gradient passes give the JITs' bits); false without a tape form.
  bool is_exact(const std::vector<double>& a) const;

 private:
  struct Entry {
    std::vector<double> params;
    std::shared_ptr<const Tape> tape;  ///< null: no tape form
    bool exact = false;                ///< TapeVm::is_exact(*tape)
  };
  std::shared_ptr<const Entry> entry(const std::vector<double>& a) const;
  const Function& fn_;
  mutable std::mutex mutex_;
  mutable std::atomic<std::shared_ptr<const Entry>> entry_;
};

/// A JIT compile on a thread of its own (the engines' compile_in_background): started at
/// most once; the destructor waits for it (the code it compiles refers to the engine).
class BackgroundCompile {
 public:
  BackgroundCompile() = default;
  BackgroundCompile(const BackgroundCompile&) = delete;
  BackgroundCompile& operator=(const BackgroundCompile&) = delete;
  ~BackgroundCompile();
  /// Starts `compile` on a new thread if nothing was started yet and `eligible()` (asked
  /// under the lock, so two callers cannot both start one) says so. True when a compile was
  /// started, now or before.
  bool start(const std::function<bool()>& eligible, std::function<void()> compile);
  bool started() const { return started_.load(std::memory_order_acquire); }

 private:
  std::mutex mutex_;
  std::thread thread_;
  std::atomic<bool> started_{false};
};

/// How an object's engines are built (from ModelOptions and the object's size).
struct EngineOptions {
  bool use_jit = true;  ///< false: the interpreter backend, every domain interpreted
  int opt_level = 2;
  int lanes = 0;              ///< scalar JIT lanes (0: host width)
  int interval_lanes = 0;     ///< interval JIT lanes (0: host width)
  bool interval_jit = false;  ///< the interval domain uses the JIT (else the interpreter)
  bool gradient_jit = false;  ///< the gradient domain uses the JIT
  /// IntervalEngine::compile_in_background starts nothing below this many IR instructions
  /// (-1: never): ModelOptions::background_interval_min_insts.
  int background_interval_min_insts = -1;
  /// The same for GradientEngine::compile_in_background:
  /// ModelOptions::background_gradient_min_insts.
  int background_gradient_min_insts = -1;
  /// The same for ScalarEngine::compile_in_background_f32:
  /// ModelOptions::background_point_min_insts.
  int background_point_min_insts = -1;
};

/// The scalar domain: F and s[] at points, f64 and f32.
class ScalarEngine {
 public:
  /// `tapes`: the object's tapes (outlives the engine).
  ScalarEngine(const Function& fn, const EngineOptions& options, const TapeCache* tapes);
  /// As IntervalEngine::compile_in_background, for the f32 code: starts its compile on a
  /// thread of its own when the JIT is used and the code is not compiled yet, the object has
  /// at least EngineOptions::background_point_min_insts instructions and an exact tape
  /// (TapeVm::is_exact). Until the code is ready the f32 eval_batch answers from the tape
  /// VM's float pass with the JIT's bits (calls that ask for attributes s[] wait for the
  /// code). True when a compile was started (now or before).
  bool compile_in_background_f32(const std::vector<double>& a) const;
  bool background_f32() const { return background_.started(); }
  /// The JIT code of a precision (compiled on first use), or null: interpreter backend or
  /// failed compile (error() says why).
  const JitFunction* code(Precision p) const;
  /// The code if already compiled (never compiles; for statistics).
  const JitFunction* peek(Precision p) const { return jit_[index(p)].peek(); }
  const std::string& error(Precision p) const { return jit_[index(p)].error; }
  /// The LLVM IR text of the code of a precision: a compile of its own with
  /// JitOptions::keep_llvm_ir (the evaluators' compiles keep none). Empty on failure.
  std::string llvm_ir(Precision p) const;
  /// The reference interpreter (also explains the NaN of a JIT result: the error and where).
  const Interpreter& interpreter() const { return *interp_; }
  /// n points, structure of arrays (hfrt::Model::eval_batch). `a64`/`a32`: the parameters.
  void eval_batch(int64_t n, const double* xs, const std::vector<double>& a64, double* out_f,
                  double* out_s) const;
  void eval_batch(int64_t n, const float* xs, const std::vector<float>& a32,
                  const std::vector<double>& a64, float* out_f, float* out_s) const;
  /// Like the f32 eval_batch but mesh and patch leaves give +1/-1 (Model::eval_batch_sign).
  void eval_batch_sign(int64_t n, const float* xs, const std::vector<float>& a32,
                       const std::vector<double>& a64, float* out_f) const;

 private:
  static int index(Precision p) { return p == Precision::kF64 ? 0 : 1; }
  const Function& fn_;
  EngineOptions options_;
  const TapeCache* tapes_;
  std::unique_ptr<Interpreter> interp_;
  mutable LazySlot<JitFunction> jit_[2];
  /// f32 code with JitOptions::surface_sign_only.
  mutable LazySlot<JitFunction> sign_;
  /// Declared last: destroyed (joined) first, while the slot it compiles into still lives.
  mutable BackgroundCompile background_;
};

/// The interval domain: sound enclosures over boxes (jit/interval.h).
class IntervalEngine {
 public:
  /// `tapes`: the object's tapes (outlives the engine).
  IntervalEngine(const Function& fn, const EngineOptions& options, const TapeCache* tapes);
  /// The JIT, or null when the interpreter must be used (compiles on first call, or waits
  /// for the compile that compile_in_background() started).
  const IntervalJit* code() const;
  const IntervalJit* peek() const { return jit_.peek(); }
  bool uses_jit() const { return options_.interval_jit && jit_.state.load() != 2; }
  /// Starts the JIT's compile on a thread of its own and returns at once, when the JIT is
  /// wanted and not compiled yet, the object has at least
  /// EngineOptions::background_interval_min_insts instructions and a tape form (for the
  /// parameters `a`). Until the code is ready, eval() and eval_batch() take the tape VM (or,
  /// for a trace of choices, the interpreter): their intervals and traces are the JIT's bit
  /// for bit (all three are the interval interpreter's: tests/jit/interval_jit_test.cpp,
  /// tape_test.cpp), so whatever a caller decides from them does not depend on which one
  /// answered, nor on the machine's speed. A renderer thus starts at once instead of waiting
  /// for the slowest of the JITs (a 551-instruction model: 0.4-0.5 s). True when a compile was
  /// started (now or before).
  bool compile_in_background(const std::vector<double>& a) const;
  /// A compile was started by compile_in_background().
  bool background() const { return background_.started(); }
  /// The tape (jit/tape.h) that evaluates boxes in place of the interpreter when the JIT is
  /// wanted but not used (an object above ModelOptions::interval_jit_max_insts, or a failed
  /// compile): the tape VM's batched pass is ~15x the interpreter's boxes per second on
  /// prospero (hfrt_bench_interval); also while compile_in_background()'s compile runs. Null
  /// with the interpreter backend, while the JIT is used, or for an object without a tape
  /// form (control flow, tables, surfaces). Built for the parameters `a` on first use and
  /// again when they change.
  std::shared_ptr<const Tape> tape(const std::vector<double>& a) const;
  bool wants_jit() const { return options_.interval_jit; }
  const std::string& error() const { return jit_.error; }
  double compile_ms() const { return jit_.compile_ms; }
  /// One box (coordinates lo[k] <= hi[k] for every input; the caller pads).
  Interval eval(std::span<const double> lo, std::span<const double> hi,
                const std::vector<double>& a, std::vector<uint8_t>* choices) const;
  /// n boxes, structure of arrays (Model::eval_interval_batch).
  void eval_batch(int64_t n, const double* lo, const double* hi, const std::vector<double>& a,
                  double* out_lo, double* out_hi, uint8_t* out_nan, uint8_t* choices) const;

 private:
  /// The code the evaluations take now: code(), except while a background compile runs
  /// (then null: the tape VM or the interpreter answers).
  const IntervalJit* ready_code() const;
  const Function& fn_;
  EngineOptions options_;
  const TapeCache* tapes_;
  mutable LazySlot<IntervalJit> jit_;
  mutable Pool<IntervalInterpreter> pool_;
  /// Declared last: destroyed (joined) first, while the slot it compiles into still lives.
  mutable BackgroundCompile background_;
};

/// The gradient domain: F and dF/dx[1..3] by forward-mode AD (jit/gradient.h).
class GradientEngine {
 public:
  /// `tapes`: the object's tapes (outlives the engine).
  GradientEngine(const Function& fn, const EngineOptions& options, const TapeCache* tapes);
  const GradientJit* code(Precision p) const;
  const GradientJit* peek(Precision p) const { return jit_[index(p)].peek(); }
  bool uses_jit(Precision p) const {
    return options_.gradient_jit && jit_[index(p)].state.load() != 2;
  }
  bool wants_jit() const { return options_.gradient_jit; }
  /// As IntervalEngine::compile_in_background, for the JIT of precision `p`: starts its
  /// compile on a thread of its own when it is wanted and not compiled yet, the object has at
  /// least EngineOptions::background_gradient_min_insts instructions and a tape that the tape
  /// VM's gradient pass runs (TapeVm::is_exact). Until the code is ready the tape VM
  /// answers with the JIT's bits (TapeVm::eval_gradient), so a render or a mesh does not
  /// depend on which one did. True when a compile was started (now or before).
  bool compile_in_background(Precision p, const std::vector<double>& a) const;
  bool background(Precision p) const { return background_[index(p)].started(); }
  /// The tape that the tape VM evaluates in place of the JIT (while a background compile runs,
  /// or when the JIT is wanted but not used: an object above
  /// ModelOptions::gradient_jit_max_insts, a failed compile), or null: the JIT answers, the
  /// interpreter backend, or no tape with a gradient form (then the interpreter answers).
  std::shared_ptr<const Tape> tape(Precision p, const std::vector<double>& a) const;
  const std::string& error(Precision p) const { return jit_[index(p)].error; }
  double compile_ms(Precision p) const { return jit_[index(p)].compile_ms; }
  /// One point (padded to the object's inputs by the caller).
  Dual eval(std::span<const double> x, const std::vector<double>& a) const;
  void eval_batch(int64_t n, const double* xs, const std::vector<double>& a, double* out) const;
  void eval_batch(int64_t n, const float* xs, const std::vector<double>& a, float* out) const;

 private:
  static int index(Precision p) { return p == Precision::kF64 ? 0 : 1; }
  template <typename T>
  void interpret_batch(int64_t n, const T* xs, const std::vector<double>& a, T* out) const;
  /// n points through the tape VM's gradient pass on `tape` (inputs as eval_batch's).
  template <typename T>
  void vm_batch(const Tape& tape, int64_t n, const T* xs, T* out) const;
  template <typename T>
  void eval_batch_t(Precision p, int64_t n, const T* xs, const std::vector<double>& a,
                    T* out) const;
  /// code(p), except while a background compile runs (then null until it is ready).
  const GradientJit* ready_code(Precision p) const;
  const Function& fn_;
  EngineOptions options_;
  const TapeCache* tapes_;
  mutable LazySlot<GradientJit> jit_[2];
  mutable Pool<GradientInterpreter> pool_;
  /// Declared last: destroyed (joined) first, while the slots they compile into still live.
  mutable BackgroundCompile background_[2];
};

/// The polynomial domain (analytic ray tracing): the analysis, computed on first use, and the
/// coefficients of every leaf along a ray (jit/poly.h).
class PolyEngine {
 public:
  PolyEngine(const Function& fn, const EngineOptions& options);
  const PolyAnalysis& analysis() const;
  /// The JIT (one ray per call), or null: interpreter backend, an object that does not
  /// qualify, or a failed compile.
  const PolyJit* code() const;
  const PolyJit* peek() const { return jit_.peek(); }
  bool wants_jit() const { return options_.use_jit; }
  const std::string& error() const { return jit_.error; }
  double compile_ms() const { return jit_.compile_ms; }
  /// Every leaf's coefficients for the ray o + t d (analysis().program.leaves * kPolyCoeffs).
  void eval(const double o[3], const double d[3], const std::vector<double>& a, double* out) const;

 private:
  const Function& fn_;
  EngineOptions options_;
  mutable SettledOnce analysis_once_;  ///< sets analysis_ and interp_
  mutable PolyAnalysis analysis_;
  mutable std::unique_ptr<PolyInterpreter> interp_;
  mutable LazySlot<PolyJit> jit_;
};

}  // namespace hfrt::jit
