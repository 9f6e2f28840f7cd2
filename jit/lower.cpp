// AST -> IR (see lower.h). HyperFun's evaluation rules, as the original interpreter
// implements them (../shared/spec/hyperfun.md §3), become explicit IR here:
//  - operands and arguments are evaluated right to left (the original walks postfix code
//    backwards), which decides which run-time error is reported first;
//  - each run-time error is a kCheck placed before the op it guards, located at the
//    operator or call in the source;
//  - variables are slots; reading one that is not provably assigned reads a shadow
//    "defined" flag slot (unneeded flags vanish in IrBuilder::finish's dead-code removal);
//  - called objects are inlined; every while loop carries an iteration counter.
#include "jit/lower.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "base/check.h"
#include "ir/builder.h"
#include "ir/scalar_ops.h"
#include "lang/builtins.h"
#include "lang/library_table.h"
#include "stdlib/library.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;

namespace {

using lang::BinaryOp;
using lang::Builtin;
using lang::Expr;
using lang::ExprKind;
using lang::Object;
using lang::Program;
using lang::SourceLoc;
using lang::Stmt;
using lang::StmtKind;
using lang::SymbolKind;
using lang::UnaryOp;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// Constant integral exponents up to this size become chains of multiplications.
constexpr int kMaxMulChain = 64;

/// A run of slots holding one array, and the flags that say which elements are assigned.
struct ArraySlots {
  int base = -1;
  int size = 0;
  int flag_base = -1;  ///< -1: every element is always assigned (x, a, s)
};

/// Which variables are certainly assigned at the current point (a definite-assignment
/// analysis run alongside the lowering): reads that it proves need no run-time check.
struct Assigned {
  std::vector<char> scalars;
  std::vector<std::vector<char>> arrays;  // per local array, per element

  void meet(const Assigned& o) {
    for (size_t i = 0; i < scalars.size(); ++i) scalars[i] = scalars[i] && o.scalars[i];
    for (size_t a = 0; a < arrays.size(); ++a) {
      for (size_t k = 0; k < arrays[a].size(); ++k) arrays[a][k] = arrays[a][k] && o.arrays[a][k];
    }
  }
};

/// One activation of an object: the top-level model or an inlined call.
struct Frame {
  const Object* obj = nullptr;
  ArraySlots x, a, s;  // s.base == -1 when the object has no s
  std::vector<int> scalar_slot, scalar_flag;
  std::vector<ArraySlots> arrays;
  Assigned assigned;
};

class Lowerer {
 public:
  Lowerer(const Program& program, lang::DiagnosticSink* warnings, const Limits& limits)
      : prog_(program), warnings_(warnings), limits_(limits), b_(fn_) {
    fn_.source = program.source;
  }

  Function run(int object_index) {
    HFRT_CHECK(object_index >= 0 && object_index < static_cast<int>(prog_.objects.size()));
    const Object& obj = prog_.objects[object_index];
    fn_.name = obj.name;
    fn_.num_inputs = obj.x_size;
    fn_.num_params = obj.a_size;
    b_.set_loc(obj.name_range.begin);

    Frame top;
    top.obj = &obj;
    // x and a are copied into slots: library transformations move the point in place.
    top.x = new_array(obj.x_size, 0, false);
    top.a = new_array(obj.a_size, 0, false);
    // s starts at 0; without an s in the header the original still reports s1 = 0.
    const int s_size = obj.has_s ? obj.s_size : 1;
    top.s = new_array(s_size, 0, false);
    for (int i = 0; i < s_size; ++i) fn_.s_slots.push_back(top.s.base + i);
    if (!obj.has_s) top.s = {};
    for (int i = 0; i < obj.x_size; ++i) b_.store(top.x.base + i, b_.input(i));
    for (int i = 0; i < obj.a_size; ++i) b_.store(top.a.base + i, b_.param(i));

    ValueId result = lower_body(top, /*inlined=*/false);
    b_.finish(result);
    return std::move(fn_);
  }

 private:
  // ---- slots ----------------------------------------------------------------------------
  ArraySlots new_array(int size, double init, bool with_flags) {
    ArraySlots arr;
    arr.size = size;
    arr.base = fn_.num_slots;
    for (int i = 0; i < size; ++i) b_.new_slot(init);
    if (with_flags) {
      arr.flag_base = fn_.num_slots;
      for (int i = 0; i < size; ++i) b_.new_slot(0);
    }
    return arr;
  }

