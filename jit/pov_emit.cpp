// IR -> POV-Ray function text (see pov_emit.h for what can be written and why).
//
// Two passes. (1) A symbolic run over the instruction list builds a hash-consed expression
// DAG of POV-level operations: slots hold node ids, `if` regions run both branches on copies
// of the slot state and merge differing slots with select(); ops POV-Ray lacks are expanded
// into POV operations here, so that their operands are shared like any other value.
// (2) The DAG reachable from the result is printed: nodes used once are inlined, nodes used
// more than once (other than leaves) are bound by a let-chain of helper functions.
#include "jit/pov_emit.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <string_view>
#include <unordered_map>

#include "base/check.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

using NodeId = uint32_t;
constexpr NodeId kNone = UINT32_MAX;

// POV-level operations. kInfix prints `(a SYM b)`, kCall prints `SYM(a, ...)`.
enum class Kind : uint8_t { kConst, kVar, kNeg, kInfix, kCall };

struct Node {
  Kind kind = Kind::kConst;
  std::string_view sym;  // operator or function name; kVar: "x", "y", "z"
  int nargs = 0;
  std::array<NodeId, 4> args{kNone, kNone, kNone, kNone};
  double imm = 0;        // kConst
  bool boolean = false;  // value is known to be 0 or 1
};

class DagBuilder {
 public:
  NodeId constant(double v) {
    if (std::isnan(v)) ++undefined_reads;
    if (std::isnan(v)) v = 0;  // see PovFunction::undefined_reads
    Node n;
    n.kind = Kind::kConst;
    n.imm = v;
    n.boolean = v == 0 || v == 1;
    return intern(n);
  }
  NodeId var(int index0) {
    if (index0 >= 3) return constant(0);  // the renderer passes 3 coordinates
    static constexpr std::string_view kNames[3] = {"x", "y", "z"};
    Node n;
    n.kind = Kind::kVar;
    n.sym = kNames[index0];
    return intern(n);
  }
  NodeId neg(NodeId a) {
    if (is_const(a)) return constant(-nodes[a].imm);
    Node n;
    n.kind = Kind::kNeg;
    n.nargs = 1;
    n.args[0] = a;
    return intern(n);
  }
  NodeId infix(std::string_view sym, NodeId a, NodeId b, bool boolean = false) {
    Node n;
    n.kind = Kind::kInfix;
    n.sym = sym;
    n.nargs = 2;
    n.args[0] = a;
    n.args[1] = b;
    n.boolean = boolean;
    return intern(n);
  }
  NodeId call(std::string_view sym, std::initializer_list<NodeId> args) {
    Node n;
    n.kind = Kind::kCall;
    n.sym = sym;
    HFRT_CHECK(args.size() <= 4);
    for (NodeId a : args) n.args[n.nargs++] = a;
    return intern(n);
  }
  NodeId add(NodeId a, NodeId b) { return infix("+", a, b); }
  NodeId sub(NodeId a, NodeId b) { return infix("-", a, b); }

  /// POV select(s, neg, nonneg): `neg` where s < 0.
  NodeId select_sign(NodeId s, NodeId neg_value, NodeId nonneg_value) {
    if (neg_value == nonneg_value) return neg_value;
    if (is_const(s)) return nodes[s].imm < 0 ? neg_value : nonneg_value;
    return call("select", {s, neg_value, nonneg_value});
  }
  /// c != 0 ? a : b for a 0/1 condition c. A comparison condition p < q becomes the sign
  /// test select(p - q, a, b) directly (one operation less for POV-Ray's VM).
  NodeId select01(NodeId c, NodeId a, NodeId b) {
    if (a == b) return a;
    if (is_const(c)) return nodes[c].imm != 0 ? a : b;
    const Node& cn = nodes[c];
    if (cn.kind == Kind::kInfix && cn.sym == "<")
      return select_sign(sub(cn.args[0], cn.args[1]), a, b);
    if (cn.kind == Kind::kInfix && cn.sym == ">")
      return select_sign(sub(cn.args[1], cn.args[0]), a, b);
    return select_sign(neg(c), a, b);
  }
  /// |v| >= 1e-6 as 0/1 (HyperFun's truth value); a known 0/1 value is its own truth.
  NodeId truth(NodeId v) {
    if (nodes[v].boolean) return v;
    return infix(">=", call("abs", {v}), constant(1e-6), true);
  }

