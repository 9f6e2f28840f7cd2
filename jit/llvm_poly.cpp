// The polynomial JIT: a PolyProgram (jit/poly.h) -> straight-line LLVM code over W rays per
// SIMD block.
//
// Design
// - Each register is five <W x double> values, the coefficients of t^0..t^4; those above the
//   register's degree bound are the constant 0 and no instruction touches them (LLVM may not
//   fold x * 0 or x + 0 itself without fast-math flags). Every operation is the interpreter's
//   (poly_interpreter.cpp), term for term and in the same order, so both give the same values
//   (up to the sign of a zero: the interpreter accumulates products onto +0).
// - kScalar uses the shared scalar_op of llvm_emit.h (the scalar JIT's code for every pure
//   op), kTable a load from a constant global per lane. There is no control flow: a
//   PolyProgram is straight-line by construction.
//
// Signature of the block function:
//   void block(const double* o, const double* d, i64 stride, const double* a, double* out,
//              i64 positive)
// o[k*stride + lane], d[k*stride + lane]; out[(5*leaf + k)*stride + lane]; `positive` > 0
// feeds VectorEmitter::cut_block.

#include <array>
#include <chrono>
#include <cmath>
#include <limits>

#include "base/check.h"
#include "jit/llvm_emit.h"
#include "jit/llvm_session.h"
#include "jit/poly.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

using Coeffs = std::array<llvm::Value*, kPolyCoeffs>;

class PolyEmitter : public VectorEmitter {
 public:
  PolyEmitter(llvm::Module& m, const Function& fn, const PolyProgram& prog, int lanes)
      : VectorEmitter(m, fn, llvm::Type::getDoubleTy(m.getContext()), lanes), prog_(prog) {}

  void emit(const std::string& name) {
    auto* fty = llvm::FunctionType::get(llvm::Type::getVoidTy(ctx_),
                                        {ptr_, ptr_, i64_, ptr_, ptr_, i64_}, false);
    f_ = llvm::Function::Create(fty, llvm::Function::ExternalLinkage, name, m_);
    f_->setDoesNotThrow();
    auto arg = f_->arg_begin();
    o_ = &*arg++;
    d_ = &*arg++;
    stride_ = &*arg++;
    a_ = &*arg++;
    out_ = &*arg++;
    positive_ = &*arg++;
    b_.SetInsertPoint(llvm::BasicBlock::Create(ctx_, "entry", f_));
    regs_.resize(prog_.insts.size());
    for (size_t i = 0; i < prog_.insts.size(); ++i) {
      if (i > 0 && i % 256 == 0) cut_block(positive_);
      regs_[i] = emit_inst(prog_.insts[i]);
    }
    for (size_t j = 0; j < prog_.leaves.size(); ++j) {
      const Coeffs& c = regs_[size_t(prog_.leaves[j].reg)];
      for (int k = 0; k < kPolyCoeffs; ++k) {
        llvm::Value* row =
            b_.CreateMul(stride_, llvm::ConstantInt::get(i64_, int64_t(j) * kPolyCoeffs + k));
        b_.CreateAlignedStore(c[k], b_.CreateInBoundsGEP(st_, out_, row), align_);
      }
    }
    b_.CreateRetVoid();
  }

 private:
  Coeffs zeros() const {
    Coeffs c;
    c.fill(splat(0.0));
    return c;
  }

  llvm::Value* load_row(llvm::Value* base, int k) {
    llvm::Value* p =
        b_.CreateInBoundsGEP(st_, base, b_.CreateMul(stride_, llvm::ConstantInt::get(i64_, k)));
    return b_.CreateAlignedLoad(vt_, p, align_);
  }