  // Slots for the locals of `f`; an inlined call (possibly inside a loop) also clears the
  // flags, since its locals start undefined at every call.
  void allocate_locals(Frame& f, bool inlined) {
    const Object& obj = *f.obj;
    for (size_t i = 0; i < obj.scalars.size(); ++i) {
      f.scalar_slot.push_back(b_.new_slot(kNaN));
      f.scalar_flag.push_back(b_.new_slot(0));
      if (inlined) b_.store(f.scalar_flag.back(), b_.constant(0));
    }
    for (const lang::ArrayDecl& d : obj.arrays) {
      f.arrays.push_back(new_array(d.size, kNaN, true));
      if (inlined) {
        for (int k = 0; k < d.size; ++k) b_.store(f.arrays.back().flag_base + k, b_.constant(0));
      }
    }
    f.assigned.scalars.assign(obj.scalars.size(), 0);
    for (const lang::ArrayDecl& d : obj.arrays) f.assigned.arrays.emplace_back(d.size, 0);
  }

  ValueId lower_body(Frame& f, bool inlined) {
    allocate_locals(f, inlined);
    lower_block(f, f.obj->body);
    HFRT_CHECK(f.obj->result != nullptr);
    return lower_expr(f, *f.obj->result);
  }

  // ---- locations ------------------------------------------------------------------------
  // The operator of a binary expression: the first character after the left operand that
  // is not a space, a closing parenthesis or a comment (the AST keeps operand ranges only).
  SourceLoc operator_loc(const Expr& e) const {
    if (!prog_.source || e.args.empty() || !e.args[0]) return e.range.begin;
    std::string_view text = prog_.source->text();
    const lang::SourceRange& left = e.args[0]->range;
    size_t p = static_cast<size_t>(left.begin.offset) + left.length;
    while (p < text.size()) {
      char c = text[p];
      if (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == ')') {
        ++p;
      } else if (c == '-' && p + 1 < text.size() && text[p + 1] == '-') {
        while (p < text.size() && text[p] != '\n') ++p;
      } else {
        break;
      }
    }
    if (p >= text.size()) return e.range.begin;
    return prog_.source->loc_at(static_cast<uint32_t>(p));
  }

  // ---- statements -----------------------------------------------------------------------
  void lower_block(Frame& f, const std::vector<lang::StmtPtr>& body) {
    for (const lang::StmtPtr& s : body) lower_stmt(f, *s);
  }

  void lower_stmt(Frame& f, const Stmt& s) {
    switch (s.kind) {
      case StmtKind::kAssign: {
        HFRT_CHECK(s.symbol.kind == SymbolKind::kLocalScalar);
        ValueId v = lower_expr(f, *s.value);
        b_.set_loc(s.name_range.begin);
        const int i = s.symbol.index;
        b_.store(f.scalar_slot[i], v);
        b_.store(f.scalar_flag[i], b_.constant(1));
        f.assigned.scalars[i] = 1;
        return;
      }
      case StmtKind::kAssignIndex: {
        ArraySlots arr = array_of(f, s.symbol);
        // The original evaluates and checks the index before the value.
        std::optional<int> known;
        ValueId index = lower_index(f, *s.index, arr, &known);
        ValueId v = lower_expr(f, *s.value);
        b_.set_loc(s.name_range.begin);
        b_.store_index(arr.base, arr.size, index, v);
        if (arr.flag_base >= 0) {
          b_.store_index(arr.flag_base, arr.size, index, b_.constant(1));
          if (known) f.assigned.arrays[s.symbol.index][*known - 1] = 1;
        }
        return;
      }
      case StmtKind::kAssignArray: {
        ArraySlots arr = array_of(f, s.symbol);
        HFRT_CHECK_EQ(static_cast<int>(s.literal.size()), arr.size);
        b_.set_loc(s.name_range.begin);
        for (int k = 0; k < arr.size; ++k) {
          b_.store(arr.base + k, b_.constant(s.literal[k]));
          if (arr.flag_base >= 0) b_.store(arr.flag_base + k, b_.constant(1));
        }
        if (arr.flag_base >= 0) {
          auto& done = f.assigned.arrays[s.symbol.index];
          std::fill(done.begin(), done.end(), 1);
        }
        return;
      }
      case StmtKind::kIf:
        return lower_if(f, s);
      case StmtKind::kWhile:
        return lower_while(f, s);
    }
  }

