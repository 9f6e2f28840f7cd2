// The per-domain engines of one lowered object (engines.h).
#include "jit/engines.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <span>
#include <vector>

#include "base/check.h"

namespace hfrt::jit {

namespace {

/// The rows of a structure-of-arrays block (eval_batch's layout: input k of the n points at
/// xs + k n), as the tape VM takes its inputs; `rows` is the caller's scratch.
template <typename T>
std::span<const T* const> soa_rows(const T* xs, int num_inputs, int64_t n,
                                   std::vector<const T*>* rows) {
  rows->clear();
  for (int k = 0; k < num_inputs; ++k) rows->push_back(xs + size_t(k) * size_t(n));
  return *rows;
}

}  // namespace

// --- Scalar domain ----------------------------------------------------------------------------

ScalarEngine::ScalarEngine(const Function& fn, const EngineOptions& options, const TapeCache* tapes)
    : fn_(fn), options_(options), tapes_(tapes), interp_(std::make_unique<Interpreter>(fn)) {}

bool ScalarEngine::compile_in_background_f32(const std::vector<double>& a) const {
  if (!options_.use_jit || options_.background_point_min_insts < 0) return false;
  LazySlot<JitFunction>& slot = jit_[index(Precision::kF32)];
  return background_.start(
      [&] {
        return slot.state.load(std::memory_order_acquire) == 0 &&
               static_cast<int64_t>(fn_.insts.size()) >= options_.background_point_min_insts &&
               tapes_->is_exact(a);
      },
      [this] { code(Precision::kF32); });
}

std::string ScalarEngine::llvm_ir(Precision p) const {
  if (!options_.use_jit) return "";
  JitOptions options;
  options.opt_level = options_.opt_level;
  options.lanes = options_.lanes;
  options.keep_llvm_ir = true;
  auto code = JitFunction::compile(fn_, p, options);
  return code.ok() ? code.value()->llvm_ir() : "";
}

const JitFunction* ScalarEngine::code(Precision p) const {
  if (!options_.use_jit) return nullptr;
  return jit_[index(p)].get([&] {
    JitOptions options;
    options.opt_level = options_.opt_level;
    options.lanes = options_.lanes;
    return JitFunction::compile(fn_, p, options);
  });
}

namespace {
template <typename T>
void interp_batch(const Function& fn, const Interpreter& interp, const std::vector<double>& a,
                  int64_t n, const T* xs, T* out_f, T* out_s) {
  const int nx = fn.num_inputs;
  std::vector<double> x(static_cast<size_t>(std::max(nx, 0)));
  for (int64_t i = 0; i < n; ++i) {
    for (int k = 0; k < nx; ++k) x[k] = static_cast<double>(xs[k * n + i]);
    EvalResult r = interp.eval(x, a);
    out_f[i] = static_cast<T>(r.value);
    if (out_s) {
      for (size_t k = 0; k < fn.s_slots.size(); ++k) {
        double v = r.error ? std::nan("") : (k < r.s.size() ? r.s[k] : std::nan(""));
        out_s[k * n + i] = static_cast<T>(v);
      }
    }
  }
}
}  // namespace

void ScalarEngine::eval_batch(int64_t n, const double* xs, const std::vector<double>& a64,
                              double* out_f, double* out_s) const {
  if (const JitFunction* jit = code(Precision::kF64)) {
    jit->f64()(n, xs, a64.data(), out_f, out_s);
  } else {
    interp_batch(fn_, *interp_, a64, n, xs, out_f, out_s);
  }
}

void ScalarEngine::eval_batch(int64_t n, const float* xs, const std::vector<float>& a32,
                              const std::vector<double>& a64, float* out_f, float* out_s) const {
  // While a background compile runs: the tape VM's float pass, the JIT's bits (an exact tape;
  // attributes are not on the tape: such calls wait for the code below).
  if (background_.started() && !out_s && n > 0 && !jit_[index(Precision::kF32)].peek()) {
    if (std::shared_ptr<const Tape> t = tapes_->get(a64)) {
      thread_local TapeVm vm;
      thread_local std::vector<const float*> in;
      vm.eval<float>(*t, size_t(n), soa_rows(xs, fn_.num_inputs, n, &in), out_f);
      return;
    }
  }
  if (const JitFunction* jit = code(Precision::kF32)) {
    jit->f32()(n, xs, a32.data(), out_f, out_s);
  } else {
    interp_batch(fn_, *interp_, a64, n, xs, out_f, out_s);
  }
}

void ScalarEngine::eval_batch_sign(int64_t n, const float* xs, const std::vector<float>& a32,
                                   const std::vector<double>& a64, float* out_f) const {
  if (fn_.surfaces.empty() || !options_.use_jit) {
    eval_batch(n, xs, a32, a64, out_f, nullptr);
    return;
  }
  const JitFunction* jit = sign_.get([&] {
    JitOptions options;
    options.opt_level = options_.opt_level;
    // One lane: the caller (the analytic root search) passes a few points per call, and a
    // wide block would evaluate its padding lanes' winding numbers too, which dominate the
    // cost; the rest of the code is cheap next to them.
    options.lanes = 1;
    options.surface_sign_only = true;
    return JitFunction::compile(fn_, Precision::kF32, options);
  });
  if (!jit) {
    eval_batch(n, xs, a32, a64, out_f, nullptr);
    return;
  }
  jit->f32()(n, xs, a32.data(), out_f, nullptr);
}

// --- Tapes and background compiles -------------------------------------------------------------

std::shared_ptr<const TapeCache::Entry> TapeCache::entry(const std::vector<double>& a) const {
  std::shared_ptr<const Entry> e = entry_.load(std::memory_order_acquire);
  if (e && e->params == a) return e;
  std::lock_guard<std::mutex> lock(mutex_);
  e = entry_.load(std::memory_order_acquire);
  if (!e || e->params != a) {
    std::shared_ptr<const Tape> tape = Tape::build(fn_, a);
    const bool exact = tape && TapeVm::is_exact(*tape);
    e = std::make_shared<const Entry>(Entry{a, std::move(tape), exact});
    entry_.store(e, std::memory_order_release);
  }
  return e;
}

std::shared_ptr<const Tape> TapeCache::get(const std::vector<double>& a) const {
  return entry(a)->tape;
}

bool TapeCache::is_exact(const std::vector<double>& a) const {
  return entry(a)->exact;
}

BackgroundCompile::~BackgroundCompile() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (thread_.joinable()) thread_.join();
}