  bool is_const(NodeId a) const { return nodes[a].kind == Kind::kConst; }

  std::vector<Node> nodes;
  int undefined_reads = 0;

 private:
  NodeId intern(const Node& n) {
    std::string key;
    key.reserve(48);
    key += char('0' + int(n.kind));
    key += n.sym;
    key += '|';
    if (n.kind == Kind::kConst) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%a", n.imm);
      key += buf;
    }
    for (int i = 0; i < n.nargs; ++i) key += std::to_string(n.args[i]) + ',';
    auto [it, inserted] = index_.try_emplace(key, NodeId(nodes.size()));
    if (inserted) nodes.push_back(n);
    return it->second;
  }
  std::unordered_map<std::string, NodeId> index_;
};

lang::SourceRange range_of(const Inst& in) {
  return lang::SourceRange{in.loc, 1};
}

// Pass 1: the symbolic run.
class SymbolicRun {
 public:
  SymbolicRun(const Function& fn, const PovEmitOptions& opts, lang::DiagnosticSink* diags)
      : fn_(fn), opts_(opts), diags_(diags), val_(fn.insts.size(), kNone) {
    // Matching control markers: for kIf the index of its kElse (or kEndIf), for kElse its kEndIf.
    match_.assign(fn.insts.size(), -1);
    std::vector<size_t> stack;
    for (size_t i = 0; i < fn.insts.size(); ++i) {
      Op op = fn.insts[i].op;
      if (op == Op::kIf || op == Op::kLoop) {
        stack.push_back(i);
      } else if (op == Op::kElse) {
        match_[stack.back()] = int(i);
        stack.back() = i;
      } else if (op == Op::kEndIf || op == Op::kEndLoop) {
        match_[stack.back()] = int(i);
        stack.pop_back();
      }
    }
    slots_.resize(fn.num_slots);
    for (int s = 0; s < fn.num_slots; ++s) {
      double init = s < int(fn.slot_init.size()) ? fn.slot_init[s] : NAN;
      slots_[s] = kNone;  // created lazily: an undefined slot that is never read costs nothing
      init_.push_back(init);
    }
  }

  /// Runs the whole function; false after reporting an error.
  bool run() { return run_range(0, fn_.insts.size()); }

  NodeId value(ValueId v) const { return val_[v]; }
  DagBuilder& dag() { return dag_; }
  int dropped_checks() const { return dropped_checks_; }

 private:
  NodeId slot(int s) {
    if (slots_[s] == kNone) slots_[s] = dag_.constant(init_[s]);
    return slots_[s];
  }

  bool fail(const Inst& in, const std::string& construct, const std::string& hint) {
    if (diags_) {
      diags_->error(range_of(in), "cannot write this model as a POV-Ray function: " + construct,
                    hint);
    }
    return false;
  }

  bool const_index(const Inst& in, int* slot_out) {
    NodeId idx = val_[in.args[0]];
    if (!dag_.is_const(idx)) return false;
    const double i = dag_.nodes[idx].imm;
    const int size = int(in.imm);
    if (!(i >= 1 && i <= size && i == std::floor(i))) return false;
    *slot_out = in.aux + int(i) - 1;
    return true;
  }

  NodeId table_tree(const std::vector<double>& t, NodeId index, int lo, int hi) {
    if (lo == hi) return dag_.constant(t[lo]);
    int mid = (lo + hi) / 2;
    return dag_.select_sign(dag_.sub(index, dag_.constant(mid + 0.5)),
                            table_tree(t, index, lo, mid), table_tree(t, index, mid + 1, hi));
  }

