// Tests of jit/pov_emit: the text written for small models, the rejection (with a location) of
// what POV-Ray functions cannot express, and — through a small evaluator of the POV-Ray
// function syntax the emitter writes — that the emitted function computes what the
// reference interpreter computes, on hand-written models and on every corpus probe that has
// no loop or computed array index.
#include "jit/pov_emit.h"

#include <gtest/gtest.h>

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "ir/builder.h"
#include "tests/jit/compile_util.h"

namespace hfrt::jit {

// jit/ evaluates the IR: its types and ops are used unqualified here.
using namespace ::hfrt::ir;
namespace {

using testutil::compile;

struct Emitted {
  bool ok = false;
  PovFunction pov;
  std::string diagnostics;
  std::vector<lang::Diagnostic> diags;
};

Emitted emit(const std::string& text, const std::vector<double>& params = {},
             const std::string& name = "F") {
  Emitted e;
  testutil::Compiled c = compile(text);
  EXPECT_TRUE(c.ok) << c.diagnostics;
  if (!c.ok) return e;
  auto file = std::make_shared<const lang::SourceFile>("test.hf", text);
  lang::DiagnosticSink diags(file);
  PovEmitOptions o;
  o.name = name;
  o.params = params;
  e.ok = emit_pov_function(c.fn, o, &e.pov, &diags);
  e.diagnostics = diags.render(false);
  e.diags = diags.diagnostics();
  return e;
}

// ---------------------------------------------------------------------------------------
// A evaluator of the subset of POV-Ray's function language that the emitter writes:
// `#declare NAME = function(p, ...) { EXPR }` lines; EXPR is numbers, parameter names,
// parenthesised infix (+ - * / < <= > >= = != & |), parenthesised unary minus and calls of
// POV-Ray's built-in functions or of earlier declared functions. POV-Ray semantics:
// select(a, b, c) = a < 0 ? b : c; select(a, b, c, d) = a < 0 ? b : a == 0 ? c : d;
// ln natural log, log base 10, int truncation, mod = fmod; comparisons and & | give 1 or 0.
class PovEval {
 public:
  explicit PovEval(const std::string& text) {
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
      if (line.rfind("#declare ", 0) != 0) continue;
      size_t eq = line.find(" = function(");
      EXPECT_NE(eq, std::string::npos) << line;
      Fn f;
      std::string name = line.substr(9, eq - 9);
      size_t p0 = eq + 12, p1 = line.find(')', p0);
      std::string params = line.substr(p0, p1 - p0);
      std::istringstream ps(params);
      std::string p;
      while (std::getline(ps, p, ',')) {
        while (!p.empty() && p[0] == ' ') p.erase(0, 1);
        f.params.push_back(p);
      }
      size_t b0 = line.find("{ ", p1), b1 = line.rfind(" }");
      f.body = line.substr(b0 + 2, b1 - b0 - 2);
      fns_[name] = f;
      last_ = name;
    }
  }
  const std::string& last() const { return last_; }
  bool has(const std::string& name) const { return fns_.count(name) > 0; }

  double call(const std::string& name, const std::vector<double>& args) {
    const Fn& f = fns_.at(name);
    EXPECT_EQ(f.params.size(), args.size()) << name;
    std::map<std::string, double> env;
    for (size_t i = 0; i < f.params.size() && i < args.size(); ++i) env[f.params[i]] = args[i];
    size_t pos = 0;
    double v = expr(f.body, pos, env);
    EXPECT_EQ(pos, f.body.size()) << "trailing text in " << f.body;
    return v;
  }

 private:
  struct Fn {
    std::vector<std::string> params;
    std::string body;
  };

  static void skip(const std::string& s, size_t& p) {
    while (p < s.size() && s[p] == ' ') ++p;
  }
  static bool eat(const std::string& s, size_t& p, const std::string& tok) {
    skip(s, p);
    if (s.compare(p, tok.size(), tok) == 0) {
      p += tok.size();
      return true;
    }
    return false;
  }