bool BackgroundCompile::start(const std::function<bool()>& eligible,
                              std::function<void()> compile) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (started_.load(std::memory_order_relaxed)) return true;
  if (!eligible()) return false;
  thread_ = std::thread(std::move(compile));
  started_.store(true, std::memory_order_release);
  return true;
}

// --- Interval domain --------------------------------------------------------------------------

IntervalEngine::IntervalEngine(const Function& fn, const EngineOptions& options,
                               const TapeCache* tapes)
    : fn_(fn), options_(options), tapes_(tapes), pool_(fn) {}

const IntervalJit* IntervalEngine::code() const {
  if (!options_.interval_jit) return nullptr;
  // (While a background compile runs, the slot's once makes this wait for it.)
  return jit_.get([&] {
    // O1: the interval code is large (three values per op, rounding); O2 buys little over
    // O1 and costs much compile time (see llvm_interval.cpp).
    IntervalJit::Options options;
    options.opt_level = std::min(options_.opt_level, 1);
    options.lanes = options_.interval_lanes;
    return IntervalJit::compile(fn_, options);
  });
}

const IntervalJit* IntervalEngine::ready_code() const {
  if (background_.started()) return jit_.peek();
  return code();
}

bool IntervalEngine::compile_in_background(const std::vector<double>& a) const {
  if (!options_.interval_jit || options_.background_interval_min_insts < 0) return false;
  return background_.start(
      [&] {
        return jit_.state.load(std::memory_order_acquire) == 0 &&  // not compiled nor failed
               static_cast<int64_t>(fn_.insts.size()) >= options_.background_interval_min_insts &&
               tapes_->get(a) != nullptr;  // else the interpreter answers: ~15x slower than the VM
      },
      [this] { code(); });
}

