// Semantic checks: name resolution, call signatures, array sizes, the model assignment rule
// and a definite-assignment analysis that warns about possibly uninitialised reads.
//
// The checks run object by object, in file order, so that "earlier object" is simply "an
// object whose index is below the current one". Objects whose text had syntax errors are
// registered (their names can be called) but their bodies are not checked: a recovered AST
// only produces follow-up errors.
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "base/check.h"
#include "lang/builtins.h"
#include "lang/frontend.h"
#include "lang/library_table.h"
#include "lang/names.h"

namespace hfrt::lang {
namespace {

int edit_distance(std::string_view a, std::string_view b) {
  std::vector<int> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = static_cast<int>(j);
  for (size_t i = 1; i <= a.size(); ++i) {
    int diag = row[0];
    row[0] = static_cast<int>(i);
    for (size_t j = 1; j <= b.size(); ++j) {
      int up = row[j];
      bool same = same_name(a.substr(i - 1, 1), b.substr(j - 1, 1));
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (same ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

// The closest candidate within a small edit distance, for "did you mean" hints.
std::string closest(std::string_view name, const std::vector<std::string>& candidates) {
  if (name.size() > 64) return {};
  std::string best;
  int best_d = name.size() <= 3 ? 1 : 2;
  for (const std::string& c : candidates) {
    if (c.size() > 64) continue;
    int d = edit_distance(name, c);
    if (d <= best_d && (best.empty() || d < best_d)) {
      best = c;
      best_d = d;
    }
  }
  return best;
}

std::string plural(int n, std::string_view word) {
  return std::to_string(n) + " " + std::string(word) + (n == 1 ? "" : "s");
}

std::string where(SourceRange r) {
  return std::to_string(r.begin.line) + ":" + std::to_string(r.begin.col);
}

// What a reserved name is, or nullopt for a free name.
std::optional<std::string> reserved_reason(std::string_view name) {
  if (same_name(name, "x") || same_name(name, "a") || same_name(name, "s")) {
    return "a header array";
  }
  if (find_builtin(name)) return "a built-in function";
  if (find_library_fn(name)) return "a library function";
  return std::nullopt;
}

class Checker {
 public:
  Checker(Program& prog, DiagnosticSink& diags) : prog_(prog), diags_(diags) {}

  void run() {
    for (size_t i = 0; i < prog_.objects.size(); ++i) register_object(static_cast<int>(i));
    for (size_t i = 0; i < prog_.objects.size(); ++i) {
      if (diags_.truncated()) break;
      if (!prog_.objects[i].had_syntax_errors) check_object(static_cast<int>(i));
    }
  }

 private:
  // ---- objects ------------------------------------------------------------------------
  void register_object(int index) {
    Object& obj = prog_.objects[index];
    std::string key = fold_case(obj.name);
    auto [it, inserted] = objects_.emplace(key, index);
    if (!inserted) {
      diags_.error(obj.name_range,
                   "object '" + obj.name + "' is already defined (at " +
                       where(prog_.objects[it->second].name_range) + ")",
                   "object names must be unique (names ignore case); rename one of them");
    }
    if (auto why = reserved_reason(obj.name)) {
      diags_.error(obj.name_range,
                   "'" + obj.name + "' is " + *why + " and cannot be used as an object name",
                   "choose another name for the object");
    }
  }

  void check_object(int index) {
    obj_ = &prog_.objects[index];
    obj_index_ = index;
    arrays_.clear();
    scalars_.clear();
    obj_->scalars.clear();
    warned_.clear();

    for (size_t i = 0; i < obj_->arrays.size(); ++i) {
      const ArrayDecl& d = obj_->arrays[i];
      if (auto why = reserved_reason(d.name)) {
        diags_.error(d.range,
                     "'" + d.name + "' is " + *why + " and cannot be used as an array name",
                     "choose another name for the array");
        continue;
      }
      if (same_name(d.name, obj_->name)) {
        diags_.error(
            d.range,
            "'" + d.name + "' is the name of this object and cannot be used as an array name",
            "choose another name for the array");
        continue;
      }
      auto [it, inserted] = arrays_.emplace(fold_case(d.name), static_cast<int>(i));
      if (!inserted) {
        diags_.error(d.range,
                     "array '" + d.name + "' is already declared (at " +
                         where(obj_->arrays[it->second].range) + ")",
                     "array names must be unique within an object (names ignore case)");
      }
    }
    // Local scalars are declared by their first assignment, anywhere in the body.
    declare_scalars(obj_->body);

    std::vector<char> assigned(obj_->scalars.size(), 0);
    check_block(obj_->body, assigned);
    if (obj_->result) check_value(*obj_->result, assigned);
    obj_ = nullptr;
  }

  void declare_scalars(const std::vector<StmtPtr>& body) {
    for (const StmtPtr& s : body) {
      if (s->kind == StmtKind::kAssign) {
        const std::string& n = s->name;
        if (!reserved_reason(n) && !same_name(n, obj_->name) && !find_array(n)) {
          std::string key = fold_case(n);
          if (!scalars_.count(key)) {
            scalars_.emplace(key, static_cast<int>(obj_->scalars.size()));
            obj_->scalars.push_back(n);
          }
        }
      }
      declare_scalars(s->then_body);
      declare_scalars(s->else_body);
    }
  }

  // ---- lookups ------------------------------------------------------------------------
  std::optional<int> find_array(std::string_view name) const {
    auto it = arrays_.find(fold_case(name));
    if (it == arrays_.end()) return std::nullopt;
    return it->second;
  }
  std::optional<int> find_scalar(std::string_view name) const {
    auto it = scalars_.find(fold_case(name));
    if (it == scalars_.end()) return std::nullopt;
    return it->second;
  }
  std::optional<int> find_object(std::string_view name) const {
    auto it = objects_.find(fold_case(name));
    if (it == objects_.end()) return std::nullopt;
    return it->second;
  }

  // An array name as an argument or target: x, a, s (when declared) or a local array.
  // Returns the symbol and the array's size, or nullopt when `name` is not an array.
  struct ArrayRef {
    Symbol symbol;
    int size;
  };
  std::optional<ArrayRef> resolve_array(std::string_view name) const {
    if (same_name(name, "x")) return ArrayRef{{SymbolKind::kX, -1}, obj_->x_size};
    if (same_name(name, "a")) return ArrayRef{{SymbolKind::kA, -1}, obj_->a_size};
    if (same_name(name, "s")) {
      if (!obj_->has_s) return std::nullopt;
      return ArrayRef{{SymbolKind::kS, -1}, obj_->s_size};
    }
    if (auto i = find_array(name)) {
      return ArrayRef{{SymbolKind::kLocalArray, *i}, obj_->arrays[*i].size};
    }
    return std::nullopt;
  }
  bool is_undeclared_s(std::string_view name) const { return same_name(name, "s") && !obj_->has_s; }
  void error_no_s(SourceRange r) {
    diags_.error(r, "object '" + obj_->name + "' has no 's' array in its header",
                 "declare it in the header, e.g. " + obj_->name +
                     "(x[3], a[1], s[3]); 's' cannot be a variable name");
  }
  void error_not_array(SourceRange r, const std::string& name) {
    if (find_scalar(name)) {
      diags_.error(r, "'" + name + "' is a scalar variable, not an array",
                   "declare an array with 'array " + name +
                       "[N];' before the first statement, or use a different name");
    } else {
      diags_.error(r, "'" + name + "' is not a declared array",
                   "declare it with 'array " + name + "[N];' before the first statement");
    }
  }
  void error_read_only(SourceRange r, const std::string& name) {
    diags_.error(r, "cannot assign to '" + name + "': x and a are read-only inputs of the object",
                 "copy what you need into a local variable, e.g. t = " + name + "[1];");
  }
  void error_whole_array(SourceRange r, const std::string& name) {
    diags_.error(
        r, "'" + name + "' is an array and cannot be assigned a single value",
        "assign one element, " + name + "[1] = ...;, or all of them, " + name + " = [...];");
  }

  std::vector<std::string> visible_names() const {
    std::vector<std::string> out = obj_->scalars;
    for (const ArrayDecl& d : obj_->arrays) out.push_back(d.name);
    return out;
  }
  std::vector<std::string> function_names() const {
    std::vector<std::string> out;
#define HFRT_X(e, s, n) out.emplace_back(s);
    HFRT_BUILTINS(HFRT_X)
#undef HFRT_X
#define HFRT_X(e, s, k) out.emplace_back(s);
    HFRT_LIBRARY(HFRT_X)
#undef HFRT_X
    for (int i = 0; i < obj_index_; ++i) out.push_back(prog_.objects[i].name);
    return out;
  }

  // ---- statements ---------------------------------------------------------------------
  void check_block(std::vector<StmtPtr>& body, std::vector<char>& assigned) {
    for (StmtPtr& s : body) {
      if (diags_.truncated()) return;
      check_stmt(*s, assigned);
    }
  }

  void check_stmt(Stmt& s, std::vector<char>& assigned) {
    switch (s.kind) {
      case StmtKind::kAssign:
        if (s.value) check_value(*s.value, assigned);
        resolve_assign_target(s);
        if (s.symbol.kind == SymbolKind::kLocalScalar) assigned[s.symbol.index] = 1;
        return;
      case StmtKind::kAssignIndex:
        if (s.index) check_value(*s.index, assigned);
        if (s.value) check_value(*s.value, assigned);
        resolve_element_target(s);
        return;
      case StmtKind::kAssignArray:
        resolve_array_target(s);
        return;
      case StmtKind::kIf: {
        if (s.cond) check_value(*s.cond, assigned);
        std::vector<char> then_set = assigned;
        check_block(s.then_body, then_set);
        std::vector<char> else_set = assigned;
        check_block(s.else_body, else_set);
        for (size_t i = 0; i < assigned.size(); ++i) assigned[i] = then_set[i] && else_set[i];
        return;
      }
      case StmtKind::kWhile: {
        if (s.cond) check_value(*s.cond, assigned);
        // The body may run zero times: what it assigns is not definitely assigned after.
        std::vector<char> body_set = assigned;
        check_block(s.then_body, body_set);
        return;
      }
    }
  }

  void resolve_assign_target(Stmt& s) {
    const std::string& n = s.name;
    if (same_name(n, obj_->name)) {
      diags_.error(
          s.name_range,
          "'" + n +
              "' is the value of the object and can only be assigned by the last "
              "statement",
          "compute into a local variable here and end the body with '" + n + " = <expression>;'");
      return;
    }
    if (same_name(n, "x") || same_name(n, "a")) return error_read_only(s.name_range, n);
    if (is_undeclared_s(n)) return error_no_s(s.name_range);
    if (resolve_array(n)) return error_whole_array(s.name_range, n);
    if (auto why = reserved_reason(n)) {
      diags_.error(s.name_range,
                   "'" + n + "' is " + *why + " and cannot be used as a variable name",
                   "choose another variable name");
      return;
    }
    auto idx = find_scalar(n);
    HFRT_CHECK(idx.has_value());
    s.symbol = {SymbolKind::kLocalScalar, *idx};
  }

  /// The array a statement writes (element or whole), or nullopt after reporting why it
  /// cannot be written (x and a are read-only, s needs a header entry, scalars have no elements).
  std::optional<ArrayRef> resolve_writable_array(Stmt& s) {
    const std::string& n = s.name;
    if (same_name(n, "x") || same_name(n, "a")) {
      error_read_only(s.name_range, n);
      return std::nullopt;
    }
    if (is_undeclared_s(n)) {
      error_no_s(s.name_range);
      return std::nullopt;
    }
    auto ref = resolve_array(n);
    if (!ref) {
      error_not_array(s.name_range, n);
      return std::nullopt;
    }
    s.symbol = ref->symbol;
    return ref;
  }

  void resolve_element_target(Stmt& s) {
    auto ref = resolve_writable_array(s);
    if (ref && s.index) check_constant_index(*s.index, s.name, ref->size);
  }

  void resolve_array_target(Stmt& s) {
    auto ref = resolve_writable_array(s);
    if (!ref) return;
    const std::string& n = s.name;
    const int count = static_cast<int>(s.literal.size());
    if (count != ref->size) {
      diags_.error(s.range,
                   "the array literal has " + plural(count, "value") + ", but '" + n + "' has " +
                       plural(ref->size, "element"),
                   "give exactly " + plural(ref->size, "value") + " for '" + n + "'");
    }
  }

  // A constant index (possibly negated) that is certainly out of range at run time.
  void check_constant_index(const Expr& index, const std::string& name, int size) {
    const Expr* e = &index;
    double sign = 1;
    if (e->kind == ExprKind::kUnary && e->unary_op == UnaryOp::kNeg && !e->args.empty()) {
      sign = -1;
      e = e->args[0].get();
    }
    if (e->kind != ExprKind::kNumber) return;
    double i = std::round(sign * e->number);
    if (i >= 1 && i <= size) return;
    diags_.warning(index.range,
                   "index " + std::to_string(static_cast<long long>(std::clamp(i, -1e15, 1e15))) +
                       " is out of range for '" + name + "', which has " + plural(size, "element"),
                   "array indices run from 1 to the declared size; this read fails at run time");
  }

  // ---- expressions --------------------------------------------------------------------
  void check_value(Expr& e, std::vector<char>& assigned) {
    switch (e.kind) {
      case ExprKind::kNumber:
        return;
      case ExprKind::kUnary:
      case ExprKind::kBinary:
        for (ExprPtr& a : e.args) {
          if (a) check_value(*a, assigned);
        }
        return;
      case ExprKind::kName:
        return check_name(e, assigned);
      case ExprKind::kIndex: {
        if (!e.args.empty() && e.args[0]) check_value(*e.args[0], assigned);
        if (is_undeclared_s(e.name)) return error_no_s(e.name_range);
        auto ref = resolve_array(e.name);
        if (!ref) return error_not_array(e.name_range, e.name);
        e.symbol = ref->symbol;
        if (!e.args.empty() && e.args[0]) check_constant_index(*e.args[0], e.name, ref->size);
        return;
      }
      case ExprKind::kCall:
        return check_call(e, assigned);
      case ExprKind::kString:
        // The parser only reads strings where a file name may go; a file argument in the
        // wrong call (an object or built-in of the same arity) is still an error.
        diags_.error(e.range, "strings are not part of HyperFun",
                     "arguments are numbers, expressions or array names");
        return;
    }
  }

  void check_name(Expr& e, std::vector<char>& assigned) {
    const std::string& n = e.name;
    if (is_undeclared_s(n)) return error_no_s(e.name_range);
    if (resolve_array(n)) {
      diags_.error(e.name_range, "'" + n + "' is an array and cannot be used as a number",
                   "use one element, like " + n + "[1]");
      return;
    }
    if (auto i = find_scalar(n)) {
      e.symbol = {SymbolKind::kLocalScalar, *i};
      if (!assigned[*i] && !warned_.count(*i)) {
        warned_.insert({*i, true});
        diags_.warning(e.name_range, "'" + n + "' may be used before it is assigned",
                       "assign '" + n +
                           "' on every path before this point; reading an "
                           "unassigned variable is an error at run time");
      }
      return;
    }
    if (same_name(n, obj_->name)) {
      diags_.error(e.name_range, "object '" + n + "' cannot use its own value",
                   "the value is defined by the last statement; use a local variable instead");
      return;
    }
    if (find_object(n)) {
      diags_.error(e.name_range, "object '" + n + "' must be called with array arguments",
                   "call it like " + n + "(x, a)");
      return;
    }
    if (find_builtin(n) || find_library_fn(n)) {
      diags_.error(e.name_range, "function '" + n + "' must be called with arguments",
                   "call it like " + n + "(...)");
      return;
    }
    std::string hint = "assign it before this point (" + n + " = ...;) or check the spelling";
    std::string guess = closest(n, visible_names());
    if (!guess.empty()) hint = "did you mean '" + guess + "'?";
    diags_.error(e.name_range, "'" + n + "' is used but never assigned", hint);
  }

  // A file name argument (hfMesh, hfBezierSurface): a non-empty string literal.
  void check_file_arg(Expr& arg, int position, const std::string& fn) {
    if (arg.kind != ExprKind::kString) {
      diags_.error(arg.range,
                   "argument " + std::to_string(position) + " of '" + fn +
                       "' must be a file name in double quotes",
                   "for example " + fn +
                       "(x, \"model.off\"); the path is relative to the "
                       "model file's folder");
      return;
    }
    if (arg.name.empty()) {
      diags_.error(arg.range, "the file name of '" + fn + "' is empty",
                   "write the path of the file, relative to the model file's folder");
    }
  }

  // A real-valued argument: anything but a bare array name.
  void check_real_arg(Expr& arg, int position, const std::string& fn, std::vector<char>& assigned) {
    if (arg.kind == ExprKind::kName && resolve_array(arg.name)) {
      diags_.error(arg.range,
                   "argument " + std::to_string(position) + " of '" + fn +
                       "' must be a number, not the array '" + arg.name + "'",
                   "pass one element, like " + arg.name + "[1]");
      return;
    }
    check_value(arg, assigned);
  }

  // An array argument: a bare name of x, a, s or a local array. Returns its size or -1.
  int check_array_arg(Expr& arg, int position, const std::string& fn) {
    if (arg.kind == ExprKind::kName) {
      if (is_undeclared_s(arg.name)) {
        error_no_s(arg.name_range);
        return -1;
      }
      if (auto ref = resolve_array(arg.name)) {
        arg.symbol = ref->symbol;
        return ref->size;
      }
    }
    diags_.error(
        arg.range,
        "argument " + std::to_string(position) + " of '" + fn +
            "' must be an array name (x, a, s or a declared array)",
        arg.kind == ExprKind::kName
            ? "'" + arg.name + "' is not an array; declare one with 'array " + arg.name + "[N];'"
            : "pass the array itself, without an index or an expression");
    return -1;
  }

  void check_call(Expr& e, std::vector<char>& assigned) {
    const std::string& n = e.name;
    const int count = static_cast<int>(e.args.size());
    if (auto b = find_builtin(n)) {
      e.symbol = {SymbolKind::kBuiltin, static_cast<int>(*b)};
      const int arity = builtin_arity(*b);
      if (count != arity) {
        diags_.error(e.name_range,
                     "'" + n + "' takes " + plural(arity, "argument") + ", but " +
                         std::to_string(count) + (count == 1 ? " was" : " were") + " given",
                     std::string(builtin_name(*b)) + (arity == 1 ? "(v)" : "(u, v)"));
      }
      for (int i = 0; i < count; ++i) {
        if (e.args[i]) check_real_arg(*e.args[i], i + 1, n, assigned);
      }
      return;
    }
    if (auto f = find_library_fn(n)) {
      e.symbol = {SymbolKind::kLibrary, static_cast<int>(*f)};
      std::string_view kinds = library_fn_kinds(*f);
      const int arity = static_cast<int>(kinds.size());
      std::string signature = std::string(library_fn_name(*f)) + "(";
      for (int i = 0; i < arity; ++i) {
        signature += i ? ", " : "";
        signature += kinds[i] == 'A' ? "array" : kinds[i] == 'F' ? "\"file\"" : "real";
      }
      signature += ")";
      if (count != arity) {
        diags_.error(e.name_range,
                     "'" + n + "' takes " + plural(arity, "argument") + ", but " +
                         std::to_string(count) + (count == 1 ? " was" : " were") + " given",
                     "the signature is " + signature);
      }
      for (int i = 0; i < count; ++i) {
        if (!e.args[i]) continue;
        if (i < arity && kinds[i] == 'A') {
          const int size = check_array_arg(*e.args[i], i + 1, n);
          if (i == 0 && size >= 0 && size < 3 && is_surface_leaf(*f)) {
            diags_.error(e.args[i]->range,
                         "'" + n + "' needs a point of 3 coordinates, but '" + e.args[i]->name +
                             "' has " + plural(size, "element"),
                         "pass x of a 3-D object, e.g. 'my_model(x[3], a[1])'");
          }
        } else if (i < arity && kinds[i] == 'F') {
          check_file_arg(*e.args[i], i + 1, n);
        } else {
          check_real_arg(*e.args[i], i + 1, n, assigned);
        }
      }
      return;
    }
    if (auto j = find_object(n)) {
      if (*j == obj_index_ || same_name(n, obj_->name)) {
        diags_.error(e.name_range, "object '" + n + "' cannot call itself",
                     "HyperFun has no recursion; use a 'while' loop");
        return;
      }
      if (*j > obj_index_) {
        diags_.error(e.name_range,
                     "object '" + n + "' is defined after '" + obj_->name +
                         "'; an object can only call objects defined before it",
                     "move '" + n + "' above '" + obj_->name + "' in the file");
        return;
      }
      const Object& callee = prog_.objects[*j];
      e.symbol = {SymbolKind::kObject, *j};
      const int max_args = callee.has_s ? 3 : 2;
      if (count < 2 || count > max_args) {
        diags_.error(
            e.name_range,
            "object '" + n + "' takes " +
                (callee.has_s ? "2 or 3 array arguments (x, a [, s])"
                              : std::string("2 array arguments (x, a)")) +
                ", but " + std::to_string(count) + (count == 1 ? " was" : " were") + " given",
            "call it like " + n + (callee.has_s ? "(x, a) or " + n + "(x, a, s)" : "(x, a)"));
      }
      const char* header_names[3] = {"x", "a", "s"};
      const int header_sizes[3] = {callee.x_size, callee.a_size, callee.s_size};
      for (int i = 0; i < count; ++i) {
        if (!e.args[i]) continue;
        int size = check_array_arg(*e.args[i], i + 1, n);
        if (size >= 0 && i < max_args && size != header_sizes[i]) {
          diags_.error(
              e.args[i]->range,
              "array '" + e.args[i]->name + "' has " + plural(size, "element") + ", but object '" +
                  n + "' expects " + header_names[i] + "[" + std::to_string(header_sizes[i]) + "]",
              "pass an array with exactly " + plural(header_sizes[i], "element") +
                  " (declare one with 'array p[" + std::to_string(header_sizes[i]) + "];')");
        }
      }
      return;
    }
    for (ExprPtr& a : e.args) {
      if (a && !(a->kind == ExprKind::kName && resolve_array(a->name))) check_value(*a, assigned);
    }
    if (find_scalar(n) || resolve_array(n) || same_name(n, "s")) {
      diags_.error(e.name_range, "'" + n + "' is not a function",
                   "index arrays with brackets, like " + n + "[1]");
      return;
    }
    std::string hint =
        "built-in functions are sqrt, sin, max, ...; library functions start "
        "with 'hf'; objects must be defined above";
    std::string guess = closest(n, function_names());
    if (!guess.empty()) hint = "did you mean '" + guess + "'?";
    diags_.error(e.name_range, "unknown function '" + n + "'", hint);
  }

  Program& prog_;
  DiagnosticSink& diags_;
  std::unordered_map<std::string, int> objects_;
  Object* obj_ = nullptr;
  int obj_index_ = 0;
  std::unordered_map<std::string, int> arrays_;
  std::unordered_map<std::string, int> scalars_;
  std::unordered_map<int, bool> warned_;
};

}  // namespace

bool check_program(Program& program, DiagnosticSink& diags) {
  Checker(program, diags).run();
  // Parse errors count too: a program with any error is not fit for lowering.
  return !diags.has_errors();
}

}  // namespace hfrt::lang