  void lower_if(Frame& f, const Stmt& s) {
    ValueId c = lower_expr(f, *s.cond);
    b_.set_loc(s.range.begin);
    ValueId t = b_.unary(Op::kTruth, c);
    const Inst& ti = fn_.insts[t];
    if (ti.op == Op::kConst) {  // decided at compile time: lower only the branch taken
      lower_block(f, ti.imm != 0 ? s.then_body : s.else_body);
      return;
    }
    const Assigned before = f.assigned;
    b_.begin_if(t);
    lower_block(f, s.then_body);
    Assigned after_then = f.assigned;
    f.assigned = before;
    if (!s.else_body.empty()) {
      b_.set_loc(s.range.begin);
      b_.begin_else();
      lower_block(f, s.else_body);
    }
    b_.set_loc(s.range.begin);
    b_.end_if();
    f.assigned.meet(after_then);
  }

  void lower_while(Frame& f, const Stmt& s) {
    b_.set_loc(s.range.begin);
    // One counter for every loop of the evaluation (inlined objects' too): it starts at 0 with
    // each point, and nested or repeated loops add up, so the bound is per point.
    if (loop_counter_ < 0) loop_counter_ = b_.new_slot(0);
    const int counter = loop_counter_;
    const Assigned before = f.assigned;
    b_.begin_loop();
    ValueId c = lower_expr(f, *s.cond);
    b_.set_loc(s.range.begin);
    ValueId t = b_.unary(Op::kTruth, c);
    ValueId n = b_.load(counter);
    ValueId limit = b_.constant(static_cast<double>(limits_.max_loop_iterations));
    b_.check(b_.binary(Op::kAnd, t, b_.ge(n, limit)), ErrorKind::kLoopLimit);
    b_.loop_test(b_.binary(Op::kAnd, t, b_.lt(n, limit)));
    // Counted as the iteration starts, so that the limit is the number of iterations run
    // (nested loops' included), whichever loop runs the last one.
    b_.store(counter, b_.add(b_.load(counter), b_.constant(1)));
    lower_block(f, s.then_body);
    b_.set_loc(s.range.begin);
    b_.end_loop();
    f.assigned = before;  // the body may run zero times
  }

  // ---- arrays ---------------------------------------------------------------------------
  ArraySlots array_of(const Frame& f, const lang::Symbol& sym) const {
    switch (sym.kind) {
      case SymbolKind::kX:
        return f.x;
      case SymbolKind::kA:
        return f.a;
      case SymbolKind::kS:
        HFRT_CHECK(f.s.base >= 0);
        return f.s;
      case SymbolKind::kLocalArray:
        return f.arrays.at(sym.index);
      default:
        break;
    }
    HFRT_CHECK_MSG(false, "symbol is not an array (kind " << static_cast<int>(sym.kind) << ")");
    return {};
  }

  // Evaluates an index, rounds it to the nearest integer, checks the range (at the index's
  // location) and returns an index that is always in range, so that evaluation can go on
  // safely after the error. *known receives a constant in-range index.
  ValueId lower_index(Frame& f, const Expr& index_expr, const ArraySlots& arr,
                      std::optional<int>* known) {
    ValueId v = lower_expr(f, index_expr);
    b_.set_loc(index_expr.range.begin);
    ValueId idx = b_.unary(Op::kRound, v);
    ValueId size = b_.constant(arr.size);
    ValueId one = b_.constant(1);
    ValueId in_range = b_.binary(Op::kAnd, b_.ge(idx, one), b_.le(idx, size));
    b_.check(b_.unary(Op::kNot, in_range), ErrorKind::kIndexOutOfRange);
    ValueId safe = b_.binary(Op::kMax, b_.binary(Op::kMin, idx, size), one);
    const Inst& si = fn_.insts[safe];
    const Inst& ri = fn_.insts[in_range];
    if (si.op == Op::kConst && ri.op == Op::kConst && ri.imm != 0)
      *known = static_cast<int>(si.imm);
    return safe;
  }