  NodeId value_op(const Inst& in) {
    DagBuilder& d = dag_;
    auto a = [&](int k) { return val_[in.args[k]]; };
    switch (in.op) {
      case Op::kConst:
        return d.constant(in.imm);
      case Op::kInput:
        return d.var(in.aux);
      case Op::kParam:
        return d.constant(in.aux < int(opts_.params.size()) ? opts_.params[in.aux] : 0.0);
      case Op::kAdd:
        return d.add(a(0), a(1));
      case Op::kSub:
        return d.sub(a(0), a(1));
      case Op::kMul:
        return d.infix("*", a(0), a(1));
      case Op::kDiv:
        return d.infix("/", a(0), a(1));
      case Op::kNeg:
        return d.neg(a(0));
      case Op::kAbs:
        return d.call("abs", {a(0)});
      case Op::kMin:
        return d.call("min", {a(0), a(1)});
      case Op::kMax:
        return d.call("max", {a(0), a(1)});
      case Op::kSqrt:
        return d.call("sqrt", {a(0)});
      case Op::kExp:
        return d.call("exp", {a(0)});
      case Op::kLog:
        return d.call("ln", {a(0)});  // POV: ln is natural, log is base 10
      case Op::kLog10:
        return d.call("log", {a(0)});
      case Op::kSin:
        return d.call("sin", {a(0)});
      case Op::kCos:
        return d.call("cos", {a(0)});
      case Op::kTan:
        return d.call("tan", {a(0)});
      case Op::kAsin:
        return d.call("asin", {a(0)});
      case Op::kAcos:
        return d.call("acos", {a(0)});
      case Op::kAtan:
        return d.call("atan", {a(0)});
      case Op::kAtan2:
        return d.call("atan2", {a(0), a(1)});
      case Op::kSinh:
        return d.call("sinh", {a(0)});
      case Op::kCosh:
        return d.call("cosh", {a(0)});
      case Op::kTanh:
        return d.call("tanh", {a(0)});
      case Op::kFloor:
        return d.call("floor", {a(0)});
      case Op::kCeil:
        return d.call("ceil", {a(0)});
      case Op::kTrunc:
        return d.call("int", {a(0)});  // POV int() truncates towards 0
      case Op::kRound: {
        // Half away from zero: v < 0 ? -floor(0.5 - v) : floor(v + 0.5).
        NodeId v = a(0), half = d.constant(0.5);
        return d.select_sign(v, d.neg(d.call("floor", {d.sub(half, v)})),
                             d.call("floor", {d.add(v, half)}));
      }
      case Op::kFmod:
        return d.call("mod", {a(0), a(1)});
      case Op::kPow:
        return d.call("pow", {a(0), a(1)});
      case Op::kPowHF: {
        // |b| < 1e-6 -> 0; integral e -> b^round(e) (pow is exact enough for integral e and
        // takes negative bases); else b^e.
        NodeId b = a(0), e = a(1);
        NodeId p;
        if (d.is_const(e)) {
          double ev = d.nodes[e].imm;
          double fr = ev - std::trunc(ev);
          p = std::fabs(fr) < 1e-6 ? d.call("pow", {b, d.constant(std::round(ev))})
                                   : d.call("pow", {b, e});
        } else {
          NodeId ie = d.call("int", {e});
          NodeId frac_small = d.sub(d.call("abs", {d.sub(e, ie)}), d.constant(1e-6));
          p = d.select_sign(frac_small, d.call("pow", {b, ie}), d.call("pow", {b, e}));
        }
        return d.select_sign(d.sub(d.call("abs", {b}), d.constant(1e-6)), d.constant(0), p);
      }
      case Op::kSign:
        return d.call("select", {a(0), d.constant(-1), d.constant(0), d.constant(1)});
      case Op::kLt:
        return d.infix("<", a(0), a(1), true);
      case Op::kLe:
        return d.infix("<=", a(0), a(1), true);
      case Op::kGt:
        return d.infix(">", a(0), a(1), true);
      case Op::kGe:
        return d.infix(">=", a(0), a(1), true);
      case Op::kEq:
        return d.infix("=", a(0), a(1), true);
      case Op::kNe:
        return d.infix("!=", a(0), a(1), true);
      case Op::kEqTol:
        return d.infix("<", d.call("abs", {d.sub(a(0), a(1))}), d.constant(1e-6), true);
      case Op::kNeTol:
        return d.infix(">=", d.call("abs", {d.sub(a(0), a(1))}), d.constant(1e-6), true);
      case Op::kTruth:
        return d.truth(a(0));
      case Op::kAnd:
        return d.infix("&", d.truth(a(0)), d.truth(a(1)), true);
      case Op::kOr:
        return d.infix("|", d.truth(a(0)), d.truth(a(1)), true);
      case Op::kNot:
        return d.sub(d.constant(1), d.truth(a(0)));
      case Op::kSelect:
        return d.select01(a(0), a(1), a(2));
      case Op::kCbrt: {
        // POV-Ray has no cbrt, and its pow of a negative base and 1/3 is not real:
        // select(v, -pow(-v, 1/3), pow(v, 1/3)) (select(s, a, b) is a where s < 0).
        NodeId v = a(0), third = d.constant(1.0 / 3.0);
        return d.select_sign(v, d.neg(d.call("pow", {d.neg(v), third})), d.call("pow", {v, third}));
      }
      case Op::kLoadSlot:
        return slot(in.aux);
      case Op::kTableLoad: {
        const std::vector<double>& t = fn_.tables[in.aux];
        NodeId idx = a(0);
        if (d.is_const(idx)) {
          double i = d.nodes[idx].imm;
          HFRT_CHECK(i >= 0 && i < double(t.size()));
          return d.constant(t[size_t(i)]);
        }
        return table_tree(t, idx, 0, int(t.size()) - 1);
      }
      // run_range handles these itself.
      case Op::kStoreSlot:
      case Op::kLoadIdx:
      case Op::kStoreIdx:
      case Op::kSurface:
      case Op::kCheck:
      case Op::kIf:
      case Op::kElse:
      case Op::kEndIf:
      case Op::kLoop:
      case Op::kLoopTest:
      case Op::kEndLoop:
        HFRT_CHECK_MSG(false, "value_op on a non-value op");
        break;
    }
    return kNone;
  }

