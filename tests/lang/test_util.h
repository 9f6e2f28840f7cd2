#pragma once
// Helpers shared by the lang/ tests: compile a string, pick diagnostics apart, and print
// expressions as S-expressions (independent of dump_ast, so the tests check the tree, not
// the dump format).

#include <memory>
#include <string>
#include <vector>

#include "lang/ast.h"
#include "lang/diagnostics.h"
#include "lang/frontend.h"

namespace hfrt::lang::testing {

struct Compiled {
  std::shared_ptr<const SourceFile> file;
  std::unique_ptr<DiagnosticSink> diags;
  std::unique_ptr<Program> program;  ///< always set (parse_program never returns null)

  bool ok() const { return !diags->has_errors(); }
  std::vector<const Diagnostic*> errors() const { return of(Severity::kError); }
  std::vector<const Diagnostic*> warnings() const { return of(Severity::kWarning); }
  std::vector<const Diagnostic*> of(Severity s) const {
    std::vector<const Diagnostic*> out;
    for (const Diagnostic& d : diags->diagnostics()) {
      if (d.severity == s) out.push_back(&d);
    }
    return out;
  }
  std::string rendered() const { return diags->render(false); }
};

/// parse_program + check_program on `text`.
inline Compiled compile(std::string text, std::string name = "test.hf") {
  Compiled c;
  c.file = std::make_shared<const SourceFile>(std::move(name), std::move(text));
  c.diags = std::make_unique<DiagnosticSink>(c.file);
  c.program = parse_program(c.file, *c.diags);
  check_program(*c.program, *c.diags);
  return c;
}

/// Wraps statements into `my_model(x[3], a[1]) { BODY }`.
inline std::string model(const std::string& body, const std::string& header = "x[3], a[1]") {
  return "my_model(" + header + ")\n{\n" + body + "\n}\n";
}

/// Prefix form of an expression: (+ 1 (* 2 x[1])), names as written, calls as (f a b).
inline std::string sexpr(const Expr& e) {
  static const char* const kBinary[] = {"+", "-",  "*", "/",  "^", "|",  "&",   "\\", "@",
                                        "<", "<=", ">", ">=", "=", "/=", "and", "or"};
  static const char* const kUnary[] = {"-", "+", "~", "not"};
  auto num = [](double v) {
    std::string s = std::to_string(v);
    s.erase(s.find_last_not_of('0') + 1);
    if (!s.empty() && s.back() == '.') s.pop_back();
    return s;
  };
  switch (e.kind) {
    case ExprKind::kNumber:
      return num(e.number);
    case ExprKind::kName:
      return e.name;
    case ExprKind::kIndex:
      return e.name + "[" + sexpr(*e.args[0]) + "]";
    case ExprKind::kUnary:
      return std::string("(") + kUnary[static_cast<int>(e.unary_op)] + " " + sexpr(*e.args[0]) +
             ")";
    case ExprKind::kBinary:
      return std::string("(") + kBinary[static_cast<int>(e.binary_op)] + " " + sexpr(*e.args[0]) +
             " " + sexpr(*e.args[1]) + ")";
    case ExprKind::kString:
      return "\"" + e.name + "\"";
    case ExprKind::kCall: {
      std::string s = "(" + e.name;
      for (const ExprPtr& a : e.args) s += " " + sexpr(*a);
      return s + ")";
    }
  }
  return "?";
}

}  // namespace hfrt::lang::testing