  // Emits "element not assigned" checks for the elements of a local array that are not
  // provably assigned (all of them, or the one at `index`).
  void check_elements(const ArraySlots& arr, const std::vector<char>* done,
                      std::optional<ValueId> index, std::optional<int> known, ErrorKind kind) {
    if (arr.flag_base < 0) return;
    if (index) {
      if (known && (*done)[*known - 1]) return;
      if (std::all_of(done->begin(), done->end(), [](char c) { return c != 0; })) return;
      ValueId flag = b_.load_index(arr.flag_base, arr.size, *index);
      b_.check(b_.binary(Op::kEq, flag, b_.constant(0)), kind);
      return;
    }
    for (int k = 0; k < arr.size; ++k) {
      if ((*done)[k]) continue;
      b_.check(b_.binary(Op::kEq, b_.load(arr.flag_base + k), b_.constant(0)), kind);
    }
  }

  // An array passed by name to a library function or an object: all elements must be set.
  ArraySlots array_argument(Frame& f, const Expr& arg) {
    HFRT_CHECK(arg.kind == ExprKind::kName);
    ArraySlots arr = array_of(f, arg.symbol);
    if (arg.symbol.kind == SymbolKind::kLocalArray) {
      b_.set_loc(arg.range.begin);
      check_elements(arr, &f.assigned.arrays[arg.symbol.index], std::nullopt, std::nullopt,
                     ErrorKind::kArrayUninitialized);
    }
    return arr;
  }

  // ---- expressions ----------------------------------------------------------------------
  ValueId lower_expr(Frame& f, const Expr& e) {
    switch (e.kind) {
      case ExprKind::kNumber:
        return b_.constant(e.number);
      case ExprKind::kName:
        return read_scalar(f, e);
      case ExprKind::kIndex:
        return read_element(f, e);
      case ExprKind::kUnary:
        return lower_unary(f, e);
      case ExprKind::kBinary:
        return lower_binary(f, e);
      case ExprKind::kCall:
        switch (e.symbol.kind) {
          case SymbolKind::kBuiltin:
            return lower_builtin(f, e);
          case SymbolKind::kLibrary:
            return lower_library(f, e);
          case SymbolKind::kObject:
            return lower_object_call(f, e);
          default:
            break;
        }
        break;
      case ExprKind::kString:
        break;  // only a file argument, which lower_library reads as text
    }
    HFRT_CHECK_MSG(false, "unresolved expression '" << e.name << "' reached the lowering");
    return kNoValue;
  }

  ValueId read_scalar(Frame& f, const Expr& e) {
    HFRT_CHECK_MSG(e.symbol.kind == SymbolKind::kLocalScalar,
                   "name '" << e.name << "' is not a scalar");
    const int i = e.symbol.index;
    b_.set_loc(e.name_range.begin);
    if (!f.assigned.scalars[i]) {
      ValueId flag = b_.load(f.scalar_flag[i]);
      b_.check(b_.binary(Op::kEq, flag, b_.constant(0)), ErrorKind::kUninitialized);
    }
    return b_.load(f.scalar_slot[i]);
  }

  ValueId read_element(Frame& f, const Expr& e) {
    ArraySlots arr = array_of(f, e.symbol);
    std::optional<int> known;
    ValueId index = lower_index(f, *e.args[0], arr, &known);
    b_.set_loc(e.name_range.begin);
    if (arr.flag_base >= 0) {
      check_elements(arr, &f.assigned.arrays[e.symbol.index], index, known,
                     ErrorKind::kUninitialized);
    }
    return b_.load_index(arr.base, arr.size, index);
  }

  ValueId lower_unary(Frame& f, const Expr& e) {
    ValueId v = lower_expr(f, *e.args[0]);
    b_.set_loc(e.range.begin);
    switch (e.unary_op) {
      case UnaryOp::kNeg:
      case UnaryOp::kComplement:
        return b_.neg(v);
      case UnaryOp::kPlus:
        return v;
      case UnaryOp::kNot:
        return b_.unary(Op::kNot, v);
    }
    return v;
  }