Interval IntervalEngine::eval(std::span<const double> lo, std::span<const double> hi,
                              const std::vector<double>& a, std::vector<uint8_t>* choices) const {
  const int nx = fn_.num_inputs;
  if (const IntervalJit* jit = ready_code()) {
    // One box: the JIT pads its SIMD block with copies of it (the per-lane helpers of the
    // libm-based ops compute a copy once), from the caller's buffers, so no call allocates.
    double out_lo = 0, out_hi = 0;
    uint8_t out_nan = 0;
    uint8_t* trace = nullptr;
    if (choices) {
      choices->assign(fn_.insts.size(), 0);
      trace = choices->data();
    }
    jit->eval(1, lo.data(), hi.data(), a, &out_lo, &out_hi, &out_nan, trace);
    return {out_lo, out_hi, out_nan != 0};
  }
  std::vector<Interval> box(static_cast<size_t>(std::max(nx, 0)), Interval{});
  for (int k = 0; k < nx; ++k) box[k] = Interval::of(lo[k], hi[k]);
  // The trace of choices is indexed by IR instruction, which only the interpreter records.
  if (!choices) {
    if (std::shared_ptr<const Tape> t = tape(a)) {
      thread_local TapeVm vm;
      return vm.eval_interval(*t, box);
    }
  }
  return pool_.take()->eval(box, a, choices);
}

std::shared_ptr<const Tape> IntervalEngine::tape(const std::vector<double>& a) const {
  if (!options_.use_jit) return nullptr;
  // The JIT answers once it is compiled, or (without a background compile) from the first
  // call on, when code() compiles it.
  if (background_.started() ? jit_.peek() != nullptr : uses_jit()) return nullptr;
  return tapes_->get(a);
}

void IntervalEngine::eval_batch(int64_t n, const double* lo, const double* hi,
                                const std::vector<double>& a, double* out_lo, double* out_hi,
                                uint8_t* out_nan, uint8_t* choices) const {
  const size_t ninsts = fn_.insts.size();
  if (choices) std::memset(choices, 0, ninsts);
  if (n <= 0) return;
  if (const IntervalJit* jit = ready_code()) {
    jit->eval(n, lo, hi, a, out_lo, out_hi, out_nan, choices);
    return;
  }
  const int nx = fn_.num_inputs;
  if (!choices) {
    if (std::shared_ptr<const Tape> t = tape(a)) {
      thread_local TapeVm vm;
      thread_local std::vector<const double*> in_lo, in_hi;
      vm.eval_intervals(*t, size_t(n), soa_rows(lo, nx, n, &in_lo), soa_rows(hi, nx, n, &in_hi),
                        out_lo, out_hi, out_nan);
      return;
    }
  }
  auto ii = pool_.take();
  std::vector<Interval> box(static_cast<size_t>(std::max(nx, 0)));
  std::vector<uint8_t> one;
  for (int64_t i = 0; i < n; ++i) {
    for (int k = 0; k < nx; ++k) box[k] = Interval::of(lo[k * n + i], hi[k * n + i]);
    Interval r = ii->eval(box, a, choices ? &one : nullptr);
    out_lo[i] = r.lo;
    out_hi[i] = r.hi;
    out_nan[i] = r.maybe_nan ? 1 : 0;
    if (choices) {
      for (size_t j = 0; j < ninsts && j < one.size(); ++j) choices[j] |= one[j];
    }
  }
}

// --- Gradient domain --------------------------------------------------------------------------

GradientEngine::GradientEngine(const Function& fn, const EngineOptions& options,
                               const TapeCache* tapes)
    : fn_(fn), options_(options), tapes_(tapes), pool_(fn) {}

const GradientJit* GradientEngine::code(Precision p) const {
  if (!options_.gradient_jit) return nullptr;
  return jit_[index(p)].get([&] {
    GradientJit::Options options;
    options.precision = p;
    options.opt_level = std::min(options_.opt_level, 1);
    return GradientJit::compile(fn_, options);
  });
}

const GradientJit* GradientEngine::ready_code(Precision p) const {
  if (background_[index(p)].started()) return jit_[index(p)].peek();
  return code(p);
}