  Coeffs emit_inst(const PolyInst& in) {
    Coeffs r = zeros();
    const int n = in.degree + 1;
    auto reg = [&](int k) -> const Coeffs& { return regs_[size_t(in.args[k])]; };
    switch (in.op) {
      case PolyOp::kConst:
        r[0] = splat(in.imm);
        break;
      case PolyOp::kInput:
        if (in.aux < 3) {
          r[0] = load_row(o_, in.aux);
          r[1] = load_row(d_, in.aux);
        }
        break;
      case PolyOp::kParam:
        // The caller passes at least poly_num_params(fn) values (PolyJit::eval pads them).
        if (in.aux >= 0 && in.aux < poly_num_params(fn_)) {
          llvm::Value* v =
              b_.CreateLoad(st_, b_.CreateConstInBoundsGEP1_64(st_, a_, uint64_t(in.aux)));
          r[0] = b_.CreateVectorSplat(unsigned(w_), v);
        }
        break;
      case PolyOp::kAdd:
        for (int k = 0; k < n; ++k) r[k] = b_.CreateFAdd(reg(0)[k], reg(1)[k]);
        break;
      case PolyOp::kSub:
        for (int k = 0; k < n; ++k) r[k] = b_.CreateFSub(reg(0)[k], reg(1)[k]);
        break;
      case PolyOp::kNeg:
        for (int k = 0; k < n; ++k) r[k] = b_.CreateFNeg(reg(0)[k]);
        break;
      case PolyOp::kMul: {
        const int dx = prog_.insts[size_t(in.args[0])].degree,
                  dy = prog_.insts[size_t(in.args[1])].degree;
        // The interpreter's loop order: for i, for j: r[i+j] += x[i] * y[j], from +0.
        std::array<llvm::Value*, kPolyCoeffs> acc{};
        for (int i = 0; i <= dx; ++i) {
          for (int j = 0; j <= dy && i + j < kPolyCoeffs; ++j) {
            llvm::Value* p = b_.CreateFMul(reg(0)[i], reg(1)[j]);
            acc[i + j] = acc[i + j] ? b_.CreateFAdd(acc[i + j], p) : b_.CreateFAdd(splat(0.0), p);
          }
        }
        for (int k = 0; k < kPolyCoeffs; ++k) {
          if (acc[k]) r[k] = acc[k];
        }
        break;
      }
      case PolyOp::kDiv:
        for (int k = 0; k < n; ++k) r[k] = b_.CreateFDiv(reg(0)[k], reg(1)[0]);
        break;
      case PolyOp::kScalar: {
        llvm::Value* x = in.args[0] >= 0 ? reg(0)[0] : splat(0.0);
        llvm::Value* y = in.args[1] >= 0 ? reg(1)[0] : splat(0.0);
        llvm::Value* z = in.args[2] >= 0 ? reg(2)[0] : splat(0.0);
        r[0] = scalar_op(in.scalar_op, x, y, z);
        break;
      }
      case PolyOp::kTable:
        r[0] = table_load(in.aux, reg(0)[0]);
        break;
      case PolyOp::kSelect: {
        llvm::Value* c = nonzero(reg(0)[0]);
        for (int k = 0; k < kPolyCoeffs; ++k) r[k] = b_.CreateSelect(c, reg(1)[k], reg(2)[k]);
        break;
      }
    }
    return r;
  }

  /// tables[t][idx] per lane; NaN for an index out of range (as the interpreter).
  llvm::Value* table_load(int t, llvm::Value* idx) {
    const std::vector<double>& tab = fn_.tables.at(size_t(t));
    auto* aty = llvm::ArrayType::get(st_, tab.size());
    std::vector<llvm::Constant*> elems;
    for (double v : tab) elems.push_back(llvm::ConstantFP::get(st_, v));
    auto* g = new llvm::GlobalVariable(m_, aty, true, llvm::GlobalValue::PrivateLinkage,
                                       llvm::ConstantArray::get(aty, elems));
    llvm::Value* out = splat(0.0);
    for (int lane = 0; lane < w_; ++lane) {
      llvm::Value* v = b_.CreateExtractElement(idx, uint64_t(lane));
      llvm::Value* ok =
          b_.CreateAnd(b_.CreateFCmpOGE(v, llvm::ConstantFP::get(st_, 0.0)),
                       b_.CreateFCmpOLT(v, llvm::ConstantFP::get(st_, double(tab.size()))));
      llvm::Value* i =
          b_.CreateSelect(ok, b_.CreateFPToSI(v, i64_), llvm::ConstantInt::get(i64_, 0));
      llvm::Value* e = b_.CreateLoad(st_, b_.CreateInBoundsGEP(st_, g, i));
      e = b_.CreateSelect(ok, e,
                          llvm::ConstantFP::get(st_, std::numeric_limits<double>::quiet_NaN()));
      out = b_.CreateInsertElement(out, e, uint64_t(lane));
    }
    return out;
  }