  ValueId lower_binary(Frame& f, const Expr& e) {
    // Right operand first, as the original.
    ValueId r = lower_expr(f, *e.args[1]);
    ValueId l = lower_expr(f, *e.args[0]);
    b_.set_loc(operator_loc(e));
    switch (e.binary_op) {
      case BinaryOp::kAdd:
        return b_.add(l, r);
      case BinaryOp::kSub:
        return b_.sub(l, r);
      case BinaryOp::kMul:
        return b_.mul(l, r);
      case BinaryOp::kDiv:
        b_.check(b_.lt(b_.unary(Op::kAbs, r), b_.constant(kHfEps)), ErrorKind::kDivisionByZero);
        return b_.div(l, r);
      case BinaryOp::kPow:
        return lower_power(l, r);
      case BinaryOp::kUnion:
        return r_function(l, r, /*plus=*/true);
      case BinaryOp::kIntersect:
      case BinaryOp::kProduct:
        return r_function(l, r, /*plus=*/false);
      case BinaryOp::kSubtract:
        return r_function(l, b_.neg(r), /*plus=*/false);
      case BinaryOp::kLt:
        return b_.lt(l, r);
      case BinaryOp::kLe:
        return b_.le(l, r);
      case BinaryOp::kGt:
        return b_.gt(l, r);
      case BinaryOp::kGe:
        return b_.ge(l, r);
      case BinaryOp::kEq:
        return b_.binary(Op::kEqTol, l, r);
      case BinaryOp::kNe:
        return b_.binary(Op::kNeTol, l, r);
      case BinaryOp::kAnd:
        return b_.binary(Op::kAnd, l, r);
      case BinaryOp::kOr:
        return b_.binary(Op::kOr, l, r);
    }
    HFRT_CHECK(false);
    return kNoValue;
  }

  // f1 + f2 +- sqrt(f1^2 + f2^2): the original's formula with alpha = 0, term for term.
  ValueId r_function(ValueId f1, ValueId f2, bool plus) {
    ValueId sum = b_.add(f1, f2);
    ValueId root = b_.sqrt(b_.add(b_.mul(f1, f1), b_.mul(f2, f2)));
    return plus ? b_.add(sum, root) : b_.sub(sum, root);
  }

  // b ^ e with HyperFun's rules (scalar_ops.h hf_pow) and its two run-time errors.
  ValueId lower_power(ValueId base, ValueId expo) {
    ValueId eps = b_.constant(kHfEps);
    ValueId tiny = b_.lt(b_.unary(Op::kAbs, base), eps);  // |b| < 1e-6
    b_.check(b_.binary(Op::kAnd, tiny, b_.le(expo, eps)), ErrorKind::kZeroPower);
    const Inst& ei = fn_.insts[expo];
    if (ei.op == Op::kConst) {
      const double e = ei.imm;
      if (std::fabs(e - std::trunc(e)) < kHfEps) {
        const double n = std::round(std::fabs(e));
        if (n <= kMaxMulChain) {
          // The original's loop, unrolled: ((b * b) * b) ..., then 1/v for e < 0.
          ValueId v = b_.constant(1);
          if (n >= 1) v = base;
          for (int i = 1; i < static_cast<int>(n); ++i) v = b_.mul(v, base);
          if (e < 0) v = b_.div(b_.constant(1), v);
          return b_.select(tiny, b_.constant(0), v);
        }
        return b_.binary(Op::kPowHF, base, expo);
      }
      // Real exponent: a negative base (not tiny) is an error.
      b_.check(b_.binary(Op::kAnd, b_.lt(base, b_.constant(0)), b_.unary(Op::kNot, tiny)),
               ErrorKind::kNegativePower);
      return b_.binary(Op::kPowHF, base, expo);
    }
    ValueId integral = b_.lt(b_.unary(Op::kAbs, b_.sub(expo, b_.unary(Op::kTrunc, expo))), eps);
    ValueId neg_real =
        b_.binary(Op::kAnd, b_.unary(Op::kNot, integral), b_.lt(base, b_.constant(0)));
    b_.check(b_.binary(Op::kAnd, neg_real, b_.unary(Op::kNot, tiny)), ErrorKind::kNegativePower);
    return b_.binary(Op::kPowHF, base, expo);
  }

