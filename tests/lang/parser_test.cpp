// Parser: the grammar and precedence of the spec, the hfrt condition deviation, error
// recovery (all errors of a file in one run), and robustness against hostile input.
#include "lang/parser.h"

#include <gtest/gtest.h>

#include <random>
#include <string>

#include "tests/lang/test_util.h"

namespace hfrt::lang {
namespace {

using testing::compile;
using testing::Compiled;
using testing::model;
using testing::sexpr;

// The S-expression of the model's result expression `my_model = EXPR;`.
std::string result_of(const std::string& expr, const std::string& before = "") {
  Compiled c = compile(model(before + "my_model = " + expr + ";"));
  EXPECT_TRUE(c.ok()) << c.rendered();
  if (c.program->objects.empty() || !c.program->objects[0].result) return "<none>";
  return sexpr(*c.program->objects[0].result);
}

// The S-expression of the condition of the first statement, an `if`.
std::string condition_of(const std::string& cond) {
  Compiled c = compile(model("v = 0; w = 1; if " + cond + " then v = 1; endif;\nmy_model = v;"));
  EXPECT_TRUE(c.ok()) << c.rendered();
  const auto& body = c.program->objects.at(0).body;
  if (body.size() < 3 || body[2]->kind != StmtKind::kIf) return "<none>";
  return sexpr(*body[2]->cond);
}

TEST(Parser, SetOperatorsShareTheAdditiveLevel) {
  EXPECT_EQ(result_of("1|2+1"), "(+ (| 1 2) 1)");
  EXPECT_EQ(result_of("2*3|4"), "(| (* 2 3) 4)");
  EXPECT_EQ(result_of("x[1] | x[2] + 1"), "(+ (| x[1] x[2]) 1)");
  EXPECT_EQ(result_of("1 & 2 \\ 3 @ 4 - 5"), "(- (@ (\\ (& 1 2) 3) 4) 5)");
}

TEST(Parser, MultiplicativeBindsTighterThanAdditive) {
  EXPECT_EQ(result_of("1 + 2 * 3 - 4 / 5"), "(- (+ 1 (* 2 3)) (/ 4 5))");
  EXPECT_EQ(result_of("8 / 4 / 2"), "(/ (/ 8 4) 2)");
}

TEST(Parser, PowerIsLeftAssociative) {
  EXPECT_EQ(result_of("2^3^2"), "(^ (^ 2 3) 2)");
  EXPECT_EQ(result_of("2*3^2"), "(* 2 (^ 3 2))");
}

TEST(Parser, UnaryBindsTighterThanPower) {
  EXPECT_EQ(result_of("-x[1]^2"), "(^ (- x[1]) 2)");
  EXPECT_EQ(result_of("2^-1"), "(^ 2 (- 1))");
  EXPECT_EQ(result_of("~x[1] & +x[2]"), "(& (~ x[1]) (+ x[2]))");
  EXPECT_EQ(result_of("- - 3"), "(- (- 3))");
}

TEST(Parser, ParenthesesAndCalls) {
  EXPECT_EQ(result_of("(1 + 2) * 3"), "(* (+ 1 2) 3)");
  EXPECT_EQ(result_of("max(x[1], min(x[2], 3)) + sqrt(4)"), "(+ (max x[1] (min x[2] 3)) (sqrt 4))");
  EXPECT_EQ(result_of("c[1 + 1]", "array c[3]; c = [1, 2, 3];\n"), "c[(+ 1 1)]");
  EXPECT_EQ(result_of("hfSphere(x, c, 1)", "array c[3]; c = [0, 0, 0];\n"), "(hfSphere x c 1)");
}

// hfrt extension (issue 10): a string literal is read only as the file argument of hfMesh and
// hfBezierSurface (the other places keep the original's error: diagnostics_test.cpp).
TEST(Parser, FileArgumentsOfMeshAndPatchLeaves) {
  EXPECT_EQ(result_of("hfMesh(x, \"data/bunny.off\")"), "(hfMesh x \"data/bunny.off\")");
  EXPECT_EQ(result_of("HFMESH(x, \"a b.obj\") | hfBezierSurface(x, \"t.bpt\")"),
            "(| (HFMESH x \"a b.obj\") (hfBezierSurface x \"t.bpt\"))");
  Compiled c = compile(model("my_model = hfMesh(x, \"m.off\");"));
  ASSERT_TRUE(c.ok()) << c.rendered();
  const Expr& call = *c.program->objects[0].result;
  ASSERT_EQ(call.args.size(), 2u);
  EXPECT_EQ(call.args[1]->kind, ExprKind::kString);
  EXPECT_EQ(call.args[1]->name, "m.off");
  EXPECT_EQ(call.args[1]->range.begin.col, 22u);
  EXPECT_EQ(call.args[1]->range.length, 7u);  // with the quotes
  EXPECT_NE(dump_ast(*c.program).find("string \"m.off\""), std::string::npos);
  // An unterminated string is still the original's error, even in the file position.
  Compiled bad = compile(model("my_model = hfMesh(x, \"m.off);"));
  ASSERT_FALSE(bad.errors().empty());
  EXPECT_EQ(bad.errors()[0]->message, "strings are not part of HyperFun");
}

TEST(Parser, ConditionsAndOrAreOneLevelLeftToRight) {
  EXPECT_EQ(condition_of("1 or 1 and 0"), "(and (or 1 1) 0)");
  EXPECT_EQ(condition_of("v > 0 and w < 1 or v = w"), "(or (and (> v 0) (< w 1)) (= v w))");
}

TEST(Parser, ComparisonsChain) {
  EXPECT_EQ(condition_of("2 <= v < 5"), "(< (<= 2 v) 5)");
  EXPECT_EQ(condition_of("v /= w"), "(/= v w)");
  EXPECT_EQ(condition_of("v >= w + 1"), "(>= v (+ w 1))");
}

TEST(Parser, NotBindsTightly) {
  EXPECT_EQ(condition_of("not x[1] > 5"), "(> (not x[1]) 5)");
  EXPECT_EQ(condition_of("not (x[1] > 5)"), "(not (> x[1] 5))");
  EXPECT_EQ(condition_of("not not v"), "(not (not v))");
}

TEST(Parser, ParenthesisedConditions) {
  EXPECT_EQ(condition_of("(v > 0)"), "(> v 0)");
  EXPECT_EQ(condition_of("(v > 0) and (w < 1 or v = 1)"), "(and (> v 0) (or (< w 1) (= v 1)))");
  EXPECT_EQ(condition_of("((v))"), "v");
  EXPECT_EQ(condition_of("(x[1]) > 0"), "(> x[1] 0)");
}

TEST(Parser, ArithmeticInParenthesesAfterIf) {
  // hfrt deviation: the original rejects these; hfrt re-reads the parentheses as arithmetic.
  EXPECT_EQ(condition_of("(x[1]+1)*2 > 0"), "(> (* (+ x[1] 1) 2) 0)");
  EXPECT_EQ(condition_of("(v + 1) ^ 2 = 4 and w > 0"), "(and (= (^ (+ v 1) 2) 4) (> w 0))");
  EXPECT_EQ(condition_of("((v)) - 1 < 0"), "(< (- v 1) 0)");
  EXPECT_EQ(condition_of("not (v - 1) * 2 > 0"), "(> (not (* (- v 1) 2)) 0)");
}

TEST(Parser, ConditionThatIsNeitherReportsTheConditionError) {
  Compiled c = compile(model("v = 0;\nif (x[1] > 0) * 2 > 0 then v = 1; endif;\nmy_model = v;"));
  ASSERT_EQ(c.errors().size(), 1u) << c.rendered();
  EXPECT_EQ(c.errors()[0]->message, "expected 'then' after the condition of 'if', found '*'");
  EXPECT_EQ(c.errors()[0]->range.begin.line, 4u);
  EXPECT_EQ(c.errors()[0]->range.begin.col, 15u);
}

TEST(Parser, CaseInsensitiveProgram) {
  Compiled c = compile(
      "MY_Model(X[3], A[1])\n{\n ARRAY C[3];\n C = [1,2,3];\n Y = SQRT(C[3]+1) ;\n My_Model = "
      "y;\n}\n");
  ASSERT_TRUE(c.ok()) << c.rendered();
  const Object& o = c.program->objects[0];
  EXPECT_EQ(o.name, "MY_Model");
  ASSERT_TRUE(o.result);
  EXPECT_EQ(sexpr(*o.result), "y");
  EXPECT_EQ(o.body.size(), 2u);
}

TEST(Parser, ObjectHeaderAndDeclarations) {
  Compiled c = compile(
      "obj(x[4], a[2], s[3]) {\n array c[3], w[10];\n array d[1];\n s = [0.1, 0.2, 0.3];\n"
      " obj = x[4];\n}\n");
  ASSERT_TRUE(c.ok()) << c.rendered();
  const Object& o = c.program->objects[0];
  EXPECT_EQ(o.x_size, 4);
  EXPECT_EQ(o.a_size, 2);
  EXPECT_TRUE(o.has_s);
  EXPECT_EQ(o.s_size, 3);
  ASSERT_EQ(o.arrays.size(), 3u);
  EXPECT_EQ(o.arrays[0].name, "c");
  EXPECT_EQ(o.arrays[1].size, 10);
  EXPECT_EQ(o.arrays[2].name, "d");
  ASSERT_EQ(o.body.size(), 1u);
  EXPECT_EQ(o.body[0]->kind, StmtKind::kAssignArray);
  EXPECT_EQ(o.body[0]->literal, (std::vector<double>{0.1, 0.2, 0.3}));
  EXPECT_FALSE(compile("o(x[3], a[1]) { o = 1; }").program->objects[0].has_s);
}

TEST(Parser, ArrayLiteralSigns) {
  Compiled c = compile(model("array c[3];\nc = [-1, +2, -3.5];\nmy_model = c[1];"));
  ASSERT_TRUE(c.ok()) << c.rendered();
  EXPECT_EQ(c.program->objects[0].body[0]->literal, (std::vector<double>{-1, 2, -3.5}));
}

TEST(Parser, StatementsKinds) {
  Compiled c =
      compile(model("array c[2];\nv = 1;\nc[2] = v;\nc = [1, 2];\n"
                    "if v > 0 then w = 1; else w = 2; endif;\n"
                    "i = 0; while i < 3 loop i = i + 1; endloop;\n"
                    "if x[1] > 0 then else endif;\nwhile i > 10 loop endloop;\n"
                    "my_model = v + w;"));
  ASSERT_TRUE(c.ok()) << c.rendered();
  const auto& b = c.program->objects[0].body;
  ASSERT_EQ(b.size(), 8u);
  EXPECT_EQ(b[0]->kind, StmtKind::kAssign);
  EXPECT_EQ(b[1]->kind, StmtKind::kAssignIndex);
  EXPECT_EQ(sexpr(*b[1]->index), "2");
  EXPECT_EQ(b[2]->kind, StmtKind::kAssignArray);
  EXPECT_EQ(b[3]->kind, StmtKind::kIf);
  EXPECT_TRUE(b[3]->has_else);
  EXPECT_EQ(b[3]->then_body.size(), 1u);
  EXPECT_EQ(b[3]->else_body.size(), 1u);
  EXPECT_EQ(b[5]->kind, StmtKind::kWhile);
  EXPECT_EQ(b[5]->then_body.size(), 1u);
  EXPECT_TRUE(b[6]->has_else);
  EXPECT_TRUE(b[6]->then_body.empty());
  EXPECT_TRUE(b[7]->then_body.empty());
}

TEST(Parser, NestedIfInElse) {
  Compiled c = compile(model(
      "v = 0;\nif x[1] > 0 then v = 1; else if x[1] < 0 then v = 2; endif; endif;\nmy_model = v;"));
  ASSERT_TRUE(c.ok()) << c.rendered();
  const Stmt& s = *c.program->objects[0].body[1];
  ASSERT_EQ(s.else_body.size(), 1u);
  EXPECT_EQ(s.else_body[0]->kind, StmtKind::kIf);
  EXPECT_FALSE(s.else_body[0]->has_else);
}

TEST(Parser, ModelAssignmentIsStoredAsResult) {
  Compiled c = compile(model("t = 1;\nmy_model = t * 2;"));
  ASSERT_TRUE(c.ok());
  const Object& o = c.program->objects[0];
  ASSERT_EQ(o.body.size(), 1u);
  ASSERT_TRUE(o.result);
  EXPECT_EQ(sexpr(*o.result), "(* t 2)");
  EXPECT_EQ(o.result_range.begin.line, 4u);
  EXPECT_EQ(o.result_range.begin.col, 1u);
}

TEST(Parser, MultipleObjectsAndDefaultModel) {
  Compiled c = compile(
      "first(x[3], a[1]) { first = 1; }\nmy_model(x[3], a[1]) { my_model = first(x, a); }\n"
      "third(x[2], a[1]) { third = x[2]; }\n");
  ASSERT_TRUE(c.ok()) << c.rendered();
  ASSERT_EQ(c.program->objects.size(), 3u);
  EXPECT_EQ(c.program->default_object(), 1);
  EXPECT_EQ(c.program->find_object("THIRD"), 2);
  EXPECT_EQ(c.program->find_object("none"), -1);
  Compiled d = compile("b(x[3], a[1]) { b = 1; } c(x[3], a[1]) { c = 2; }");
  EXPECT_EQ(d.program->default_object(), 0);
}

TEST(Parser, SourceRangesCoverTheText) {
  Compiled c = compile(model("v = max(1, 2) + 3;\nmy_model = v;"));
  ASSERT_TRUE(c.ok());
  const Stmt& s = *c.program->objects[0].body[0];
  EXPECT_EQ(s.range.begin.line, 3u);
  EXPECT_EQ(s.range.length, std::string("v = max(1, 2) + 3;").size());
  EXPECT_EQ(s.value->range.begin.col, 5u);
  EXPECT_EQ(s.value->range.length, std::string("max(1, 2) + 3").size());
  EXPECT_EQ(s.value->args[0]->name_range.length, 3u);
}

// ---- error recovery ---------------------------------------------------------------------

TEST(ParserRecovery, ReportsEveryBrokenStatement) {
  Compiled c = compile(model("v = 1 +;\nw = (2;\nu = 3 3;\nt = 4;\nmy_model = t;"));
  ASSERT_EQ(c.errors().size(), 3u) << c.rendered();
  EXPECT_EQ(c.errors()[0]->range.begin.line, 3u);
  EXPECT_EQ(c.errors()[1]->range.begin.line, 4u);
  EXPECT_EQ(c.errors()[2]->range.begin.line, 5u);
}

TEST(ParserRecovery, ErrorsInSeveralObjects) {
  Compiled c = compile(
      "one(x[3], a[1]) { v = ; one = 1; }\n"
      "two(x[3] a[1]) { two = 1; }\n"
      "three(x[3], a[1]) { three = 1 }\n");
  ASSERT_EQ(c.errors().size(), 3u) << c.rendered();
  EXPECT_EQ(c.errors()[0]->range.begin.line, 1u);
  EXPECT_EQ(c.errors()[1]->range.begin.line, 2u);
  EXPECT_EQ(c.errors()[2]->range.begin.line, 3u);
  EXPECT_EQ(c.program->objects.size(), 3u);
}

TEST(ParserRecovery, StopsAfterTwentyErrors) {
  std::string body;
  for (int i = 0; i < 50; ++i) body += "v = ;\n";
  Compiled c = compile(model(body + "my_model = 1;"));
  EXPECT_EQ(c.diags->error_count(), DiagnosticSink::kMaxErrors);
  ASSERT_FALSE(c.diags->diagnostics().empty());
  const Diagnostic& last = c.diags->diagnostics().back();
  EXPECT_EQ(last.severity, Severity::kNote);
  EXPECT_NE(last.message.find("too many errors"), std::string::npos);
}

TEST(ParserRecovery, ElseifGivesOneError) {
  Compiled c = compile(
      model("v = 0;\nif x[1] > 0 then v = 1; elseif x[1] < 0 then v = 2; endif;\nmy_model = v;"));
  ASSERT_EQ(c.errors().size(), 1u) << c.rendered();
  EXPECT_EQ(c.errors()[0]->message, "'elseif' is not HyperFun");
}

TEST(ParserRecovery, StrayKeywordsMakeProgress) {
  Compiled c = compile(model("else; endif; endloop; then loop;\nmy_model = 1;"));
  EXPECT_FALSE(c.ok());
  EXPECT_LE(c.errors().size(), 5u);
}

// ---- robustness -------------------------------------------------------------------------

// How long the front end takes on these inputs is measured by bench/frontend_bench.cpp.
void expect_error_no_crash(const std::string& text, const char* what) {
  Compiled c = compile(text);
  EXPECT_FALSE(c.ok()) << what;
  EXPECT_GE(c.errors().size(), 1u) << what;
  EXPECT_LE(c.diags->error_count(), DiagnosticSink::kMaxErrors) << what;
  std::string r = c.rendered();  // rendering must not crash either
  EXPECT_FALSE(r.empty()) << what;
}

TEST(Robustness, TenThousandNestedParentheses) {
  std::string e = std::string(10000, '(') + "1" + std::string(10000, ')');
  Compiled c = compile(model("my_model = " + e + ";"));
  ASSERT_FALSE(c.ok());
  ASSERT_EQ(c.errors().size(), 1u) << c.rendered();
  EXPECT_EQ(c.errors()[0]->message,
            "nesting is too deep (more than 256 levels of parentheses, calls, operators or "
            "blocks)");
  EXPECT_EQ(c.errors()[0]->range.begin.col, 12u + kMaxNesting);
}

TEST(Robustness, DeepNestingEverywhere) {
  const int n = 10000;
  expect_error_no_crash(model("if " + std::string(n, '(') + "1 > 0" + std::string(n, ')') +
                              " then endif; my_model = 1;"),
                        "parentheses in a condition");
  expect_error_no_crash(model("my_model = " + std::string(n, '-') + "1;"), "unary minus");
  expect_error_no_crash(model("if not " +
                              [&] {
                                std::string s;
                                for (int i = 0; i < n; ++i) s += "not ";
                                return s;
                              }() +
                              "1 then endif; my_model = 1;"),
                        "not");
  std::string calls;
  for (int i = 0; i < n; ++i) calls += "sqrt(";
  expect_error_no_crash(model("my_model = " + calls + "1" + std::string(n, ')') + ";"), "calls");
  std::string ifs;
  for (int i = 0; i < n; ++i) ifs += "if 1 then ";
  for (int i = 0; i < n; ++i) ifs += "endif; ";
  expect_error_no_crash(model(ifs + "my_model = 1;"), "nested if");
  // The too-deep block is skipped as a whole: one error, not one per 'endif'.
  EXPECT_EQ(compile(model(ifs + "my_model = 1;")).errors().size(), 1u);
  std::string idx;
  for (int i = 0; i < n; ++i) idx += "x[";
  expect_error_no_crash(model("my_model = " + idx + "1" + std::string(n, ']') + ";"), "index");
  // Only opening parentheses, to the end of the file.
  expect_error_no_crash(model("my_model = " + std::string(n, '(')), "unclosed");
}

TEST(Robustness, LongOperatorChainIsBounded) {
  // 5000 terms: no parser recursion, but a tree deeper than kMaxExprDepth.
  std::string e = "1";
  for (int i = 0; i < 5000; ++i) e += "+1";
  Compiled c = compile(model("my_model = " + e + ";"));
  ASSERT_EQ(c.errors().size(), 1u) << c.rendered();
  EXPECT_NE(c.errors()[0]->message.find("too deeply nested"), std::string::npos);
  // 900 terms are fine.
  std::string ok = "1";
  for (int i = 0; i < 900; ++i) ok += "+x[1]";
  EXPECT_TRUE(compile(model("my_model = " + ok + ";")).ok());
}

TEST(Robustness, TenMegabyteFile) {
  // ~10 MB of valid statements (generated-model style, with comments), then a syntax error
  // on the last line: the error is found, at the right line (its time: bench/frontend_bench.cpp).
  std::string text = "my_model(x[3], a[1])\n{\n  t0 = x[1];\n";
  int line = 3;
  int i = 1;
  while (text.size() < 10u * 1000 * 1000) {
    text += "  t" + std::to_string(i) + " = (t" + std::to_string(i - 1) +
            " * 0.999000001 + x[2]) / 1.000001;  -- generated statement number " +
            std::to_string(i) + "\n";
    ++line;
    ++i;
  }
  text += "  my_model = t" + std::to_string(i - 1) + " +;\n}\n";
  ++line;
  Compiled c = compile(text);
  ASSERT_EQ(c.errors().size(), 1u) << c.rendered().substr(0, 2000);
  EXPECT_EQ(c.errors()[0]->range.begin.line, static_cast<uint32_t>(line));
  // One 10 MB line of garbage: 20 errors at most, each rendered in bounded width.
  std::string junk(10u * 1000 * 1000, '$');
  for (size_t k = 0; k < junk.size(); k += 97) junk[k] = ' ';
  Compiled g = compile(junk);
  EXPECT_FALSE(g.ok());
  EXPECT_LT(g.rendered().size(), 20000u);
}

TEST(Robustness, RandomBinaryGarbage) {
  std::mt19937 rng(12345);
  for (int round = 0; round < 200; ++round) {
    std::string text(1 + rng() % 4000, '\0');
    for (char& ch : text) ch = static_cast<char>(rng() & 0xFF);
    expect_error_no_crash(text, "random bytes");
  }
}

TEST(Robustness, RandomTokenSoup) {
  // Random sequences of valid tokens exercise the recovery paths much more than bytes do.
  static const char* const kPieces[] = {
      "my_model", "(",     ")",     "x",    "a",       "s",        "[",   "]",   "{",     "}",
      ",",        ";",     "=",     "+",    "-",       "*",        "/",   "^",   "|",     "&",
      "\\",       "@",     "~",     "<",    "<=",      ">",        ">=",  "/=",  "if",    "then",
      "else",     "endif", "while", "loop", "endloop", "and",      "or",  "not", "array", "1",
      "3",        "0.5",   "v",     "c",    "sqrt",    "hfSphere", "max", "\n",  "xor",   "elseif"};
  std::mt19937 rng(777);
  for (int round = 0; round < 500; ++round) {
    std::string text = round % 2 ? "my_model(x[3], a[1]) {" : "";
    int n = 1 + static_cast<int>(rng() % 300);
    for (int k = 0; k < n; ++k) {
      text += kPieces[rng() % (sizeof kPieces / sizeof kPieces[0])];
      text += ' ';
    }
    Compiled c = compile(text);
    EXPECT_LE(c.diags->error_count(), DiagnosticSink::kMaxErrors);
    (void)c.rendered();
  }
}

TEST(Robustness, EmptyAndBlankFiles) {
  Compiled e = compile("");
  ASSERT_EQ(e.errors().size(), 1u);
  EXPECT_EQ(e.errors()[0]->message, "the file is empty");
  Compiled b = compile("  \n\t\r\n");
  ASSERT_EQ(b.errors().size(), 1u);
  EXPECT_EQ(b.errors()[0]->message, "the file is empty");
  Compiled c = compile("-- just a comment\n");
  ASSERT_EQ(c.errors().size(), 1u);
  EXPECT_EQ(c.errors()[0]->message, "the file contains no object definition");
}

TEST(Robustness, NulByteInAModel) {
  std::string text = model("v = 1;\nmy_model = v;");
  text.insert(text.find("v = 1"), std::string("\0", 1));
  Compiled c = compile(text);
  ASSERT_GE(c.errors().size(), 1u);
  EXPECT_EQ(c.errors()[0]->message, "NUL byte in the source text");
  EXPECT_EQ(c.errors()[0]->range.begin.line, 3u);
  std::string r = c.rendered();
  EXPECT_EQ(r.find('\0'), std::string::npos);
}

TEST(Robustness, UnterminatedConstructs) {
  const char* cases[] = {
      "my_model(x[3], a[1]",
      "my_model(x[3], a[1]) {",
      "my_model(x[3], a[1]) { my_model = 1;",
      "my_model(x[3], a[1]) { if x[1] > 0 then my_model = 1;",
      "my_model(x[3], a[1]) { while 1 loop v = 1;",
      "my_model(x[3], a[1]) { my_model = (1 + 2",
      "my_model(x[3], a[1]) { my_model = max(1, 2",
      "my_model(x[3], a[1]) { array c[3]; c = [1, 2",
      "my_model(x[3], a[1]) { my_model = x[1",
      "my_model(x[3], a[1]) { my_model = \"abc",
      "my_model(x[3], a[1]) { /* my_model = 1; }",
      "my_model(x[",
      "my_model",
  };
  for (const char* text : cases) expect_error_no_crash(text, text);
}

}  // namespace
}  // namespace hfrt::lang

