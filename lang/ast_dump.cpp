// dump_ast: a stable, indented text form of the AST, one node per line. Used by
// `hfrt check --dump-ast` and by golden tests; changing the format breaks those tests.
#include <charconv>
#include <string>

#include "lang/builtins.h"
#include "lang/frontend.h"
#include "lang/library_table.h"

namespace hfrt::lang {
namespace {

std::string number_text(double v) {
  char buf[64];
  auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);  // shortest round-trip form
  return ec == std::errc() ? std::string(buf, ptr) : "?";
}

const char* unary_name(UnaryOp op) {
  switch (op) {
    case UnaryOp::kNeg:
      return "-";
    case UnaryOp::kPlus:
      return "+";
    case UnaryOp::kComplement:
      return "~";
    case UnaryOp::kNot:
      return "not";
  }
  return "?";
}

const char* binary_name(BinaryOp op) {
  switch (op) {
    case BinaryOp::kAdd:
      return "+";
    case BinaryOp::kSub:
      return "-";
    case BinaryOp::kMul:
      return "*";
    case BinaryOp::kDiv:
      return "/";
    case BinaryOp::kPow:
      return "^";
    case BinaryOp::kUnion:
      return "|";
    case BinaryOp::kIntersect:
      return "&";
    case BinaryOp::kSubtract:
      return "\\";
    case BinaryOp::kProduct:
      return "@";
    case BinaryOp::kLt:
      return "<";
    case BinaryOp::kLe:
      return "<=";
    case BinaryOp::kGt:
      return ">";
    case BinaryOp::kGe:
      return ">=";
    case BinaryOp::kEq:
      return "=";
    case BinaryOp::kNe:
      return "/=";
    case BinaryOp::kAnd:
      return "and";
    case BinaryOp::kOr:
      return "or";
  }
  return "?";
}

class Dumper {
 public:
  explicit Dumper(const Program& prog) : prog_(prog) {}

  std::string run() {
    out_ += "program " + std::to_string(prog_.objects.size()) + " object" +
            (prog_.objects.size() == 1 ? "" : "s");
    int def = prog_.default_object();
    if (def >= 0) out_ += ", model " + prog_.objects[def].name;
    out_ += '\n';
    for (const Object& obj : prog_.objects) object(obj);
    return std::move(out_);
  }

 private:
  void line(int indent, const std::string& text) {
    out_.append(static_cast<size_t>(indent) * 2, ' ');
    out_ += text;
    out_ += '\n';
  }
  static std::string at(SourceRange r) {
    if (!r.begin.valid()) return "";
    return " @" + std::to_string(r.begin.line) + ":" + std::to_string(r.begin.col);
  }

  std::string symbol(const Symbol& s) const {
    switch (s.kind) {
      case SymbolKind::kUnresolved:
        return "unresolved";
      case SymbolKind::kLocalScalar:
        return "local#" + std::to_string(s.index);
      case SymbolKind::kLocalArray:
        return "array#" + std::to_string(s.index);
      case SymbolKind::kX:
        return "x";
      case SymbolKind::kA:
        return "a";
      case SymbolKind::kS:
        return "s";
      case SymbolKind::kBuiltin:
        return "builtin " + std::string(builtin_name(static_cast<Builtin>(s.index)));
      case SymbolKind::kLibrary:
        return "library " + std::string(library_fn_name(static_cast<LibraryFn>(s.index)));
      case SymbolKind::kObject:
        return "object#" + std::to_string(s.index);
    }
    return "?";
  }

  void object(const Object& obj) {
    std::string head = "object " + obj.name + "(x[" + std::to_string(obj.x_size) + "], a[" +
                       std::to_string(obj.a_size) + "]";
    if (obj.has_s) head += ", s[" + std::to_string(obj.s_size) + "]";
    head += ")" + at(obj.name_range);
    line(0, head);
    for (const ArrayDecl& d : obj.arrays) {
      line(1, "array " + d.name + "[" + std::to_string(d.size) + "]" + at(d.range));
    }
    if (!obj.scalars.empty()) {
      std::string s = "scalars";
      for (size_t i = 0; i < obj.scalars.size(); ++i) s += (i ? ", " : " ") + obj.scalars[i];
      line(1, s);
    }
    block(obj.body, 1);
    if (obj.result) {
      line(1, "result" + at(obj.result_range));
      expr(*obj.result, 2);
    }
  }

  void block(const std::vector<StmtPtr>& body, int indent) {
    for (const StmtPtr& s : body) stmt(*s, indent);
  }

  void stmt(const Stmt& s, int indent) {
    switch (s.kind) {
      case StmtKind::kAssign:
        line(indent, "assign " + s.name + " (" + symbol(s.symbol) + ")" + at(s.range));
        if (s.value) expr(*s.value, indent + 1);
        return;
      case StmtKind::kAssignIndex:
        line(indent, "assign-element " + s.name + " (" + symbol(s.symbol) + ")" + at(s.range));
        if (s.index) expr(*s.index, indent + 1);
        if (s.value) expr(*s.value, indent + 1);
        return;
      case StmtKind::kAssignArray: {
        std::string v;
        for (size_t i = 0; i < s.literal.size(); ++i)
          v += (i ? ", " : "") + number_text(s.literal[i]);
        line(indent,
             "assign-array " + s.name + " (" + symbol(s.symbol) + ") [" + v + "]" + at(s.range));
        return;
      }
      case StmtKind::kIf:
        line(indent, "if" + at(s.range));
        line(indent + 1, "cond");
        if (s.cond) expr(*s.cond, indent + 2);
        line(indent + 1, "then");
        block(s.then_body, indent + 2);
        if (s.has_else) {
          line(indent + 1, "else");
          block(s.else_body, indent + 2);
        }
        return;
      case StmtKind::kWhile:
        line(indent, "while" + at(s.range));
        line(indent + 1, "cond");
        if (s.cond) expr(*s.cond, indent + 2);
        line(indent + 1, "loop");
        block(s.then_body, indent + 2);
        return;
    }
  }

  void expr(const Expr& e, int indent) {
    switch (e.kind) {
      case ExprKind::kNumber:
        line(indent, "number " + number_text(e.number));
        return;
      case ExprKind::kName:
        line(indent, "name " + e.name + " (" + symbol(e.symbol) + ")");
        return;
      case ExprKind::kIndex:
        line(indent, "index " + e.name + " (" + symbol(e.symbol) + ")");
        break;
      case ExprKind::kUnary:
        line(indent, std::string("unary ") + unary_name(e.unary_op));
        break;
      case ExprKind::kBinary:
        line(indent, std::string("binary ") + binary_name(e.binary_op));
        break;
      case ExprKind::kCall:
        line(indent, "call " + e.name + " (" + symbol(e.symbol) + ")");
        break;
      case ExprKind::kString:
        line(indent, "string \"" + e.name + "\"");
        return;
    }
    for (const ExprPtr& a : e.args) {
      if (a) expr(*a, indent + 1);
    }
  }

  const Program& prog_;
  std::string out_;
};

}  // namespace

std::string dump_ast(const Program& program) {
  return Dumper(program).run();
}

}  // namespace hfrt::lang
