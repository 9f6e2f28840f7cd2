#pragma once
// What the three LLVM emitters (scalar llvm_jit.cpp, interval llvm_interval.cpp, gradient
// llvm_gradient.cpp) share: the vector types of a block of W lanes, constants and small
// helpers, entry-block allocas, per-lane calls of scalar host functions, the scalar value of
// every pure op (the scalar JIT's code, which is also the value part of the gradient JIT),
// lane-mask control flow (scalar and gradient; the interval JIT has its own tri-state rules)
// and the region/slot analyses of structured control flow.
//
// Only jit/llvm_*.cpp may include this header (it includes LLVM).

#include <cstdint>
#include <vector>

#include "ir/ir.h"
#include "jit/llvm_includes.h"
#include "jit/llvm_jit.h"  // Precision

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

/// The scalar JIT's code of `fn` (llvm_jit.cpp) in `module`: the internal function
///   void body(const T* xs, i64 stride, const T* a, T* out_f, T* out_s, i64 out_stride)
/// that evaluates one block of `lanes` points (x[k+1] of lane i at xs[k*stride + i], F to
/// out_f[i], s[k+1] to out_s[k*out_stride + i] unless out_s is null), and, unless
/// `batch_entry` is empty, the exported batch function of that name (BatchFn). Per-lane libm
/// calls are declarations (op_libm_name); the caller links or defines them, f32 sin and cos
/// included (they are not the host's trig_kernel code here). Returns the body.
/// The NVPTX kernels (llvm_nvptx.cpp) call it with one lane.
llvm::Function* emit_scalar_function(llvm::Module& module, const Function& fn, Precision precision,
                                     int lanes, const std::string& batch_entry);

/// The interval JIT's block function of `fn` (llvm_interval.cpp) in `module` as `name`:
///   void name(const double* xlo, const double* xhi, i64 stride, const double* a,
///             double* out_lo, double* out_hi, u8* out_nan, u8* choices (unused), double* scratch)
/// for one block of `lanes` boxes (x[k+1] of lane i in [xlo[k*stride + i], xhi[...]]);
/// scratch holds 3 * lanes * *num_homes doubles. Not outlined, no trace.
llvm::Function* emit_interval_function(llvm::Module& module, const Function& fn, int lanes,
                                       int loop_limit, const std::string& name, int* num_homes);

/// Slots written (kStoreSlot, kStoreIdx) by the instructions in [begin, end), ascending.
std::vector<int> written_slots(const Function& fn, size_t begin, size_t end);

/// Memory homes of IR values for the wide emitters (interval, gradient). Their values are
/// many vectors each (lo/hi/NaN, value and three derivatives) and their code per op is long:
/// kept in SSA form, a large model becomes one huge web of selects and masks in which
/// SelectionDAG's known-bits queries (exponential in their depth) and the register
/// allocator take minutes. Instead every computed value is stored to a home in a scratch
/// buffer when it is defined and loaded where it is used, so each op is a small independent
/// piece of code between loads and stores (compile time linear in the model) that works in
/// L1 cache: homes are reused once a value is dead (linear scan over the instruction list;
/// a value used inside a loop it was not defined in lives until that loop's end).
struct ValueHomes {
  std::vector<int32_t> home;  ///< per instruction: its home, or -1 (no value, or a constant)
  int num_homes = 0;          ///< homes needed at once
};
/// `params_at_use`: parameters get no home either (the emitter loads them where they are used:
/// a broadcast load from the parameter array is cheaper than a home's three vectors, and
/// hoisted numbers make many parameters, see hoist_constants).
/// `extra_uses`: empty, or two values per instruction that it reads besides its arguments
/// (kNoValue: none), so that they stay live until it (the interval emitter's R-function nodes).
ValueHomes plan_value_homes(const Function& fn, bool params_at_use = false,
                            const std::vector<ValueId>& extra_uses = {});

/// Base of the emitters: one IR Function -> LLVM code over <W x T> vectors (lane i = point or
/// box i of a block). Holds the builder and the types; emitters add their value
/// representation (one vector, an interval, a dual number) on top.
class VectorEmitter {
 protected:
  /// `element` is double or float; `lanes` a power of two.
  VectorEmitter(llvm::Module& module, const Function& fn, llvm::Type* element, int lanes);

  // --- Constants and small helpers ------------------------------------------------------
  llvm::Constant* splat(double v) const { return llvm::ConstantFP::get(vt_, v); }
  llvm::Constant* all_true() const { return llvm::ConstantInt::getTrue(mt_); }
  llvm::Constant* all_false() const { return llvm::ConstantInt::getFalse(mt_); }
  llvm::Value* fabs(llvm::Value* v) { return b_.CreateUnaryIntrinsic(llvm::Intrinsic::fabs, v); }
  /// Some lane set (a branch condition).
  llvm::Value* any(llvm::Value* mask) { return b_.CreateOrReduce(mask); }
  /// A lane mask as 1.0 / 0.0.
  llvm::Value* to_real(llvm::Value* mask) { return b_.CreateUIToFP(mask, vt_); }
  /// `v != 0` (NaN counts as nonzero): how kSelect, kIf, kLoopTest and kCheck read a value.
  llvm::Value* nonzero(llvm::Value* v) { return b_.CreateFCmpUNE(v, splat(0.0)); }
  /// HyperFun truth: |v| >= 1e-6.
  llvm::Value* truth(llvm::Value* v);
  /// m & c, where a null m means all lanes.
  llvm::Value* and_mask(llvm::Value* m, llvm::Value* c) { return m ? b_.CreateAnd(m, c) : c; }