namespace hfrt::lang {
namespace {

TEST(Robustness, DeepestAllowedNestingIsCheckedAndDumped) {
  // Just under the limits: the checks and the dump (both recursive) handle it.
  const int n = kMaxNesting - 2;
  std::string e = std::string(n, '(') + "x[1]" + std::string(n, ')');
  std::string chain = "1";
  for (int i = 0; i < kMaxExprDepth - 10; ++i) chain += "-x[2]";
  testing::Compiled c =
      testing::compile(testing::model("v = " + e + ";\nmy_model = v + " + chain + ";"));
  ASSERT_TRUE(c.ok()) << c.rendered().substr(0, 1000);
  std::string dump = dump_ast(*c.program);
  EXPECT_NE(dump.find("index x (x)"), std::string::npos);
}

}  // namespace
}  // namespace hfrt::lang

namespace hfrt::lang {
namespace {

using testing::compile;
using testing::Compiled;
using testing::model;

// ---- limits on hostile input (base/limits.h) ------------------------------------------------

TEST(Limits, HugeArrayIsALocatedErrorNamingTheOption) {
  Compiled c = compile(model("array v[1000000000];\nmy_model = 1;"));
  ASSERT_EQ(c.errors().size(), 1u) << c.rendered();
  const Diagnostic& d = *c.errors()[0];
  EXPECT_EQ(d.message, "array size 1000000000 is more than the limit of 8192 elements");
  EXPECT_EQ(d.range.begin.line, 3u);
  EXPECT_EQ(d.range.begin.col, 9u);
  EXPECT_EQ(d.range.length, 10u);
  EXPECT_NE(d.hint.find("--max-array-size N"), std::string::npos) << d.hint;
  EXPECT_NE(d.hint.find("ModelLimits::max_array_size"), std::string::npos) << d.hint;
}

TEST(Limits, ArraySizeLimitIsConfigurableAndCoversHeaders) {
  auto parse = [](const std::string& text, int64_t max) {
    auto file = std::make_shared<const SourceFile>("t.hf", text);
    auto diags = std::make_unique<DiagnosticSink>(file);
    Limits limits;
    limits.max_array_size = max;
    parse_program(file, *diags, limits);
    return diags->render(false);
  };
  const std::string src = "m(x[3], a[20]) { array v[10]; m = 1; }";
  EXPECT_EQ(parse(src, 20), "");
  EXPECT_NE(parse(src, 19).find("t.hf:1:11: error: array size 20 is more than the limit of 19 "
                                "elements"),
            std::string::npos)
      << parse(src, 19);
  EXPECT_NE(parse(src, 9).find("1:11: error: array size 20"), std::string::npos);
}

TEST(Robustness, AMillionNestedParenthesesAreAnErrorNotACrash) {
  std::string e = std::string(1000000, '(') + "1" + std::string(1000000, ')');
  Compiled c = compile(model("my_model = " + e + ";"));
  ASSERT_FALSE(c.ok());
  ASSERT_EQ(c.errors().size(), 1u) << c.errors().size();
  EXPECT_EQ(c.errors()[0]->range.begin.line, 3u);
  EXPECT_EQ(c.errors()[0]->range.begin.col, 12u + kMaxNesting);
}

}  // namespace
}  // namespace hfrt::lang