  bool run_range(size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const Inst& in = fn_.insts[i];
      switch (in.op) {
        case Op::kStoreSlot:
          slots_[in.aux] = val_[in.args[0]];
          break;
        case Op::kCheck:
          ++dropped_checks_;
          break;
        case Op::kLoadIdx:
        case Op::kStoreIdx: {
          int s = 0;
          if (!const_index(in, &s)) {
            return fail(in,
                        std::string("an array element ") +
                            (in.op == Op::kLoadIdx ? "read" : "written") +
                            " with a computed index (POV-Ray functions have no arrays)",
                        "index arrays with constants, or unroll the computation by hand");
          }
          if (in.op == Op::kLoadIdx) {
            val_[i] = slot(s);
          } else {
            slots_[s] = val_[in.args[1]];
          }
          break;
        }
        case Op::kTableLoad:
          if (!dag_.is_const(val_[in.args[0]]) && int(fn_.tables[in.aux].size()) > kMaxPovTable) {
            return fail(in,
                        "a lookup table of " + std::to_string(fn_.tables[in.aux].size()) +
                            " entries read with a computed index",
                        "POV-Ray functions have no arrays; tables up to " +
                            std::to_string(kMaxPovTable) + " entries become select() trees");
          }
          val_[i] = value_op(in);
          break;
        case Op::kSurface:
          return fail(in, "a mesh or Bezier patch leaf (POV-Ray functions cannot read files)",
                      "export the surface as a POV-Ray mesh or bicubic_patch object and combine "
                      "it in the scene, or render the model with `hfrt render`");
        case Op::kLoop:
          return fail(in, "a while loop (POV-Ray functions have no loops)",
                      "rewrite the loop with a fixed number of steps written out, or render the "
                      "model with `hfrt render`");
        case Op::kIf: {
          const size_t mid = size_t(match_[i]);
          const bool has_else = fn_.insts[mid].op == Op::kElse;
          const size_t end_if = has_else ? size_t(match_[mid]) : mid;
          const NodeId cond = val_[in.args[0]];
          std::vector<NodeId> before = slots_;
          if (!run_range(i + 1, mid)) return false;
          std::vector<NodeId> then_state = std::move(slots_);
          slots_ = std::move(before);
          if (has_else && !run_range(mid + 1, end_if)) return false;
          for (size_t s = 0; s < slots_.size(); ++s) {
            if (then_state[s] == slots_[s]) continue;
            NodeId t = then_state[s] == kNone ? slot_value_init(s) : then_state[s];
            NodeId e = slots_[s] == kNone ? slot_value_init(s) : slots_[s];
            slots_[s] = dag_.select01(cond, t, e);
          }
          i = end_if;
          break;
        }
        case Op::kElse:
        case Op::kEndIf:
        case Op::kLoopTest:
        case Op::kEndLoop:
          HFRT_CHECK_MSG(false, "unbalanced control marker");
          break;
        case Op::kConst:
        case Op::kInput:
        case Op::kParam:
        case Op::kLoadSlot:
          HFRT_OP_CASES_ARITH
          val_[i] = value_op(in);
          break;
      }
    }
    return true;
  }

  NodeId slot_value_init(size_t s) { return dag_.constant(init_[s]); }

  const Function& fn_;
  const PovEmitOptions& opts_;
  lang::DiagnosticSink* diags_;
  DagBuilder dag_;
  std::vector<NodeId> val_;
  std::vector<int> match_;
  std::vector<NodeId> slots_;
  std::vector<double> init_;
  int dropped_checks_ = 0;
};