bool GradientEngine::compile_in_background(Precision p, const std::vector<double>& a) const {
  if (!options_.gradient_jit || options_.background_gradient_min_insts < 0) return false;
  return background_[index(p)].start(
      [&] {
        return jit_[index(p)].state.load(std::memory_order_acquire) == 0 &&
               static_cast<int64_t>(fn_.insts.size()) >= options_.background_gradient_min_insts &&
               tapes_->is_exact(a);  // else the interpreter would answer: far slower
      },
      [this, p] { code(p); });
}

std::shared_ptr<const Tape> GradientEngine::tape(Precision p, const std::vector<double>& a) const {
  if (!options_.use_jit) return nullptr;
  if (background_[index(p)].started() ? jit_[index(p)].peek() != nullptr : uses_jit(p)) {
    return nullptr;
  }
  return tapes_->is_exact(a) ? tapes_->get(a) : nullptr;
}

template <typename T>
void GradientEngine::vm_batch(const Tape& tape, int64_t n, const T* xs, T* out) const {
  thread_local TapeVm vm;
  thread_local std::vector<const T*> in;
  vm.eval_gradient<T>(tape, size_t(n), soa_rows(xs, fn_.num_inputs, n, &in), out);
}

Dual GradientEngine::eval(std::span<const double> x, const std::vector<double>& a) const {
  if (const GradientJit* jit = ready_code(Precision::kF64)) return jit->eval_one(x, a);
  if (std::shared_ptr<const Tape> t = tape(Precision::kF64, a)) {
    double out[4];
    vm_batch<double>(*t, 1, x.data(), out);
    return {out[0], {out[1], out[2], out[3]}};
  }
  return pool_.take()->eval(x, a);
}

template <typename T>
void GradientEngine::interpret_batch(int64_t n, const T* xs, const std::vector<double>& a,
                                     T* out) const {
  const int nx = fn_.num_inputs;
  auto gi = pool_.take();
  std::vector<double> x(static_cast<size_t>(std::max(nx, 1)), 0.0);
  for (int64_t i = 0; i < n; ++i) {
    for (int k = 0; k < nx; ++k) x[k] = static_cast<double>(xs[k * n + i]);
    Dual d = gi->eval(x, a);
    out[i] = static_cast<T>(d.v);
    for (int k = 0; k < 3; ++k) out[(k + 1) * n + i] = static_cast<T>(d.d[k]);
  }
}

template <typename T>
void GradientEngine::eval_batch_t(Precision p, int64_t n, const T* xs, const std::vector<double>& a,
                                  T* out) const {
  if (n <= 0) return;
  if (const GradientJit* jit = ready_code(p)) {
    jit->eval(n, xs, a, out);
  } else if (std::shared_ptr<const Tape> t = tape(p, a)) {
    vm_batch<T>(*t, n, xs, out);
  } else {
    interpret_batch(n, xs, a, out);
  }
}

void GradientEngine::eval_batch(int64_t n, const double* xs, const std::vector<double>& a,
                                double* out) const {
  eval_batch_t<double>(Precision::kF64, n, xs, a, out);
}

void GradientEngine::eval_batch(int64_t n, const float* xs, const std::vector<double>& a,
                                float* out) const {
  eval_batch_t<float>(Precision::kF32, n, xs, a, out);
}

// --- Polynomial domain ------------------------------------------------------------------------

PolyEngine::PolyEngine(const Function& fn, const EngineOptions& options)
    : fn_(fn), options_(options) {}

const PolyAnalysis& PolyEngine::analysis() const {
  // Asked on every ray of the analytic search: settled, one atomic load (base/once.h).
  analysis_once_.call([&] {
    analysis_ = analyze_polynomial(fn_);
    interp_ = std::make_unique<PolyInterpreter>(fn_, analysis_.program);
  });
  return analysis_;
}

const PolyJit* PolyEngine::code() const {
  if (!options_.use_jit || !analysis().qualifies) return nullptr;
  return jit_.get([&] { return PolyJit::compile(fn_, analysis_.program, 1, options_.opt_level); });
}

void PolyEngine::eval(const double o[3], const double d[3], const std::vector<double>& a,
                      double* out) const {
  if (const PolyJit* jit = code()) {
    jit->eval_one(o, d, a, out);
  } else {
    analysis();
    interp_->eval(o, d, a, out);
  }
}

}  // namespace hfrt::jit
