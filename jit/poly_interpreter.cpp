// The reference evaluator of the polynomial domain (poly.h): runs a PolyProgram for one ray.
#include <algorithm>
#include <cstring>
#include <vector>

#include "base/check.h"
#include "ir/scalar_ops.h"
#include "jit/poly.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

void PolyInterpreter::eval(const double o[3], const double d[3], std::span<const double> a,
                           double* out) const {
  const std::vector<PolyInst>& insts = program_.insts;
  // Per-thread registers: eval is const and called from many render threads at once.
  thread_local std::vector<double> regs;
  regs.assign(insts.size() * kPolyCoeffs, 0.0);
  for (size_t i = 0; i < insts.size(); ++i) {
    const PolyInst& in = insts[i];
    double* r = &regs[i * kPolyCoeffs];
    const double* x = in.args[0] >= 0 ? &regs[size_t(in.args[0]) * kPolyCoeffs] : nullptr;
    const double* y = in.args[1] >= 0 ? &regs[size_t(in.args[1]) * kPolyCoeffs] : nullptr;
    const double* z = in.args[2] >= 0 ? &regs[size_t(in.args[2]) * kPolyCoeffs] : nullptr;
    const int n = in.degree + 1;  // coefficients that may be non-zero
    switch (in.op) {
      case PolyOp::kConst:
        r[0] = in.imm;
        break;
      case PolyOp::kInput:
        if (in.aux < 3) {
          r[0] = o[in.aux];
          r[1] = d[in.aux];
        }
        break;
      case PolyOp::kParam:
        r[0] = in.aux >= 0 && size_t(in.aux) < a.size() ? a[size_t(in.aux)] : 0.0;
        break;
      case PolyOp::kAdd:
        for (int k = 0; k < n; ++k) r[k] = x[k] + y[k];
        break;
      case PolyOp::kSub:
        for (int k = 0; k < n; ++k) r[k] = x[k] - y[k];
        break;
      case PolyOp::kNeg:
        for (int k = 0; k < n; ++k) r[k] = -x[k];
        break;
      case PolyOp::kMul: {
        const int dx = insts[size_t(in.args[0])].degree, dy = insts[size_t(in.args[1])].degree;
        for (int i0 = 0; i0 <= dx; ++i0) {
          for (int j = 0; j <= dy && i0 + j < kPolyCoeffs; ++j) r[i0 + j] += x[i0] * y[j];
        }
        break;
      }
      case PolyOp::kDiv:
        for (int k = 0; k < n; ++k) r[k] = x[k] / y[0];
        break;
      case PolyOp::kScalar:
        r[0] = apply_op(in.scalar_op, x ? x[0] : 0.0, y ? y[0] : 0.0, z ? z[0] : 0.0);
        break;
      case PolyOp::kTable: {
        const std::vector<double>& t = fn_.tables.at(size_t(in.aux));
        const double idx = x[0];
        // In range by the IR's contract; stay safe for NaN or stray indices.
        r[0] = idx >= 0 && idx < double(t.size()) ? t[size_t(idx)] : std::nan("");
        break;
      }
      case PolyOp::kSelect: {
        const double* src = x[0] != 0 ? y : z;
        std::copy(src, src + kPolyCoeffs, r);
        break;
      }
    }
  }
  for (size_t i = 0; i < program_.leaves.size(); ++i) {
    const double* r = &regs[size_t(program_.leaves[i].reg) * kPolyCoeffs];
    std::copy(r, r + kPolyCoeffs, out + i * kPolyCoeffs);
  }
}

}  // namespace hfrt::jit