std::string format_number(double v) {
  if (std::isinf(v)) v = v > 0 ? 1e300 : -1e300;  // POV-Ray has no infinity literal
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  // Shortest text that reads back exactly: try fewer digits first.
  for (int prec = 6; prec < 17; ++prec) {
    char t[40];
    std::snprintf(t, sizeof t, "%.*g", prec, v);
    if (std::strtod(t, nullptr) == v) {
      std::snprintf(buf, sizeof buf, "%s", t);
      break;
    }
  }
  std::string s = buf;
  return std::signbit(v) ? "(" + s + ")" : s;  // "(-0)" too: no bare unary minus in operands
}

// Pass 2: printing with the let-chain.
class Printer {
 public:
  Printer(const std::vector<Node>& nodes, NodeId root) : nodes_(nodes), root_(root) {}

  bool print(const std::string& name, PovFunction* out, std::string* error) {
    // Uses of each reachable node (edges from reachable nodes, plus the root's own use).
    std::vector<int> uses(nodes_.size(), 0);
    std::vector<char> reached(nodes_.size(), 0);
    std::vector<NodeId> stack{root_};
    reached[root_] = 1;
    while (!stack.empty()) {
      NodeId n = stack.back();
      stack.pop_back();
      for (int k = 0; k < nodes_[n].nargs; ++k) {
        NodeId c = nodes_[n].args[k];
        ++uses[c];
        if (!reached[c]) {
          reached[c] = 1;
          stack.push_back(c);
        }
      }
    }
    bound_index_.assign(nodes_.size(), -1);
    for (NodeId n = 0; n < nodes_.size(); ++n) {
      if (!reached[n]) continue;
      ++out->expression_nodes;
      const Kind k = nodes_[n].kind;
      // Leaves, and one operation over leaves (x * x, x - 0.45), are cheaper to repeat than
      // to pass through a helper call.
      bool cheap = k == Kind::kConst || k == Kind::kVar;
      if (!cheap) {
        cheap = true;
        for (int a = 0; a < nodes_[n].nargs; ++a) {
          const Kind ak = nodes_[nodes_[n].args[a]].kind;
          cheap = cheap && (ak == Kind::kConst || ak == Kind::kVar);
        }
      }
      if (uses[n] >= 2 && !cheap) {
        bound_index_[n] = int(bound_.size());
        bound_.push_back(n);  // node ids are topological: arguments precede their users
      }
    }
    const int m = int(bound_.size());
    // Stage k (0..m-1) binds bound_[k]; stage m computes the root. last_use[j]: the last
    // stage whose expression references bound_[j].
    std::vector<std::vector<int>> refs(m + 1);
    std::vector<int> last_use(m, -1);
    for (int k = 0; k <= m; ++k) {
      NodeId e = k < m ? bound_[k] : root_;
      collect_refs(e, /*top=*/true, &refs[k]);
      for (int j : refs[k]) last_use[j] = std::max(last_use[j], k);
    }
    // live[k]: bound values (index < k) passed into stage k.
    std::vector<std::vector<int>> live(m + 1);
    for (int k = 1; k <= m; ++k) {
      for (int j : live[k - 1])
        if (last_use[j] >= k) live[k].push_back(j);
      if (last_use[k - 1] >= k) live[k].push_back(k - 1);
      if (int(live[k].size()) + 3 > kMaxPovParams) {
        *error = std::to_string(live[k].size()) +
                 " shared intermediate values are alive at once, more than POV-Ray's " +
                 std::to_string(kMaxPovParams) + "-parameter limit for one function allows";
        return false;
      }
    }
    // Helpers are declared before use: the last stage first.
    auto stage_name = [&](int k) { return k == 0 ? name : name + "_" + std::to_string(k); };
    std::string text;
    for (int k = m; k >= 0; --k) {
      std::string params = "x, y, z";
      for (int j : live[k]) params += ", " + param_name(j);
      std::string body;
      if (k == m) {
        body = expr(root_, true);
      } else {
        body = stage_name(k + 1) + "(x, y, z";
        for (int j : live[k + 1]) body += ", " + (j == k ? expr(bound_[k], true) : param_name(j));
        body += ")";
      }
      text += "#declare " + stage_name(k) + " = function(" + params + ") { " + body + " }\n";
    }
    out->text = std::move(text);
    out->helpers = m;
    out->shared_values = m;
    return true;
  }