  ValueId lower_builtin(Frame& f, const Expr& e) {
    const auto which = static_cast<Builtin>(e.symbol.index);
    std::vector<ValueId> v(e.args.size());
    for (size_t i = e.args.size(); i-- > 0;) v[i] = lower_expr(f, *e.args[i]);
    b_.set_loc(e.name_range.begin);
    auto zero = [&] { return b_.constant(0); };
    switch (which) {
      case Builtin::kSqrt:
        b_.check(b_.lt(v[0], zero()), ErrorKind::kNegativeSqrt);
        return b_.sqrt(v[0]);
      case Builtin::kExp:
        return b_.unary(Op::kExp, v[0]);
      case Builtin::kLog:
      case Builtin::kLogd:
        // !(v > 0): NaN is an error too, as in the original.
        b_.check(b_.unary(Op::kNot, b_.gt(v[0], zero())), ErrorKind::kLogNonPositive);
        return b_.unary(which == Builtin::kLog ? Op::kLog : Op::kLog10, v[0]);
      case Builtin::kSin:
        return b_.unary(Op::kSin, v[0]);
      case Builtin::kCos:
        return b_.unary(Op::kCos, v[0]);
      case Builtin::kTan:
        return b_.unary(Op::kTan, v[0]);
      case Builtin::kAsin:
      case Builtin::kAcos: {
        const bool is_asin = which == Builtin::kAsin;
        b_.check(b_.gt(b_.unary(Op::kAbs, v[0]), b_.constant(1)),
                 is_asin ? ErrorKind::kAsinRange : ErrorKind::kAcosRange);
        return b_.unary(is_asin ? Op::kAsin : Op::kAcos, v[0]);
      }
      case Builtin::kAtan:
        return b_.unary(Op::kAtan, v[0]);
      case Builtin::kAbs:
        return b_.unary(Op::kAbs, v[0]);
      case Builtin::kSinh:
        return b_.unary(Op::kSinh, v[0]);
      case Builtin::kCosh:
        return b_.unary(Op::kCosh, v[0]);
      case Builtin::kTanh:
        return b_.unary(Op::kTanh, v[0]);
      case Builtin::kSign:
        return b_.unary(Op::kSign, v[0]);
      case Builtin::kCeil:
        return b_.unary(Op::kCeil, v[0]);
      case Builtin::kFloor:
        return b_.unary(Op::kFloor, v[0]);
      case Builtin::kInt:
        return b_.unary(Op::kTrunc, v[0]);
      case Builtin::kFrac:
        return b_.sub(v[0], b_.unary(Op::kTrunc, v[0]));
      case Builtin::kMax:
        return b_.binary(Op::kMax, v[0], v[1]);
      case Builtin::kMin:
        return b_.binary(Op::kMin, v[0], v[1]);
      case Builtin::kAtan2:
        return b_.binary(Op::kAtan2, v[0], v[1]);
      case Builtin::kMod:
        // fmod of the rounded operands; a zero divisor gives NaN (IEEE), as the original.
        return b_.binary(Op::kFmod, b_.unary(Op::kRound, v[0]), b_.unary(Op::kRound, v[1]));
    }
    HFRT_CHECK(false);
    return kNoValue;
  }

  ValueId lower_library(Frame& f, const Expr& e) {
    const auto which = static_cast<lang::LibraryFn>(e.symbol.index);
    const std::string_view kinds = lang::library_fn_kinds(which);
    HFRT_CHECK_EQ(kinds.size(), e.args.size());
    std::vector<stdlib::LibArg> args(e.args.size());
    for (size_t i = e.args.size(); i-- > 0;) {
      const Expr& arg = *e.args[i];
      stdlib::LibArg& la = args[i];
      la.range = arg.range;
      if (kinds[i] == 'A') {
        ArraySlots arr = array_argument(f, arg);
        la.is_array = true;
        la.base_slot = arr.base;
        la.size = arr.size;
      } else if (kinds[i] == 'F') {
        HFRT_CHECK(arg.kind == ExprKind::kString);
        la.text = arg.name;
      } else {
        la.value = lower_expr(f, arg);
      }
    }
    b_.set_loc(e.name_range.begin);
    stdlib::LibContext ctx{b_, warnings_, e.range, lib_state_, &limits_};
    ValueId v = stdlib::lower_library_call(which, ctx, args);
    HFRT_CHECK(v != kNoValue);
    return v;
  }

