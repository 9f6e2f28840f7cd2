#include "tests/jit/random_program.h"

#include <cmath>
#include <random>

#include "ir/builder.h"

namespace hfrt::jit::testing {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

struct OpInfo {
  Op op;
  int args;
};

/// Every op computed from arguments (the generator's expression ops). kSurface needs a loaded
/// mesh (tests/jit/surface_test.cpp compares its evaluators).
std::vector<OpInfo> expression_ops(bool tame) {
  std::vector<OpInfo> ops;
#define HFRT_X(name, n, ...) \
  if (op_is_arith(Op::k##name)) ops.push_back({Op::k##name, n});
  HFRT_IR_OPS(HFRT_X)
#undef HFRT_X
  if (!tame) return ops;
  std::vector<OpInfo> out;
  for (OpInfo o : ops) {
    switch (o.op) {
      case Op::kAdd:
      case Op::kSub:
      case Op::kMul:
      case Op::kNeg:
      case Op::kAbs:
      case Op::kMin:
      case Op::kMax:
      case Op::kSin:
      case Op::kCos:
      case Op::kAtan:
      case Op::kTanh:
      case Op::kSelect:
      case Op::kLt:
      case Op::kGt:
        out.push_back(o);
        break;
      default:
        break;
    }
  }
  return out;
}

class Generator {
 public:
  Generator(uint64_t seed, const RandomProgramOptions& options)
      : rng_(seed), options_(options), b_(fn_), ops_(expression_ops(options.tame)) {}

  Function run() {
    fn_.name = "random";
    fn_.num_inputs = options_.num_inputs;
    fn_.num_params = options_.num_params;
    scopes_.emplace_back();
    for (int k = 0; k < options_.num_inputs; ++k) add(b_.input(k));
    for (int k = 0; k < options_.num_params; ++k) add(b_.param(k));
    for (int k = 0; k < 3; ++k) add(b_.constant(random_constant()));
    int num_scalars = 2 + uniform(0, 3);
    for (int k = 0; k < num_scalars; ++k) {
      scalars_.push_back(b_.new_slot(chance(0.2) ? std::nan("") : random_constant()));
    }
    for (int size : {3, 12}) {  // a select-chain array and a gather/scatter array
      int base = -1;
      for (int j = 0; j < size; ++j) {
        int s = b_.new_slot(random_constant());
        if (j == 0) base = s;
      }
      arrays_.push_back({base, size});
    }
    if (!options_.tame) {
      int n = uniform(1, 9);
      std::vector<double> t;
      for (int j = 0; j < n; ++j) t.push_back(random_constant());
      tables_.push_back({b_.add_table(t), n});
    }
    statements(options_.statements);
    // s[]: up to two scalar slots.
    int ns = uniform(0, 2);
    for (int k = 0; k < ns; ++k) fn_.s_slots.push_back(scalars_[uniform(0, num_scalars - 1)]);
    b_.finish(pick_outer());
    return std::move(fn_);
  }

 private:
  struct Array {
    int base, size;
  };
  struct Table {
    int id, size;
  };

  int uniform(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }
  bool chance(double p) { return std::uniform_real_distribution<double>(0, 1)(rng_) < p; }
  double random_constant() {
    switch (uniform(0, 4)) {
      case 0:
        return uniform(-3, 3);
      case 1:
        return uniform(-6, 6) * 0.5;
      default:
        return std::uniform_real_distribution<double>(-3, 3)(rng_);
    }
  }

  void add(ValueId v) { scopes_.back().push_back(v); }
  /// A value visible here, biased towards recent ones so expressions grow deep.
  ValueId pick() {
    size_t total = 0;
    for (auto& s : scopes_) total += s.size();
    size_t i =
        total - 1 -
        std::min<size_t>(total - 1, static_cast<size_t>(std::abs(std::normal_distribution<double>(
                                        0, total / 3.0 + 1)(rng_))));
    for (auto& s : scopes_) {
      if (i < s.size()) return s[i];
      i -= s.size();
    }
    return scopes_.front().front();
  }
  ValueId pick_outer() {
    auto& s = scopes_.front();
    return s[s.size() - 1 - std::min<size_t>(s.size() - 1, uniform(0, 3))];
  }
  /// A 0/1 condition.
  ValueId condition() {
    switch (uniform(0, options_.tame ? 1 : 3)) {
      case 0:
        return b_.lt(pick(), pick());
      case 1:
        return b_.gt(pick(), b_.constant(random_constant()));
      case 2:
        return b_.unary(Op::kTruth, pick());
      default:
        return b_.binary(Op::kEqTol, b_.unary(Op::kRound, pick()), b_.constant(uniform(-2, 2)));
    }
  }
  /// An integral 1-based index in [1, size] from any value (NaN and inf give 1).
  ValueId safe_index(int size) {
    ValueId t =
        b_.binary(Op::kFmod, b_.unary(Op::kFloor, b_.unary(Op::kAbs, pick())), b_.constant(size));
    ValueId ok = b_.ge(t, b_.constant(0));
    return b_.add(b_.select(ok, t, b_.constant(0)), b_.constant(1));
  }

  void expression() {
    const OpInfo& o = ops_[uniform(0, static_cast<int>(ops_.size()) - 1)];
    ValueId v;
    if (o.op == Op::kSelect) {
      v = b_.select(condition(), pick(), pick());
    } else if (o.args == 1) {
      v = b_.unary(o.op, pick());
    } else {
      v = b_.binary(o.op, pick(), pick());
    }
    add(v);
  }

  void statements(int budget) {
    for (int k = 0; k < budget; ++k) statement();
  }

  void statement() {
    int depth = static_cast<int>(scopes_.size()) - 1;
    int r = uniform(0, 99);
    if (r < 50) {
      expression();
    } else if (r < 58) {
      b_.store(scalars_[uniform(0, static_cast<int>(scalars_.size()) - 1)], pick());
    } else if (r < 64) {
      add(b_.load(scalars_[uniform(0, static_cast<int>(scalars_.size()) - 1)]));
    } else if (r < 70) {
      const Array& a = arrays_[uniform(0, 1)];
      b_.store_index(a.base, a.size, safe_index(a.size), pick());
    } else if (r < 77) {
      const Array& a = arrays_[uniform(0, 1)];
      add(b_.load_index(a.base, a.size, safe_index(a.size)));
    } else if (r < 80 && !tables_.empty()) {
      const Table& t = tables_[0];
      add(b_.table_load(t.id, b_.sub(safe_index(t.size), b_.constant(1))));
    } else if (r < 84 && !options_.tame) {
      b_.check(condition(), static_cast<ErrorKind>(uniform(0, error_kind_count() - 1)));
    } else if (r < 92 && depth < options_.max_depth) {
      b_.begin_if(condition());
      region(uniform(1, 6));
      if (chance(0.5)) {
        b_.begin_else();
        region(uniform(1, 6));
      }
      b_.end_if();
    } else if (r < 97 && depth < options_.max_depth) {
      loop();
    } else {
      expression();
    }
  }

  void region(int budget) {
    scopes_.emplace_back();
    statements(budget);
    scopes_.pop_back();
  }

  /// while (i < K and i < |v| + 1) { ...; i = i + 1 } with a fresh counter slot.
  void loop() {
    int counter = b_.new_slot(0);
    b_.store(counter, b_.constant(0));
    ValueId bound = b_.add(b_.unary(Op::kAbs, pick()), b_.constant(1));
    b_.begin_loop();
    scopes_.emplace_back();
    ValueId i = b_.load(counter);
    add(i);
    ValueId go = b_.binary(Op::kAnd, b_.lt(i, b_.constant(uniform(1, options_.max_loop_trips))),
                           b_.lt(i, bound));
    b_.loop_test(go);
    statements(uniform(1, 6));
    b_.store(counter, b_.add(i, b_.constant(1)));
    scopes_.pop_back();
    b_.end_loop();
  }

  std::mt19937_64 rng_;
  RandomProgramOptions options_;
  Function fn_;
  IrBuilder b_;
  std::vector<OpInfo> ops_;
  std::vector<std::vector<ValueId>> scopes_;
  std::vector<int> scalars_;
  std::vector<Array> arrays_;
  std::vector<Table> tables_;
};

}  // namespace

Function random_program(uint64_t seed, const RandomProgramOptions& options) {
  return Generator(seed, options).run();
}

std::vector<std::vector<double>> random_points(uint64_t seed, int count, int dims) {
  std::mt19937_64 rng(seed ^ 0x9e3779b97f4a7c15ull);
  std::uniform_real_distribution<double> u(-3, 3);
  std::uniform_int_distribution<int> kind(0, 9);
  std::vector<std::vector<double>> pts(count, std::vector<double>(dims));
  for (auto& p : pts) {
    for (double& v : p) {
      switch (kind(rng)) {
        case 0:
          v = std::round(u(rng));
          break;  // integers
        case 1:
          v = std::round(u(rng) * 2) / 2;
          break;  // halves: round() ties
        case 2:
          v = 0;
          break;
        case 3:
          v = std::round(u(rng)) + 1e-7;
          break;  // just off a tie
        default:
          v = u(rng);
          break;
      }
    }
  }
  return pts;
}

}  // namespace hfrt::jit::testing
