#pragma once
// The gradient domain's meaning of every pure op, written once: apply_dual extends an op to
// dual numbers (value and d/dx[1..3]) by the chain rule, with the one-sided derivative of the
// branch the scalar code takes where the op is not differentiable (the contract is in
// jit/gradient.h). The gradient interpreter and the gradient JIT's per-lane helpers use it.

#include "ir/ir.h"

namespace hfrt::ir {

/// A value and its partial derivatives d/dx[1], d/dx[2], d/dx[3].
struct Dual {
  double v = 0;
  double d[3] = {0, 0, 0};

  static Dual constant(double v) { return {v, {0, 0, 0}}; }
};

/// The dual extension of one pure op with arguments (the ops apply_op accepts).
Dual apply_dual(Op op, const Dual& a, const Dual& b, const Dual& c);

}  // namespace hfrt::ir
