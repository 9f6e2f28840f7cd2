// Semantic checks: name resolution to symbols, local numbering, call signatures, array
// sizes, the model assignment rule and the possibly-uninitialised warning.
#include <gtest/gtest.h>

#include "lang/builtins.h"
#include "lang/library_table.h"
#include "tests/lang/test_util.h"

namespace hfrt::lang {
namespace {

using testing::compile;
using testing::Compiled;
using testing::model;

const Diagnostic* first_error(const Compiled& c) {
  auto e = c.errors();
  return e.empty() ? nullptr : e[0];
}

TEST(Sema, ResolvesEveryKindOfName) {
  Compiled c = compile(
      "helper(x[3], a[2]) { helper = x[1]; }\n"
      "my_model(x[3], a[2], s[3]) {\n"
      "  array c[3], d[2];\n"
      "  c = [0, 0, 0];\n"
      "  v = hfSphere(x, c, a[2]);\n"
      "  d[1] = sqrt(v);\n"
      "  s[1] = helper(x, d);\n"
      "  w = v + d[1];\n"
      "  my_model = max(v, w);\n"
      "}\n");
  ASSERT_TRUE(c.ok()) << c.rendered();
  const Object& o = c.program->objects[1];
  EXPECT_EQ(o.scalars, (std::vector<std::string>{"v", "w"}));
  const auto& b = o.body;
  // c = [0, 0, 0]
  EXPECT_EQ(b[0]->symbol.kind, SymbolKind::kLocalArray);
  EXPECT_EQ(b[0]->symbol.index, 0);
  // v = hfSphere(x, c, a[2])
  EXPECT_EQ(b[1]->symbol.kind, SymbolKind::kLocalScalar);
  EXPECT_EQ(b[1]->symbol.index, 0);
  const Expr& call = *b[1]->value;
  EXPECT_EQ(call.symbol.kind, SymbolKind::kLibrary);
  EXPECT_EQ(call.symbol.index, static_cast<int>(LibraryFn::kSphere));
  EXPECT_EQ(call.args[0]->symbol.kind, SymbolKind::kX);
  EXPECT_EQ(call.args[1]->symbol.kind, SymbolKind::kLocalArray);
  EXPECT_EQ(call.args[1]->symbol.index, 0);
  EXPECT_EQ(call.args[2]->symbol.kind, SymbolKind::kA);
  // d[1] = sqrt(v)
  EXPECT_EQ(b[2]->symbol.kind, SymbolKind::kLocalArray);
  EXPECT_EQ(b[2]->symbol.index, 1);
  EXPECT_EQ(b[2]->value->symbol.kind, SymbolKind::kBuiltin);
  EXPECT_EQ(b[2]->value->symbol.index, static_cast<int>(Builtin::kSqrt));
  EXPECT_EQ(b[2]->value->args[0]->symbol.kind, SymbolKind::kLocalScalar);
  // s[1] = helper(x, d)
  EXPECT_EQ(b[3]->symbol.kind, SymbolKind::kS);
  EXPECT_EQ(b[3]->value->symbol.kind, SymbolKind::kObject);
  EXPECT_EQ(b[3]->value->symbol.index, 0);
  // w = v + d[1]
  EXPECT_EQ(b[4]->symbol.index, 1);
  EXPECT_EQ(b[4]->value->args[1]->symbol.kind, SymbolKind::kLocalArray);
  // result max(v, w)
  EXPECT_EQ(o.result->symbol.index, static_cast<int>(Builtin::kMax));
  EXPECT_EQ(o.result->args[1]->symbol.index, 1);
}

TEST(Sema, ScalarsAreNumberedInFirstAssignmentOrder) {
  Compiled c =
      compile(model("b = 1;\nif x[1] > 0 then c = 2; else a1 = 3; endif;\nwhile b < 0 loop d = 1; "
                    "b = b + 1; endloop;\n"
                    "B = 4; c = 5; a1 = 1; d = 0;\nmy_model = b + c + a1 + d;"));
  ASSERT_TRUE(c.ok()) << c.rendered();
  EXPECT_EQ(c.program->objects[0].scalars, (std::vector<std::string>{"b", "c", "a1", "d"}));
  // 'B' is the same local as 'b'.
  EXPECT_EQ(c.program->objects[0].body[3]->symbol.index, 0);
}

TEST(Sema, ScalarMayBeAssignedAfterItsFirstUseInALoop) {
  // Declared by an assignment later in the source: not an "undefined name", only a warning.
  Compiled c = compile(
      model("i = 0; t = 0;\nwhile i < 3 loop u = t; t = i; i = i + 1; endloop;\nmy_model = t;"));
  EXPECT_TRUE(c.ok()) << c.rendered();
  EXPECT_TRUE(c.warnings().empty()) << c.rendered();
  Compiled d =
      compile(model("i = 0;\nwhile i < 3 loop u = t; t = i; i = i + 1; endloop;\nmy_model = i;"));
  EXPECT_TRUE(d.ok()) << d.rendered();
  ASSERT_EQ(d.warnings().size(), 1u);
  EXPECT_EQ(d.warnings()[0]->message, "'t' may be used before it is assigned");
  EXPECT_EQ(d.warnings()[0]->range.begin.line, 4u);
  EXPECT_EQ(d.warnings()[0]->range.begin.col, 22u);
}

TEST(Sema, UninitialisedWarnings) {
  // Assigned in one branch only.
  Compiled one = compile(model("if x[1] > 5 then v = 1; endif;\nmy_model = v;"));
  EXPECT_TRUE(one.ok());
  ASSERT_EQ(one.warnings().size(), 1u);
  EXPECT_EQ(one.warnings()[0]->range.begin.line, 4u);
  // Assigned in both branches: fine.
  Compiled both = compile(model("if x[1] > 5 then v = 1; else v = 2; endif;\nmy_model = v;"));
  EXPECT_TRUE(both.warnings().empty()) << both.rendered();
  // Only in a loop body.
  Compiled loop =
      compile(model("i = 0; while i < 2 loop v = i; i = i + 1; endloop;\nmy_model = v;"));
  ASSERT_EQ(loop.warnings().size(), 1u);
  // Used in its own first assignment.
  Compiled self = compile(model("v = v + 1;\nmy_model = v;"));
  ASSERT_EQ(self.warnings().size(), 1u);
  EXPECT_EQ(self.warnings()[0]->range.begin.col, 5u);
  // Nested ifs that assign on every path.
  Compiled nested =
      compile(model("if x[1] > 0 then if x[2] > 0 then v = 1; else v = 2; endif; else v = 3; "
                    "endif;\nmy_model = v;"));
  EXPECT_TRUE(nested.warnings().empty()) << nested.rendered();
  // Read inside the branch that assigned it: fine.
  Compiled inside = compile(model("w = 0; if x[1] > 0 then v = 1; w = v; endif;\nmy_model = w;"));
  EXPECT_TRUE(inside.warnings().empty()) << inside.rendered();
  // One warning per variable, not per read.
  Compiled many =
      compile(model("if x[1] > 0 then v = 1; endif;\nw = v + v * v;\nmy_model = w + v;"));
  EXPECT_EQ(many.warnings().size(), 1u);
}

TEST(Sema, UndefinedNameIsAnError) {
  Compiled c = compile(model("my_model = foo + 1;"));
  ASSERT_NE(first_error(c), nullptr);
  EXPECT_EQ(first_error(c)->message, "'foo' is used but never assigned");
  EXPECT_EQ(first_error(c)->range.begin.line, 3u);
  EXPECT_EQ(first_error(c)->range.begin.col, 12u);
  // With a near miss, the hint suggests it.
  Compiled d = compile(model("radius = 1;\nmy_model = radus;"));
  ASSERT_NE(first_error(d), nullptr);
  EXPECT_EQ(first_error(d)->hint, "did you mean 'radius'?");
}

TEST(Sema, ReservedNamesCannotBeLocals) {
  for (const char* name : {"max", "SQRT", "hfSphere", "hfa_wave"}) {
    Compiled c = compile(model(std::string(name) + " = 1;\nmy_model = 1;"));
    EXPECT_FALSE(c.ok()) << name;
  }
  EXPECT_FALSE(compile(model("x = 1;\nmy_model = 1;")).ok());
  EXPECT_FALSE(compile(model("a = 1;\nmy_model = 1;")).ok());
  EXPECT_FALSE(compile(model("s = 1;\nmy_model = 1;", "x[3], a[1], s[1]")).ok());
  EXPECT_FALSE(compile(model("array max[2];\nmy_model = 1;")).ok());
  EXPECT_FALSE(compile(model("array x[2];\nmy_model = 1;")).ok());
  EXPECT_FALSE(compile(model("array my_model[2];\nmy_model = 1;")).ok());
  // Names that merely contain reserved words are fine.
  EXPECT_TRUE(
      compile(model("maxv = 1; x1 = 2; sx = 3; ifs = 4;\nmy_model = maxv + x1 + sx + ifs;")).ok());
}

TEST(Sema, BuiltinArityAndArgumentKinds) {
  EXPECT_TRUE(compile(model("my_model = atan2(x[1], x[2]) + mod(7, 3) + frac(x[3]);")).ok());
  EXPECT_FALSE(compile(model("my_model = sqrt(1, 2);")).ok());
  EXPECT_FALSE(compile(model("my_model = max(1);")).ok());
  EXPECT_FALSE(compile(model("my_model = sin();")).ok());
  EXPECT_FALSE(compile(model("my_model = sqrt(x);")).ok());
}

TEST(Sema, LibraryArgumentKinds) {
  const std::string decl = "array c[3];\nc = [0, 0, 0];\n";
  EXPECT_TRUE(compile(model(decl + "my_model = hfSphere(x, c, 1);")).ok());
  EXPECT_TRUE(compile(model(decl + "my_model = hfSphere(X, C, a[1] + 1);")).ok());
  EXPECT_TRUE(compile(model(decl + "my_model = hfSphere(s, c, 1);", "x[3], a[1], s[3]")).ok());
  // 'A' arguments: only a bare array name.
  for (const char* bad : {"x[1]", "1", "c + 1", "-c", "v", "sqrt(2)", "hfSphere"}) {
    Compiled c =
        compile(model(decl + "v = 1;\nmy_model = hfSphere(x, " + std::string(bad) + ", 1);"));
    ASSERT_FALSE(c.ok()) << bad;
    EXPECT_NE(first_error(c)->message.find("must be an array name"), std::string::npos)
        << bad << ": " << first_error(c)->message;
  }
  // 'R' arguments: a bare array name is an error.
  Compiled r = compile(model(decl + "my_model = hfSphere(x, c, c);"));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(first_error(r)->message,
            "argument 3 of 'hfSphere' must be a number, not the array 'c'");
  // Count.
  EXPECT_FALSE(compile(model(decl + "my_model = hfSphere(x, c);")).ok());
  EXPECT_FALSE(compile(model(decl + "my_model = hfSphere(x, c, 1, 2);")).ok());
  // s without s[k] in the header.
  Compiled s = compile(model(decl + "my_model = hfSphere(s, c, 1);"));
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(first_error(s)->message, "object 'my_model' has no 's' array in its header");
}

TEST(Sema, EveryLibraryFunctionAcceptsItsSignature) {
  // Generated calls for every signature: array names for 'A', numbers for 'R', a file name for
  // 'F' (the mesh and patch leaves of issue 10).
  std::string body = "array p[3];\np = [1, 2, 3];\nv = 0;\n";
#define HFRT_X(e, s, k)                                                      \
  {                                                                          \
    std::string call = std::string(s) + "(";                                 \
    std::string_view kinds = k;                                              \
    for (size_t i = 0; i < kinds.size(); ++i) {                              \
      call += i ? ", " : "";                                                 \
      call += kinds[i] == 'A' ? "p" : kinds[i] == 'F' ? "\"m.off\"" : "0.5"; \
    }                                                                        \
    body += "v = v + " + call + ");\n";                                      \
  }
  HFRT_LIBRARY(HFRT_X)
#undef HFRT_X
  Compiled c = compile(model(body + "my_model = v;"));
  EXPECT_TRUE(c.ok()) << c.rendered();
}

TEST(Sema, ObjectCalls) {
  const std::string callee = "two(x[2], a[1], s[2]) { two = x[1]; }\n";
  EXPECT_TRUE(compile(callee + "my_model(x[3], a[1]) { array p[2]; p[1] = x[1]; p[2] = x[2];\n"
                               " my_model = two(p, a); }")
                  .ok());
  EXPECT_TRUE(compile(callee + "my_model(x[3], a[1], s[2]) { array p[2]; p = [1, 2];\n"
                               " my_model = two(p, a, s); }")
                  .ok());
  // Size mismatch.
  Compiled m = compile(callee + "my_model(x[3], a[1]) {\n my_model = two(x, a); }");
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(first_error(m)->message, "array 'x' has 3 elements, but object 'two' expects x[2]");
  EXPECT_EQ(first_error(m)->range.begin.line, 3u);
  EXPECT_EQ(first_error(m)->range.begin.col, 17u);
  // Wrong count, non-array arguments.
  EXPECT_FALSE(
      compile(callee + "my_model(x[3], a[1]) { array p[2]; p = [1, 2]; my_model = two(p); }").ok());
  EXPECT_FALSE(
      compile(callee + "my_model(x[3], a[1]) { array p[2]; p = [1, 2]; my_model = two(p, 1); }")
          .ok());
  EXPECT_FALSE(
      compile(
          "one(x[3], a[1]) { one = 1; }\nmy_model(x[3], a[1], s[1]) { my_model = one(x, a, s); }")
          .ok());
  // Forward reference and recursion.
  Compiled f = compile(
      "my_model(x[3], a[1]) {\n my_model = other(x, a);\n}\nother(x[3], a[1]) { other = 1; }");
  ASSERT_FALSE(f.ok());
  EXPECT_EQ(first_error(f)->range.begin.line, 2u);
  EXPECT_FALSE(compile("my_model(x[3], a[1]) { my_model = my_model(x, a); }").ok());
}

TEST(Sema, ArrayLiteralSizeMustMatch) {
  EXPECT_TRUE(compile(model("array c[3];\nc = [1, 2, 3];\nmy_model = c[1];")).ok());
  EXPECT_FALSE(compile(model("array c[3];\nc = [1, 2];\nmy_model = c[1];")).ok());
  EXPECT_FALSE(compile(model("array c[2];\nc = [1, 2, 3];\nmy_model = c[1];")).ok());
  EXPECT_TRUE(compile(model("s = [1, 2, 3];\nmy_model = 1;", "x[3], a[1], s[3]")).ok());
  EXPECT_FALSE(compile(model("s = [1, 2];\nmy_model = 1;", "x[3], a[1], s[3]")).ok());
  EXPECT_FALSE(compile(model("x = [1, 2, 3];\nmy_model = 1;")).ok());
  EXPECT_FALSE(compile(model("v = 1;\nv = [1];\nmy_model = 1;")).ok());
}

TEST(Sema, AssignmentsToHeaderArrays) {
  EXPECT_FALSE(compile(model("x[1] = 5;\nmy_model = x[1];")).ok());
  EXPECT_FALSE(compile(model("a[1] = 5;\nmy_model = 1;")).ok());
  EXPECT_TRUE(compile(model("s[2] = x[1];\nmy_model = 1;", "x[3], a[1], s[3]")).ok());
  EXPECT_FALSE(compile(model("s[2] = x[1];\nmy_model = 1;")).ok());
}

TEST(Sema, ModelAssignmentOnlyLast) {
  Compiled c = compile(model("if (x[1] > 0) then my_model = 1; endif;\nmy_model = 2;"));
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(first_error(c)->range.begin.line, 3u);
  EXPECT_EQ(first_error(c)->range.begin.col, 20u);
  EXPECT_FALSE(compile(model("my_model = 1;\nv = 2;\nmy_model = v;")).ok());
  // Missing the final assignment.
  Compiled m = compile(model("v = 1;"));
  ASSERT_FALSE(m.ok());
  EXPECT_EQ(first_error(m)->message, "object 'my_model' must end by assigning its value");
}

TEST(Sema, DuplicateNames) {
  Compiled o = compile("m(x[3], a[1]) { m = 1; }\nM(x[3], a[1]) { M = 2; }");
  ASSERT_FALSE(o.ok());
  EXPECT_EQ(first_error(o)->range.begin.line, 2u);
  Compiled a = compile(model("array c[3], C[2];\nmy_model = 1;"));
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(first_error(a)->message, "array 'C' is already declared (at 3:7)");
}

TEST(Sema, ArraysAndScalarsInTheWrongPlace) {
  EXPECT_FALSE(compile(model("array c[3];\nc = [1, 2, 3];\nmy_model = c;")).ok());
  EXPECT_FALSE(compile(model("my_model = x;")).ok());
  EXPECT_FALSE(compile(model("v = 1;\nmy_model = v[1];")).ok());
  EXPECT_FALSE(compile(model("my_model = q[1];")).ok());
  EXPECT_FALSE(compile(model("array c[3];\nc = 1;\nmy_model = 1;")).ok());
  EXPECT_FALSE(compile(model("v = 1;\nmy_model = v(1);")).ok());
  EXPECT_FALSE(compile(model("my_model = nosuch(1);")).ok());
  EXPECT_FALSE(compile(model("my_model = sqrt;")).ok());
}

TEST(Sema, ConstantIndexOutOfRangeWarns) {
  Compiled c = compile(model("my_model = x[4] + x[3.4] + x[0.6];"));
  EXPECT_TRUE(c.ok()) << c.rendered();
  ASSERT_EQ(c.warnings().size(), 1u) << c.rendered();
  EXPECT_EQ(c.warnings()[0]->message, "index 4 is out of range for 'x', which has 3 elements");
  EXPECT_EQ(compile(model("my_model = x[-1];")).warnings().size(), 1u);
  EXPECT_EQ(compile(model("my_model = x[0.4];")).warnings().size(), 1u);
}

TEST(Sema, ObjectsWithSyntaxErrorsAreNotChecked) {
  // The broken object reports its syntax error only; the intact one is still checked.
  Compiled c = compile(
      "one(x[3], a[1]) { v = (1; one = undefined1; }\n"
      "two(x[3], a[1]) { two = undefined2; }\n");
  ASSERT_EQ(c.errors().size(), 2u) << c.rendered();
  EXPECT_EQ(c.errors()[0]->range.begin.line, 1u);
  EXPECT_EQ(c.errors()[1]->message, "'undefined2' is used but never assigned");
  EXPECT_TRUE(c.program->objects[0].had_syntax_errors);
  EXPECT_FALSE(c.program->objects[1].had_syntax_errors);
}

TEST(Sema, CompileSourceReturnsNullOnErrors) {
  auto good = std::make_shared<const SourceFile>("g.hf", model("my_model = 1;"));
  DiagnosticSink gd(good);
  EXPECT_NE(compile_source(good, gd), nullptr);
  auto bad = std::make_shared<const SourceFile>("b.hf", model("my_model = q;"));
  DiagnosticSink bd(bad);
  EXPECT_EQ(compile_source(bad, bd), nullptr);
  EXPECT_TRUE(bd.has_errors());
  // Warnings alone do not fail.
  auto warn = std::make_shared<const SourceFile>(
      "w.hf", model("if x[1] > 0 then v = 1; endif;\nmy_model = v;"));
  DiagnosticSink wd(warn);
  EXPECT_NE(compile_source(warn, wd), nullptr);
  EXPECT_EQ(wd.warning_count(), 1);
}

TEST(AstDump, StableTextForm) {
  Compiled c = compile(
      "m(x[3], a[1], s[3])\n{\n array c[2];\n c = [1, -2.5];\n v = -x[1]^2;\n"
      " if not v > 0 and c[1] /= 1 then s[1] = v; else endif;\n"
      " while v < 1 loop v = v + 1; endloop;\n m = hfSphere(x, c, v) | max(v, 1);\n}\n");
  ASSERT_TRUE(c.ok()) << c.rendered();
  const std::string want =
      "program 1 object, model m\n"
      "object m(x[3], a[1], s[3]) @1:1\n"
      "  array c[2] @3:8\n"
      "  scalars v\n"
      "  assign-array c (array#0) [1, -2.5] @4:2\n"
      "  assign v (local#0) @5:2\n"
      "    binary ^\n"
      "      unary -\n"
      "        index x (x)\n"
      "          number 1\n"
      "      number 2\n"
      "  if @6:2\n"
      "    cond\n"
      "      binary and\n"
      "        binary >\n"
      "          unary not\n"
      "            name v (local#0)\n"
      "          number 0\n"
      "        binary /=\n"
      "          index c (array#0)\n"
      "            number 1\n"
      "          number 1\n"
      "    then\n"
      "      assign-element s (s) @6:34\n"
      "        number 1\n"
      "        name v (local#0)\n"
      "    else\n"
      "  while @7:2\n"
      "    cond\n"
      "      binary <\n"
      "        name v (local#0)\n"
      "        number 1\n"
      "    loop\n"
      "      assign v (local#0) @7:19\n"
      "        binary +\n"
      "          name v (local#0)\n"
      "          number 1\n"
      "  result @8:2\n"
      "    binary |\n"
      "      call hfSphere (library hfSphere)\n"
      "        name x (x)\n"
      "        name c (array#0)\n"
      "        name v (local#0)\n"
      "      call max (builtin max)\n"
      "        name v (local#0)\n"
      "        number 1\n";
  EXPECT_EQ(dump_ast(*c.program), want);
}

}  // namespace
}  // namespace hfrt::lang