  double expr(const std::string& s, size_t& p, std::map<std::string, double>& env) {
    skip(s, p);
    if (eat(s, p, "(")) {
      if (eat(s, p, "-")) {
        double a = expr(s, p, env);
        EXPECT_TRUE(eat(s, p, ")"));
        return -a;
      }
      double a = expr(s, p, env);
      skip(s, p);
      static const char* kOps[] = {"<=", ">=", "!=", "+", "-", "*", "/", "<", ">", "=", "&", "|"};
      std::string op;
      for (const char* o : kOps)
        if (eat(s, p, o)) {
          op = o;
          break;
        }
      EXPECT_FALSE(op.empty()) << "no operator at " << s.substr(p, 20);
      double b = expr(s, p, env);
      EXPECT_TRUE(eat(s, p, ")"));
      if (op == "+") return a + b;
      if (op == "-") return a - b;
      if (op == "*") return a * b;
      if (op == "/") return a / b;
      if (op == "<") return a < b;
      if (op == "<=") return a <= b;
      if (op == ">") return a > b;
      if (op == ">=") return a >= b;
      if (op == "=") return a == b;
      if (op == "!=") return a != b;
      if (op == "&") return a != 0 && b != 0;
      if (op == "|") return a != 0 || b != 0;
      return NAN;
    }
    if (std::isdigit(static_cast<unsigned char>(s[p])) || s[p] == '.') {
      char* end = nullptr;
      double v = std::strtod(s.c_str() + p, &end);
      p = size_t(end - s.c_str());
      return v;
    }
    size_t q = p;
    while (q < s.size() && (std::isalnum(static_cast<unsigned char>(s[q])) || s[q] == '_')) ++q;
    std::string id = s.substr(p, q - p);
    EXPECT_FALSE(id.empty()) << "unexpected text " << s.substr(p, 20);
    if (id.empty()) {
      p = s.size();
      return NAN;
    }
    p = q;
    if (!eat(s, p, "(")) {
      EXPECT_TRUE(env.count(id)) << "unknown identifier " << id;
      return env[id];
    }
    std::vector<double> args;
    if (!eat(s, p, ")")) {
      do {
        args.push_back(expr(s, p, env));
      } while (eat(s, p, ","));
      EXPECT_TRUE(eat(s, p, ")"));
    }
    if (fns_.count(id)) return call(id, args);
    auto a = [&](size_t i) { return i < args.size() ? args[i] : NAN; };
    if (id == "abs") return std::fabs(a(0));
    if (id == "min") return std::fmin(a(0), a(1));
    if (id == "max") return std::fmax(a(0), a(1));
    if (id == "sqrt") return std::sqrt(a(0));
    if (id == "exp") return std::exp(a(0));
    if (id == "ln") return std::log(a(0));
    if (id == "log") return std::log10(a(0));
    if (id == "sin") return std::sin(a(0));
    if (id == "cos") return std::cos(a(0));
    if (id == "tan") return std::tan(a(0));
    if (id == "asin") return std::asin(a(0));
    if (id == "acos") return std::acos(a(0));
    if (id == "atan") return std::atan(a(0));
    if (id == "atan2") return std::atan2(a(0), a(1));
    if (id == "sinh") return std::sinh(a(0));
    if (id == "cosh") return std::cosh(a(0));
    if (id == "tanh") return std::tanh(a(0));
    if (id == "floor") return std::floor(a(0));
    if (id == "ceil") return std::ceil(a(0));
    if (id == "int") return std::trunc(a(0));
    if (id == "mod") return std::fmod(a(0), a(1));
    if (id == "pow") return std::pow(a(0), a(1));
    if (id == "select") {
      if (args.size() == 3) return a(0) < 0 ? a(1) : a(2);
      EXPECT_EQ(args.size(), 4u);
      return a(0) < 0 ? a(1) : a(0) == 0 ? a(2) : a(3);
    }
    ADD_FAILURE() << "unknown function " << id;
    return NAN;
  }