 private:
  static std::string param_name(int j) { return "p" + std::to_string(j); }

  void collect_refs(NodeId n, bool top, std::vector<int>* refs) {
    if (!top && bound_index_[n] >= 0) {
      if (std::find(refs->begin(), refs->end(), bound_index_[n]) == refs->end())
        refs->push_back(bound_index_[n]);
      return;
    }
    for (int k = 0; k < nodes_[n].nargs; ++k) collect_refs(nodes_[n].args[k], false, refs);
  }

  std::string expr(NodeId n, bool top) {
    if (!top && bound_index_[n] >= 0) return param_name(bound_index_[n]);
    const Node& node = nodes_[n];
    switch (node.kind) {
      case Kind::kConst:
        return format_number(node.imm);
      case Kind::kVar:
        return std::string(node.sym);
      case Kind::kNeg:
        return "(-" + expr(node.args[0], false) + ")";
      case Kind::kInfix:
        return "(" + expr(node.args[0], false) + " " + std::string(node.sym) + " " +
               expr(node.args[1], false) + ")";
      case Kind::kCall: {
        std::string s = std::string(node.sym) + "(";
        for (int k = 0; k < node.nargs; ++k) s += (k ? ", " : "") + expr(node.args[k], false);
        return s + ")";
      }
    }
    return {};
  }

  const std::vector<Node>& nodes_;
  NodeId root_;
  std::vector<int> bound_index_;
  std::vector<NodeId> bound_;
};

}  // namespace

bool emit_pov_function(const Function& fn, const PovEmitOptions& options, PovFunction* out,
                       lang::DiagnosticSink* diags) {
  HFRT_CHECK(out != nullptr);
  HFRT_CHECK(fn.result != kNoValue);
  *out = PovFunction{};
  SymbolicRun run(fn, options, diags);
  if (!run.run()) return false;
  const NodeId root = run.value(fn.result);
  HFRT_CHECK(root != kNone);
  Printer printer(run.dag().nodes, root);
  std::string error;
  if (!printer.print(options.name, out, &error)) {
    if (diags) {
      lang::SourceLoc loc = fn.insts.empty() ? lang::SourceLoc{} : fn.insts.back().loc;
      diags->error(lang::SourceRange{loc, 0},
                   "cannot write this model as a POV-Ray function: " + error,
                   "split the model, or render it with `hfrt render`");
    }
    return false;
  }
  out->dropped_checks = run.dropped_checks();
  out->undefined_reads = run.dag().undefined_reads;
  return true;
}