  // Inlines an earlier object: it works on copies of its x and a arguments; its s is the
  // caller's s argument (the original copies it in and back out), or fresh zeros.
  ValueId lower_object_call(Frame& f, const Expr& e) {
    const Object& callee = prog_.objects.at(e.symbol.index);
    HFRT_CHECK(e.args.size() >= 2 && e.args.size() <= 3);
    std::vector<ArraySlots> passed(e.args.size());
    for (size_t i = e.args.size(); i-- > 0;) passed[i] = array_argument(f, *e.args[i]);
    b_.set_loc(e.name_range.begin);

    Frame g;
    g.obj = &callee;
    auto copy_of = [&](const ArraySlots& from, int size) {
      ArraySlots to = new_array(size, 0, false);
      for (int k = 0; k < size; ++k) {
        b_.store(to.base + k, k < from.size ? b_.load(from.base + k) : b_.constant(0));
      }
      return to;
    };
    g.x = copy_of(passed[0], callee.x_size);
    g.a = copy_of(passed[1], callee.a_size);
    if (callee.has_s) {
      if (passed.size() == 3 && passed[2].size == callee.s_size) {
        g.s = passed[2];
      } else {
        g.s = new_array(callee.s_size, 0, false);
        for (int k = 0; k < callee.s_size; ++k) b_.store(g.s.base + k, b_.constant(0));
      }
    }
    return lower_body(g, /*inlined=*/true);
  }

  const Program& prog_;
  lang::DiagnosticSink* warnings_;
  const Limits& limits_;
  Function fn_;
  IrBuilder b_;
  stdlib::LibState lib_state_;
  int loop_counter_ = -1;  ///< the slot counting loop iterations (-1: no loop yet)
};

// ---- the size of an object once its calls are inlined -------------------------------------
// Counted on the AST before lowering, so that a model whose inlined size explodes (objects
// that call the previous one twice, 30 deep: 2^30 copies) is refused at once instead of after
// hours of lowering, and one whose variables need more slots than evaluators can hold (the
// JIT keeps them on the stack) never reaches them.

constexpr int64_t kSaturated = std::numeric_limits<int64_t>::max() / 4;

int64_t sat_add(int64_t a, int64_t b) {
  return a >= kSaturated - b ? kSaturated : a + b;
}

/// What inlining one object costs: lowered nodes (expressions, statements, array elements
/// copied or reset) and slots (variables, array elements, their "assigned" flags).
struct Expanded {
  int64_t nodes = 0;
  int64_t slots = 0;
};

/// The largest single contributor of the top object, where a limit error is located.
struct Contributor {
  int64_t amount = -1;
  lang::SourceRange range;
  void offer(int64_t a, lang::SourceRange r) {
    if (a > amount) {
      amount = a;
      range = r;
    }
  }
};

class SizeCounter {
 public:
  explicit SizeCounter(const Program& program) : prog_(program), memo_(program.objects.size()) {}

  /// Expanded size of object i as an inlined call (its own x/a/s copies not included).
  /// `nodes_at` / `slots_at`, when non-null, receive the largest call or array of the object.
  Expanded body(int i, Contributor* nodes_at = nullptr, Contributor* slots_at = nullptr) {
    if (memo_[i] && !nodes_at) return *memo_[i];
    const Object& obj = prog_.objects[i];
    Expanded e;
    e.slots = sat_add(e.slots, 2 * static_cast<int64_t>(obj.scalars.size()));
    for (const lang::ArrayDecl& d : obj.arrays) {
      e.slots = sat_add(e.slots, 2 * static_cast<int64_t>(d.size));
      if (slots_at) slots_at->offer(2 * static_cast<int64_t>(d.size), d.range);
    }
    Walk w{this, &e, nodes_at, slots_at};
    for (const lang::StmtPtr& st : obj.body) w.stmt(*st);
    if (obj.result) w.expr(*obj.result);
    memo_[i] = e;
    return e;
  }

  /// One call of object i: copies of x and a (and s), the reset of its locals' flags, its body.
  Expanded call(int i) {
    const Object& c = prog_.objects[i];
    Expanded e = body(i);
    int64_t copies = static_cast<int64_t>(c.x_size) + c.a_size + (c.has_s ? c.s_size : 0);
    int64_t resets = static_cast<int64_t>(c.scalars.size());
    for (const lang::ArrayDecl& d : c.arrays) resets += d.size;
    e.slots = sat_add(e.slots, copies);
    e.nodes = sat_add(e.nodes, sat_add(copies, resets));
    return e;
  }