  std::map<std::string, Fn> fns_;
  std::string last_;
};

/// Compares the emitted function with the interpreter on a grid of points where the
/// interpreter has a value (no run-time error). Returns the number of points compared.
int expect_same_values(const std::string& text, const std::string& where,
                       const std::vector<double>& params = {}, int grid = 5) {
  const double lo = -2.1, hi = 2.3;
  testutil::Compiled c = compile(text);
  EXPECT_TRUE(c.ok) << where << c.diagnostics;
  if (!c.ok) return 0;
  PovEmitOptions o;
  o.name = "F";
  o.params = params;
  PovFunction pov;
  lang::DiagnosticSink diags(std::make_shared<const lang::SourceFile>(where, text));
  if (!emit_pov_function(c.fn, o, &pov, &diags)) {
    ADD_FAILURE() << where << ": not emitted\n" << diags.render(false);
    return 0;
  }
  PovEval pe(pov.text);
  EXPECT_EQ(pe.last(), "F");
  Interpreter interp(c.fn);
  int compared = 0;
  const int kN = grid;
  for (int i = 0; i < kN; ++i)
    for (int j = 0; j < kN; ++j)
      for (int k = 0; k < kN; ++k) {
        const double x[3] = {lo + (hi - lo) * i / (kN - 1), lo + (hi - lo) * j / (kN - 1),
                             lo + (hi - lo) * k / (kN - 1)};
        EvalResult r = interp.eval(x, params);
        if (r.error || !std::isfinite(r.value)) continue;
        double v = pe.call("F", {x[0], x[1], x[2]});
        EXPECT_NEAR(v, r.value, 1e-9 * (1 + std::fabs(r.value)))
            << where << " at (" << x[0] << ", " << x[1] << ", " << x[2] << ")\n"
            << pov.text;
        ++compared;
      }
  return compared;
}

// ---------------------------------------------------------------------------------------

TEST(PovEmit, SphereIsOneExpression) {
  Emitted e = emit("my_model(x[3], a[1]) { my_model = 1 - (x[1]*x[1] + x[2]*x[2] + x[3]*x[3]); }");
  ASSERT_TRUE(e.ok) << e.diagnostics;
  EXPECT_EQ(e.pov.text,
            "#declare F = function(x, y, z) { (1 - (((x * x) + (y * y)) + (z * z))) }\n");
  EXPECT_EQ(e.pov.helpers, 0);
}

TEST(PovEmit, NegativeConstantsAndCoordinatesBeyondThreeReadZero) {
  Emitted e = emit("my_model(x[4], a[1]) { my_model = -2.5 * x[1] + x[4]; }");
  ASSERT_TRUE(e.ok) << e.diagnostics;
  EXPECT_NE(e.pov.text.find("(-2.5)"), std::string::npos) << e.pov.text;
  EXPECT_EQ(e.pov.text.find("x[4]"), std::string::npos);
  PovEval pe(e.pov.text);
  EXPECT_DOUBLE_EQ(pe.call("F", {2, 0, 0}), -5.0);
}

TEST(PovEmit, SharedValuesAreBoundOnceThroughHelpers) {
  // f1 is used three times; writing it inline would repeat the sqrt.
  Emitted e = emit(
      "my_model(x[3], a[1]) { f1 = sqrt(x[1]*x[1] + x[2]*x[2] + x[3]*x[3]) - 1;"
      " f2 = x[2] - 0.5; my_model = f1 + f2 + sqrt(f1*f1 + f2*f2) + f1; }");
  ASSERT_TRUE(e.ok) << e.diagnostics;
  EXPECT_GE(e.pov.helpers, 1);
  size_t first = e.pov.text.find("sqrt((((x * x)");
  ASSERT_NE(first, std::string::npos) << e.pov.text;
  EXPECT_EQ(e.pov.text.find("sqrt((((x * x)", first + 1), std::string::npos) << e.pov.text;
  EXPECT_NE(e.pov.text.find("#declare F_1 = function(x, y, z, p0)"), std::string::npos)
      << e.pov.text;
  // Helpers are declared before the functions that call them.
  EXPECT_LT(e.pov.text.find("#declare F_1 "), e.pov.text.find("#declare F "));
}

TEST(PovEmit, IfBecomesSelect) {
  const std::string text =
      "my_model(x[3], a[1]) { v = 0; if x[1] > 0.5 then v = x[2]; else v = x[3] * 2; endif;"
      " my_model = v - 0.25; }";
  Emitted e = emit(text);
  ASSERT_TRUE(e.ok) << e.diagnostics;
  EXPECT_NE(e.pov.text.find("select("), std::string::npos) << e.pov.text;
  EXPECT_GT(expect_same_values(text, "if"), 100);
}

TEST(PovEmit, ParametersAreBakedIn) {
  Emitted e = emit("my_model(x[3], a[2]) { my_model = a[1] - x[1] + a[2]; }", {2.25});
  ASSERT_TRUE(e.ok) << e.diagnostics;
  EXPECT_NE(e.pov.text.find("2.25"), std::string::npos) << e.pov.text;
  PovEval pe(e.pov.text);
  EXPECT_DOUBLE_EQ(pe.call("F", {1, 0, 0}), 1.25);  // a[2] missing: 0
}

TEST(PovEmit, EmulatedOpsMatchTheInterpreter) {
  // mod (rounds its operands), sign, ^ (HyperFun power, integral and not, constant and
  // computed exponents), tolerance '=', and/or/not, int, frac, logd.
  const std::string text =
      "my_model(x[3], a[1]) {"
      " r = mod(x[1] * 3.3, 2.2) + sign(x[2] - 0.3) + x[3]^3 + abs(x[1])^0.5 + x[2]^(-2);"
      " r = r + (abs(x[3]) + 0.5)^(x[1] + 0.25) + (x[2] + 3)^int(x[1] * 2);"
      " if (x[1] = x[2]) or (not (x[3] < 0) and x[1] > -1) then r = r + 1; endif;"
      " my_model = r + int(x[3] * 2.2) + frac(x[1] * 1.7) + logd(abs(x[2]) + 1); }";
  testutil::Compiled c = compile(text);
  ASSERT_TRUE(c.ok) << c.diagnostics;
  EXPECT_GT(expect_same_values(text, "emulated"), 50);
}

TEST(PovEmit, CbrtIsASelectOfPowers) {
  // POV-Ray has no cbrt and its pow of a negative base is not real: cbrt(v) is written
  // select(v, -pow(-v, 1/3), pow(v, 1/3)) (select(s, a, b) is a where s < 0).
  Function fn;
  IrBuilder b(fn);
  b.finish(b.add(b.unary(Op::kCbrt, b.input(0)), b.input(1)));
  PovEmitOptions o;
  o.name = "F";
  PovFunction pov;
  ASSERT_TRUE(emit_pov_function(fn, o, &pov, nullptr));
  EXPECT_EQ(pov.text,
            "#declare F = function(x, y, z) { (select(x, (-pow((-x), 0.3333333333333333)), "
            "pow(x, 0.3333333333333333)) + y) }\n");
  PovEval pe(pov.text);
  Interpreter interp(fn);
  for (double x : {-27.0, -8.0, -1.5, -1e-9, 0.0, 1e-9, 0.7, 8.0, 1000.0}) {
    const double p[3] = {x, 0.25, 0};
    const double ref = interp.eval(p, {}).value;
    EXPECT_NEAR(pe.call("F", {x, 0.25, 0}), ref, 1e-12 * (1 + std::fabs(ref))) << x;
  }
}

TEST(PovEmit, LoopIsRejectedWithItsLocation) {
  const std::string text =
      "my_model(x[3], a[1])\n{\n  i = 0; t = 0;\n  while i < 3 loop\n    t = t + x[1]; i = i + 1;\n"
      "  endloop;\n  my_model = t;\n}\n";
  Emitted e = emit(text);
  EXPECT_FALSE(e.ok);
  ASSERT_EQ(e.diags.size(), 1u) << e.diagnostics;
  EXPECT_EQ(e.diags[0].severity, lang::Severity::kError);
  EXPECT_NE(e.diags[0].message.find("while loop"), std::string::npos) << e.diags[0].message;
  EXPECT_EQ(e.diags[0].range.begin.line, 4u) << e.diagnostics;
  EXPECT_FALSE(e.diags[0].hint.empty());
  EXPECT_NE(e.diagnostics.find("test.hf:4:"), std::string::npos) << e.diagnostics;
}

TEST(PovEmit, ComputedArrayIndexIsRejectedWithItsLocation) {
  const std::string text =
      "my_model(x[3], a[1])\n{\n  array b[3];\n  b = [1, 2, 3];\n  i = 1 + int(abs(x[1]));\n"
      "  my_model = b[i] - x[2];\n}\n";
  Emitted e = emit(text);
  EXPECT_FALSE(e.ok);
  ASSERT_EQ(e.diags.size(), 1u) << e.diagnostics;
  EXPECT_NE(e.diags[0].message.find("computed index"), std::string::npos) << e.diags[0].message;
  EXPECT_EQ(e.diags[0].range.begin.line, 6u) << e.diagnostics;
}

TEST(PovEmit, ConstantArrayIndexIsWritten) {
  const std::string text =
      "my_model(x[3], a[1]) { array b[3]; b = [1, 2, 3]; b[2] = x[1]; my_model = b[1] + b[2] * "
      "b[3]; }";
  Emitted e = emit(text);
  ASSERT_TRUE(e.ok) << e.diagnostics;
  EXPECT_GT(expect_same_values(text, "const index"), 100);
}

TEST(PovEmit, LibraryModelsMatchTheInterpreter) {
  // R-function set operations, a blend and library primitives (center arrays are constant
  // indices after lowering).
  const std::string text =
      "my_model(x[3], a[1]) { array c[3]; c = [0.2, 0, 0];"
      " sp = hfSphere(x, c, 1.1); t = hfTorusY(x, c, 1, 0.3);"
      " b = hfBlendUni(sp, t, 0.5, 0.5, 0.5); my_model = (b | -x[2]) & (1.5 - x[3]) \\ t; }";
  EXPECT_GT(expect_same_values(text, "library"), 100);
}

TEST(PovEmit, CorpusProbesWithoutLoopsMatchTheInterpreter) {
  // Every probe either is written and computes the interpreter's values, or is rejected
  // with a located error naming a loop or a computed index.
  const std::filesystem::path dir = std::filesystem::path(HFRT_CORPUS_DIR) / "probes";
  ASSERT_TRUE(std::filesystem::exists(dir)) << dir;
  int written = 0, rejected = 0, points = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".hf") continue;
    std::ifstream f(entry.path());
    std::stringstream ss;
    ss << f.rdbuf();
    const std::string text = ss.str();
    testutil::Compiled c = compile(text);
    EXPECT_TRUE(c.ok) << entry.path() << " does not lower";
    if (!c.ok) continue;
    lang::DiagnosticSink diags(
        std::make_shared<const lang::SourceFile>(entry.path().string(), text));
    PovFunction pov;
    PovEmitOptions o;
    o.name = "F";
    if (!emit_pov_function(c.fn, o, &pov, &diags)) {
      ++rejected;
      ASSERT_EQ(diags.diagnostics().size(), 1u) << entry.path();
      const std::string& m = diags.diagnostics()[0].message;
      EXPECT_TRUE(m.find("while loop") != std::string::npos ||
                  m.find("computed index") != std::string::npos ||
                  m.find("lookup table") != std::string::npos ||
                  m.find("parameter limit") != std::string::npos)
          << entry.path() << ": " << m;
      continue;
    }
    ++written;
    points += expect_same_values(text, entry.path().filename().string(), {}, 4);
  }
  // The corpus's 63 probes (2026-12), each written or rejected.
  EXPECT_GE(written + rejected, 63);
  EXPECT_GT(written, 20) << "rejected " << rejected;
  EXPECT_GT(points, 800);
}

TEST(PovEmit, Identifiers) {
  EXPECT_EQ(pov_identifier("torus"), "hf_torus");
  EXPECT_EQ(pov_identifier("my_model"), "my_model");
  EXPECT_EQ(pov_identifier("Torus"), "Torus");
  EXPECT_EQ(pov_identifier("3d-part"), "hf_3d_part");
}

}  // namespace
}  // namespace hfrt::jit