  const PolyProgram& prog_;
  std::vector<Coeffs> regs_;
  llvm::Value* o_ = nullptr;
  llvm::Value* d_ = nullptr;
  llvm::Value* stride_ = nullptr;
  llvm::Value* a_ = nullptr;
  llvm::Value* out_ = nullptr;
  llvm::Value* positive_ = nullptr;
};

using BlockFn = void (*)(const double* o, const double* d, int64_t stride, const double* a,
                         double* out, int64_t positive) noexcept;

}  // namespace

struct PolyJit::Impl {
  std::unique_ptr<CompiledCode> code;
  int lanes = 1;
  int num_params = 0;
  size_t num_leaves = 0;
  JitStats stats;
};

PolyJit::PolyJit(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
PolyJit::~PolyJit() = default;
int PolyJit::lanes() const {
  return impl_->lanes;
}
const JitStats& PolyJit::stats() const {
  return impl_->stats;
}

Result<std::unique_ptr<PolyJit>> PolyJit::compile(const Function& fn, const PolyProgram& program,
                                                  int lanes, int opt_level) {
  HFRT_CHECK(lanes >= 1 && (lanes & (lanes - 1)) == 0);
  Result<LlvmSession*> session = LlvmSession::get();
  if (!session.ok()) return session.error();
  auto impl = std::make_unique<Impl>();
  impl->lanes = lanes;
  ModuleUnit unit = session.value()->new_module("hfrt_poly");
  const std::string name = unit.name;
  auto t0 = std::chrono::steady_clock::now();
  PolyEmitter(*unit.module, fn, program, lanes).emit(name);
  impl->stats.emit_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  impl->stats.lanes = lanes;
  PipelineOptions options;
  options.opt_level = opt_level;
  options.codegen = llvm::CodeGenOptLevel::Default;
  auto code = session.value()->compile(std::move(unit), name, options, &impl->stats);
  if (!code.ok()) return code.error();
  impl->code = std::move(code.value());
  impl->num_params = poly_num_params(fn);
  impl->num_leaves = program.leaves.size();
  return std::unique_ptr<PolyJit>(new PolyJit(std::move(impl)));
}

void PolyJit::eval(int64_t n, const double* o, const double* d, std::span<const double> a,
                   double* out) const {
  auto block = reinterpret_cast<BlockFn>(impl_->code->entry());
  const int w = impl_->lanes;
  std::vector<double> params(size_t(std::max(impl_->num_params, 1)), 0.0);
  for (size_t k = 0; k < a.size() && k < params.size(); ++k) params[k] = a[k];
  const int64_t full = n - n % w;
  for (int64_t i = 0; i < full; i += w) block(o + i, d + i, n, params.data(), out + i, 1);
  if (full < n) {
    const int64_t m = n - full;
    const size_t rows = impl_->num_leaves * kPolyCoeffs;
    std::vector<double> po(3 * size_t(w)), pd(3 * size_t(w)),
        pout(std::max<size_t>(rows, 1) * size_t(w));
    for (int k = 0; k < 3; ++k) {
      for (int j = 0; j < w; ++j) {
        po[size_t(k * w + j)] = o[k * n + full + std::min<int64_t>(j, m - 1)];
        pd[size_t(k * w + j)] = d[k * n + full + std::min<int64_t>(j, m - 1)];
      }
    }
    block(po.data(), pd.data(), w, params.data(), pout.data(), 1);
    for (size_t r = 0; r < rows; ++r) {
      for (int64_t j = 0; j < m; ++j)
        out[int64_t(r) * n + full + j] = pout[r * size_t(w) + size_t(j)];
    }
  }
}

void PolyJit::eval_one(const double o[3], const double d[3], std::span<const double> a,
                       double* out) const {
  if (impl_->lanes == 1 && a.size() >= size_t(std::max(impl_->num_params, 1))) {
    // The renderer's per-ray call: no copies.
    reinterpret_cast<BlockFn>(impl_->code->entry())(o, d, 1, a.data(), out, 1);
    return;
  }
  eval(1, o, d, a, out);
}

}  // namespace hfrt::jit