  /// A new basic block at the end of the current function.
  llvm::BasicBlock* new_block(const char* name) { return llvm::BasicBlock::Create(ctx_, name, f_); }
  /// Starts a new basic block. Long straight-line code must be cut into blocks: instruction
  /// selection and scheduling work one block at a time and are superlinear in its size. An
  /// unconditional branch would not do (CodeGenPrepare merges such blocks back into one),
  /// so the cut is a conditional branch to a block that returns, on `positive == -k` for a
  /// fresh k each cut: `positive` is an i64 argument the callers always pass > 0, so the
  /// branch is never taken (one predictable compare and branch), and no pass can fold it
  /// (a repeated condition would be folded in the blocks it dominates, a pointer compared
  /// with null is known non-null once dereferenced).
  void cut_block(llvm::Value* positive);

  /// An alloca in the current function's entry block (so SROA/mem2reg promote it).
  llvm::AllocaInst* entry_alloca(llvm::Type* ty, const char* name = "");

  /// A declared pure external function of `args` scalars (libm or an hfrt helper).
  llvm::FunctionCallee pure_function(const char* name, int args);
  /// The f64 or f32 name, by the element type.
  const char* pick_name(const char* f64_name, const char* f32_name) const {
    return is_f32_ ? f32_name : f64_name;
  }
  /// Calls a scalar function on every lane (all lanes: the functions are pure, and the
  /// results of inactive lanes are never stored); once on lane 0, broadcast, while
  /// uniform_op_ says the op's value is the same on every lane (uniform_values).
  llvm::Value* call_lanes(llvm::FunctionCallee f, llvm::Value* a, llvm::Value* b = nullptr);
  bool uniform_op_ = false;

  /// Function::surfaces[index] as a constant pointer of the code (the Function owns it).
  llvm::Value* surface_pointer(int index);
  /// A C-ABI helper `void name(ptr surface, ptr in, ptr out)` (jit/surface_ops.h).
  llvm::FunctionCallee surface_helper(const char* name);
  /// kSurface's value on every lane: hfrt_surface_f64 / _f32 per lane (surface_ops.h), or
  /// with `sign_only` hfrt_surface_sign_f64 / _f32 (+1 / -1, JitOptions::surface_sign_only).
  llvm::Value* surface_lanes(int index, llvm::Value* x, llvm::Value* y, llvm::Value* z,
                             bool sign_only = false);

  /// ir/trig.h's trig_kernel on a <W x double> vector: the same IEEE operations in the same
  /// order, so every lane is bit for bit what the C++ kernel computes (any value beyond
  /// kTrigKernelLimit, as there).
  llvm::Value* trig_kernel(llvm::Value* x, bool cos);
  /// ir/trig.h's sin_cos_f32 on a <W x float> vector: the kernel on the lanes' doubles, and
  /// a branch to per-lane libm calls taken only when some lane is beyond the kernel's range.
  llvm::Value* sin_cos_f32(llvm::Value* a, bool cos);
  /// Whether f32 kSin / kCos are emitted as trig_kernel code (the host) or as calls of the
  /// float libm names (the NVPTX kernels, whose device math replaces those calls).
  bool inline_trig_ = true;

  /// The value of a pure op (kAdd ... kSelect, no kTableLoad) on vectors, exactly as
  /// scalar_ops.h apply_op computes it: IEEE instructions and intrinsics without fast-math
  /// flags, per-lane calls of the interpreter's own libm functions and hf_pow.
  llvm::Value* scalar_op(Op op, llvm::Value* a, llvm::Value* b, llvm::Value* c);

  // --- Lane-mask control flow (scalar and gradient JIT) ----------------------------------
  // Both sides of an `if` run under their masks (a side no lane takes is skipped by a
  // branch); a loop runs while any lane is active. mask() is the active lanes (null = all);
  // only side effects (stores, checks) look at it.
  llvm::Value* mask() const { return mask_; }
  void begin_if(llvm::Value* cond);  ///< cond: lanes where the condition holds
  void begin_else();
  void end_if();
  /// Opens the loop header; the lanes that enter it are mask().
  void begin_loop();
  /// kLoopTest: lanes in `stay` run the body again (mask() becomes `stay`), the others leave.
  void loop_continue(llvm::Value* stay);
  void end_loop();

  llvm::LLVMContext& ctx_;
  llvm::Module& m_;
  llvm::IRBuilder<> b_;
  const Function& fn_;
  const int w_;
  const bool is_f32_;
  llvm::Type* st_;             ///< element type
  llvm::FixedVectorType* vt_;  ///< <W x T>
  llvm::FixedVectorType* mt_;  ///< <W x i1>
  llvm::IntegerType* i64_;
  llvm::IntegerType* i32_;
  llvm::IntegerType* i8_;
  llvm::PointerType* ptr_;
  llvm::Align align_;            ///< element alignment (callers' arrays are element-aligned)
  llvm::Function* f_ = nullptr;  ///< the function being emitted

 private:
  struct MaskFrame {
    bool is_loop = false;
    llvm::Value* outer = nullptr;        ///< mask around the region (null = all lanes)
    llvm::Value* cond = nullptr;         ///< if: lanes where the condition holds
    llvm::BasicBlock* skip = nullptr;    ///< if: where the then side's skip branch lands
    llvm::BasicBlock* end = nullptr;     ///< if: after kEndIf; loop: the exit
    llvm::BasicBlock* header = nullptr;  ///< loop
    llvm::AllocaInst* active = nullptr;  ///< loop: lanes entering the next iteration
    bool has_else = false;
  };
  llvm::Value* mask_ = nullptr;
  std::vector<MaskFrame> frames_;
  llvm::BasicBlock* escape_ = nullptr;  ///< cut_block's return block (of f_)
  llvm::Function* escape_of_ = nullptr;
  int64_t cuts_ = 0;
};

}  // namespace hfrt::jit