 private:
  struct Walk {
    SizeCounter* self;
    Expanded* acc;
    Contributor* nodes_at;
    Contributor* slots_at;

    void stmt(const Stmt& s) {
      acc->nodes = sat_add(acc->nodes, 1 + static_cast<int64_t>(s.literal.size()));
      if (s.index) expr(*s.index);
      if (s.value) expr(*s.value);
      if (s.cond) expr(*s.cond);
      for (const lang::StmtPtr& t : s.then_body) stmt(*t);
      for (const lang::StmtPtr& t : s.else_body) stmt(*t);
    }
    void expr(const Expr& e) {
      acc->nodes = sat_add(acc->nodes, 1);
      for (const lang::ExprPtr& a : e.args) {
        if (a) expr(*a);
      }
      if (e.kind == ExprKind::kCall && e.symbol.kind == SymbolKind::kObject) {
        const Expanded c = self->call(e.symbol.index);
        acc->nodes = sat_add(acc->nodes, c.nodes);
        acc->slots = sat_add(acc->slots, c.slots);
        if (nodes_at) nodes_at->offer(c.nodes, e.name_range);
        if (slots_at) slots_at->offer(c.slots, e.name_range);
      }
    }
  };

  const Program& prog_;
  std::vector<std::optional<Expanded>> memo_;
};

// Reports (to `sink`, when not null) the first limit the object passes; false when it does.
bool check_expanded_size(const Program& program, int object_index, const Limits& limits,
                         lang::DiagnosticSink* sink) {
  const Object& obj = program.objects[object_index];
  SizeCounter counter(program);
  Contributor nodes_at, slots_at;
  Expanded e = counter.body(object_index, &nodes_at, &slots_at);
  // The top object's own x, a and s slots, and the loop counter.
  e.slots = sat_add(
      e.slots, static_cast<int64_t>(obj.x_size) + obj.a_size + (obj.has_s ? obj.s_size : 1) + 1);
  auto amount = [](int64_t v) {
    return v >= kSaturated ? std::string("more than 10^18") : std::to_string(v);
  };
  if (e.nodes > limits.max_model_size) {
    if (sink) {
      sink->error(nodes_at.amount >= 0 ? nodes_at.range : obj.name_range,
                  "object '" + obj.name + "' is too large once its object calls are inlined: " +
                      amount(e.nodes) + " operations, more than the limit of " +
                      std::to_string(limits.max_model_size),
                  "each call inlines a copy of the called object (a call of an object that "
                  "calls another twice copies it twice); " +
                      limit_hint("max_model_size"));
    }
    return false;
  }
  if (e.slots > limits.max_slots) {
    if (sink) {
      sink->error(slots_at.amount >= 0 ? slots_at.range : obj.name_range,
                  "object '" + obj.name + "' needs " + amount(e.slots) +
                      " slots for its variables and array elements (their 'assigned' flags and "
                      "the objects it calls included), more than the limit of " +
                      std::to_string(limits.max_slots),
                  "use smaller arrays or fewer object calls; " + limit_hint("max_slots"));
    }
    return false;
  }
  return true;
}

// What lower_object returns for an object it refused: NaN everywhere, one s of NaN.
Function stub_function(const Program& program, int object_index) {
  const Object& obj = program.objects[object_index];
  Function fn;
  fn.source = program.source;
  fn.name = obj.name;
  fn.num_inputs = obj.x_size;
  fn.num_params = obj.a_size;
  IrBuilder b(fn);
  b.set_loc(obj.name_range.begin);
  fn.s_slots.push_back(b.new_slot(kNaN));
  b.finish(b.constant(kNaN));
  return fn;
}

}  // namespace

Function lower_object(const lang::Program& program, int object_index,
                      lang::DiagnosticSink* warnings, const Limits& limits) {
  HFRT_CHECK(object_index >= 0 && object_index < static_cast<int>(program.objects.size()));
  if (!check_expanded_size(program, object_index, limits, warnings)) {
    return stub_function(program, object_index);
  }
  Lowerer lowerer(program, warnings, limits);
  return lowerer.run(object_index);
}

}  // namespace hfrt::jit