std::string pov_identifier(const std::string& base) {
  // POV-Ray 3.7 reserved words that a HyperFun object name may plausibly spell (all POV
  // keywords are lower case, so a name with an upper-case letter never collides).
  static constexpr std::string_view kKeywords[] = {"abs",
                                                   "acos",
                                                   "acosh",
                                                   "all",
                                                   "alpha",
                                                   "angle",
                                                   "area_light",
                                                   "asin",
                                                   "asinh",
                                                   "atan",
                                                   "atan2",
                                                   "atanh",
                                                   "background",
                                                   "bezier_spline",
                                                   "bicubic_patch",
                                                   "black_hole",
                                                   "blob",
                                                   "blue",
                                                   "box",
                                                   "boxed",
                                                   "bump_map",
                                                   "camera",
                                                   "ceil",
                                                   "checker",
                                                   "clipped_by",
                                                   "color",
                                                   "colour",
                                                   "cone",
                                                   "contained_by",
                                                   "cos",
                                                   "cosh",
                                                   "cube",
                                                   "cubic",
                                                   "cylinder",
                                                   "cylindrical",
                                                   "declare",
                                                   "default",
                                                   "degrees",
                                                   "density",
                                                   "difference",
                                                   "disc",
                                                   "div",
                                                   "else",
                                                   "end",
                                                   "exp",
                                                   "false",
                                                   "filter",
                                                   "finish",
                                                   "floor",
                                                   "fog",
                                                   "function",
                                                   "gradient",
                                                   "granite",
                                                   "green",
                                                   "height_field",
                                                   "hexagon",
                                                   "if",
                                                   "image_map",
                                                   "int",
                                                   "interior",
                                                   "intersection",
                                                   "isosurface",
                                                   "julia_fractal",
                                                   "lathe",
                                                   "light_source",
                                                   "ln",
                                                   "local",
                                                   "log",
                                                   "macro",
                                                   "material",
                                                   "max",
                                                   "media",
                                                   "merge",
                                                   "mesh",
                                                   "mesh2",
                                                   "min",
                                                   "mod",
                                                   "no",
                                                   "noise_generator",
                                                   "normal",
                                                   "object",
                                                   "off",
                                                   "on",
                                                   "onion",
                                                   "ovus",
                                                   "parametric",
                                                   "pattern",
                                                   "pi",
                                                   "pigment",
                                                   "plane",
                                                   "planar",
                                                   "poly",
                                                   "polygon",
                                                   "polynomial",
                                                   "pow",
                                                   "prism",
                                                   "quadric",
                                                   "quartic",
                                                   "radians",
                                                   "rand",
                                                   "red",
                                                   "ripples",
                                                   "rotate",
                                                   "scale",
                                                   "select",
                                                   "sin",
                                                   "sinh",
                                                   "sky",
                                                   "slope",
                                                   "sor",
                                                   "sphere",
                                                   "sphere_sweep",
                                                   "spherical",
                                                   "spline",
                                                   "sqrt",
                                                   "sum",
                                                   "superellipsoid",
                                                   "t",
                                                   "tan",
                                                   "tanh",
                                                   "text",
                                                   "texture",
                                                   "torus",
                                                   "transform",
                                                   "translate",
                                                   "triangle",
                                                   "true",
                                                   "u",
                                                   "union",
                                                   "v",
                                                   "version",
                                                   "warp",
                                                   "wood",
                                                   "x",
                                                   "y",
                                                   "yes",
                                                   "z"};
  std::string s;
  for (char c : base) {
    bool ok =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
    s += ok ? c : '_';
  }
  if (s.empty() || (s[0] >= '0' && s[0] <= '9')) s = "hf_" + s;
  for (std::string_view k : kKeywords)
    if (s == k) return "hf_" + s;
  return s;
}

}  // namespace hfrt::jit
