// The printer of polynomial programs (poly.h).
#include <cstdio>
#include <string>

#include "ir/ir.h"
#include "jit/poly.h"

namespace hfrt::jit {

using namespace ::hfrt::ir;

std::string_view poly_op_name(PolyOp op) {
  switch (op) {
    case PolyOp::kConst:
      return "const";
    case PolyOp::kInput:
      return "input";
    case PolyOp::kParam:
      return "param";
    case PolyOp::kAdd:
      return "add";
    case PolyOp::kSub:
      return "sub";
    case PolyOp::kNeg:
      return "neg";
    case PolyOp::kMul:
      return "mul";
    case PolyOp::kDiv:
      return "div";
    case PolyOp::kScalar:
      return "scalar";
    case PolyOp::kTable:
      return "table";
    case PolyOp::kSelect:
      return "select";
  }
  return "?";
}

namespace {

std::string reg(int32_t r) {
  return "r" + std::to_string(r);
}

std::string value(ValueId v) {
  return v == kNoValue ? std::string("-") : "%" + std::to_string(v);
}

}  // namespace

std::string print(const PolyProgram& program) {
  std::string out;
  for (size_t i = 0; i < program.insts.size(); ++i) {
    const PolyInst& in = program.insts[i];
    std::string line = reg(int32_t(i)) + " = " + std::string(poly_op_name(in.op));
    bool has_args = false;
    switch (in.op) {
      case PolyOp::kConst:
        line += " " + format_double(in.imm);
        break;
      case PolyOp::kInput:
        line += " x[" + std::to_string(in.aux + 1) + "]";
        break;
      case PolyOp::kParam:
        line += " a[" + std::to_string(in.aux + 1) + "]";
        break;
      case PolyOp::kScalar:
        line += " " + std::string(op_name(in.scalar_op));
        has_args = true;
        break;
      case PolyOp::kTable:
        line += " table " + std::to_string(in.aux);
        has_args = true;
        break;
      case PolyOp::kAdd:
      case PolyOp::kSub:
      case PolyOp::kNeg:
      case PolyOp::kMul:
      case PolyOp::kDiv:
      case PolyOp::kSelect:
        has_args = true;
        break;
    }
    if (has_args) {
      const char* sep = " ";
      for (int32_t arg : in.args) {
        if (arg < 0) continue;
        line += sep + reg(arg);
        sep = ", ";
      }
    }
    if (line.size() < 32) line.resize(32, ' ');
    out += line + "  ; deg " + std::to_string(in.degree) + "\n";
  }
  for (size_t i = 0; i < program.leaves.size(); ++i) {
    const PolyLeaf& l = program.leaves[i];
    out += "leaf " + std::to_string(i) + " = " + reg(l.reg) + "  ; deg " +
           std::to_string(l.degree) + ", " + value(l.value) + (l.surrogate ? ", surrogate" : "") +
           (int(i) >= program.num_poly_leaves ? ", surface point" : "") + "\n";
  }
  for (const PolySurfaceLeaf& s : program.surfaces) {
    out += "surface " + std::to_string(s.surface) + " at " + value(s.value) + ": leaves " +
           std::to_string(s.first_leaf) + ".." + std::to_string(s.first_leaf + 2) + "\n";
  }
  return out;
}

}  // namespace hfrt::jit
