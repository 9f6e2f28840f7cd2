// Diagnostics: the gcc/clang-style rendering, the error limit, and one test per distinct
// message of the front end, checking its exact text and its line:column.
#include "lang/diagnostics.h"

#include <gtest/gtest.h>

#include <string>

#include "tests/lang/test_util.h"

namespace hfrt::lang {
namespace {

using testing::compile;
using testing::Compiled;

// ---- rendering --------------------------------------------------------------------------

TEST(Render, LocationMessageSourceCaretHint) {
  SourceFile f("model.hf", "first line\n  v = foo + 1;\n");
  Diagnostic d{
      Severity::kError, {f.loc_at(17), 3}, "'foo' is used but never assigned", "assign it first"};
  EXPECT_EQ(render_diagnostic(f, d, false),
            "model.hf:2:7: error: 'foo' is used but never assigned\n"
            "   v = foo + 1;\n"
            "       ^~~\n"
            "hint: assign it first\n");
}

TEST(Render, WarningAndNoteAndNoHint) {
  SourceFile f("w.hf", "abc\n");
  Diagnostic w{Severity::kWarning, {f.loc_at(1), 1}, "careful", ""};
  EXPECT_EQ(render_diagnostic(f, w, false), "w.hf:1:2: warning: careful\n abc\n  ^\n");
  Diagnostic n{Severity::kNote, {f.loc_at(0), 0}, "see here", ""};
  EXPECT_EQ(render_diagnostic(f, n, false), "w.hf:1:1: note: see here\n abc\n ^\n");
}

TEST(Render, TabsAreKeptSoTheCaretLinesUp) {
  SourceFile f("t.hf", "\tv = \tq;\n");
  Diagnostic d{Severity::kError, {f.loc_at(6), 1}, "m", ""};
  EXPECT_EQ(render_diagnostic(f, d, false), "t.hf:1:7: error: m\n \tv = \tq;\n \t    \t^\n");
}

TEST(Render, UnderlineStopsAtTheEndOfTheLine) {
  SourceFile f("u.hf", "ab\ncd\n");
  Diagnostic d{Severity::kError, {f.loc_at(1), 100}, "m", ""};
  EXPECT_EQ(render_diagnostic(f, d, false), "u.hf:1:2: error: m\n ab\n  ^\n");
}

TEST(Render, EndOfFileLocation) {
  SourceFile f("e.hf", "ab");
  Diagnostic d{Severity::kError, {f.loc_at(2), 0}, "m", ""};
  EXPECT_EQ(render_diagnostic(f, d, false), "e.hf:1:3: error: m\n ab\n   ^\n");
}

TEST(Render, ControlBytesAreNotPrinted) {
  SourceFile f("c.hf", std::string("a\0b\x1b[31m", 8));
  Diagnostic d{Severity::kError, {f.loc_at(1), 1}, "m", ""};
  std::string r = render_diagnostic(f, d, false);
  EXPECT_EQ(r.find('\0'), std::string::npos);
  EXPECT_EQ(r.find('\x1b'), std::string::npos);
}

TEST(Render, LongLinesAreWindowed) {
  std::string line(100000, 'x');
  SourceFile f("l.hf", line);
  Diagnostic d{Severity::kError, {f.loc_at(50000), 1}, "m", ""};
  std::string r = render_diagnostic(f, d, false);
  EXPECT_LT(r.size(), 500u);
  EXPECT_NE(r.find("..."), std::string::npos);
  // The caret is under the right character: 3 for "...", 80 bytes of context before it.
  size_t caret_line = r.find('\n', r.find('\n') + 1) + 1;
  EXPECT_EQ(r.find('^', caret_line) - caret_line, 1u + 3u + 80u);
}

TEST(Render, ColorAddsAnsiCodes) {
  SourceFile f("k.hf", "v\n");
  Diagnostic d{Severity::kError, {f.loc_at(0), 1}, "m", "h"};
  std::string plain = render_diagnostic(f, d, false);
  std::string color = render_diagnostic(f, d, true);
  EXPECT_EQ(plain.find('\x1b'), std::string::npos);
  EXPECT_NE(color.find("\x1b[1;31merror"), std::string::npos);
  EXPECT_NE(color.find("\x1b[0m"), std::string::npos);
}

TEST(Sink, CountsAndLimits) {
  auto f = std::make_shared<const SourceFile>("s.hf", "x\n");
  DiagnosticSink sink(f);
  EXPECT_FALSE(sink.has_errors());
  sink.warning({f->loc_at(0), 1}, "w");
  EXPECT_FALSE(sink.has_errors());
  for (int i = 0; i < 30; ++i) sink.error({f->loc_at(0), 1}, "e" + std::to_string(i));
  EXPECT_EQ(sink.error_count(), DiagnosticSink::kMaxErrors);
  EXPECT_TRUE(sink.saturated());
  // 1 warning + 20 errors + one "too many errors" note.
  ASSERT_EQ(sink.diagnostics().size(), 22u);
  EXPECT_EQ(sink.diagnostics().back().severity, Severity::kNote);
  std::string r = sink.render();
  EXPECT_NE(r.find("s.hf:1:1: error: e19"), std::string::npos);
  EXPECT_EQ(r.find("e20"), std::string::npos);
  for (int i = 0; i < 500; ++i) sink.warning({f->loc_at(0), 1}, "w");
  EXPECT_LE(sink.warning_count(), DiagnosticSink::kMaxWarnings);
}

// ---- every message, with its text and location ------------------------------------------

struct MessageCase {
  const char* id;
  std::string source;
  uint32_t line;
  uint32_t col;
  Severity severity;
  std::string message;
  bool last = false;  ///< check the last diagnostic instead of the first
};

void PrintTo(const MessageCase& c, std::ostream* os) {
  *os << c.id;
}

// Bodies start at column 17 after this header.
std::string obj(const std::string& body) {
  return "m(x[3], a[1]) { " + body + " }";
}

const Severity E = Severity::kError;
const Severity W = Severity::kWarning;

std::string many_errors() {
  std::string body;
  for (int i = 0; i < 25; ++i) body += "v = ;\n";
  return "m(x[3], a[1])\n{\n" + body + "m = 1;\n}\n";
}

const MessageCase kMessages[] = {
    // lexer
    {"slash_comment", "m(x[3], a[1]) { // c\n m = 1; }", 1, 17, E,
     "'//' does not start a comment in HyperFun"},
    {"block_comment", obj("/* c */ m = 1;"), 1, 17, E, "'/* ... */' comments are not HyperFun"},
    {"eqeq", obj("v = 0; if v == 1 then v = 2; endif; m = v;"), 1, 29, E,
     "'==' is not a HyperFun operator"},
    {"bang_eq", obj("v = 0; if v != 1 then v = 2; endif; m = v;"), 1, 29, E,
     "'!=' is not a HyperFun operator"},
    {"bang", obj("v = 0; if ! v then v = 2; endif; m = v;"), 1, 27, E,
     "'!' is not a HyperFun operator"},
    {"ampamp", obj("v = 0; if v > 0 && v < 2 then v = 2; endif; m = v;"), 1, 33, E,
     "'&&' is not a HyperFun operator"},
    {"barbar", obj("v = 0; if v > 0 || v < 2 then v = 2; endif; m = v;"), 1, 33, E,
     "'||' is not a HyperFun operator"},
    {"string", obj("m = \"abc\";"), 1, 21, E, "strings are not part of HyperFun"},
    {"lone_dot", obj("m = . ;"), 1, 21, E, "'.' must be followed by digits here"},
    {"nul", std::string("m(x[3], a[1]) { m = 1;\0 }", 25), 1, 23, E, "NUL byte in the source text"},
    {"unexpected_char", obj("m = 1 $ 2;"), 1, 23, E, "unexpected character '$'"},
    {"unexpected_chars", obj("m = 1 #?;"), 1, 23, E, "unexpected characters '#?'"},
    {"long_name", obj(std::string(257, 'q') + " = 1; m = 1;"), 1, 17, E,
     "name is 257 characters long; at most 256 are allowed"},
    {"leading_zero", obj("m = 01;"), 1, 21, E, "number '01' starts with 0"},
    {"exponent_zero", obj("m = 1e05;"), 1, 21, E, "exponent of '1e05' starts with 0"},
    {"exponent_digits", obj("m = 1e+;"), 1, 21, E, "number '1e+' has no exponent digits"},
    {"too_large", obj("m = 1e400;"), 1, 21, E, "number '1e400' is too large"},
    // parser
    {"xor", obj("v = 0; if (1 xor 0) then v = 1; endif; m = v;"), 1, 30, E,
     "'xor' is reserved but is not an operator"},
    {"expected_object", "42", 1, 1, E, "expected an object definition, found number '42'"},
    {"empty_file", "", 1, 1, E, "the file is empty"},
    {"no_object", "-- nothing\n", 1, 1, E, "the file contains no object definition"},
    {"header_lparen", "m x[3], a[1]) { m = 1; }", 1, 3, E,
     "expected '(' after the object name 'm', found 'x'"},
    {"header_x", "m(y[3], a[1]) { m = 1; }", 1, 3, E,
     "expected 'x[...]' in the header of object 'm', found 'y'"},
    {"header_a", "m(x[3], b[1]) { m = 1; }", 1, 9, E,
     "expected 'a[...]' in the header of object 'm', found 'b'"},
    {"header_s", "m(x[3], a[1], t[1]) { m = 1; }", 1, 15, E,
     "expected 's[...]' in the header of object 'm', found 't'"},
    {"header_comma", "m(x[3] a[1]) { m = 1; }", 1, 8, E,
     "expected ',' in the header of object 'm', found 'a'"},
    {"header_lbracket", "m(x 3], a[1]) { m = 1; }", 1, 5, E,
     "expected '[' in the header of object 'm', found number '3'"},
    {"header_size", "m(x[], a[1]) { m = 1; }", 1, 5, E,
     "expected an array size in the header of object 'm', found ']'"},
    {"header_rbracket", "m(x[3, a[1]) { m = 1; }", 1, 6, E,
     "expected ']' in the header of object 'm', found ','"},
    {"header_rparen", "m(x[3], a[1] { m = 1; }", 1, 14, E,
     "expected ')' in the header of object 'm', found '{'"},
    {"size_range", "m(x[0], a[1]) { m = 1; }", 1, 5, E,
     "array size must be a whole number from 1 to 8192, found number '0'"},
    {"lbrace", "m(x[3], a[1]) m = 1; }", 1, 15, E,
     "expected '{' to start the body of object 'm', found 'm'"},
    {"missing_rbrace", "m(x[3], a[1]) { m = 1;", 1, 23, E,
     "missing '}' at the end of object 'm' (its '{' is at 1:15)"},
    {"no_final_assignment", obj("v = 1;"), 1, 24, E, "object 'm' must end by assigning its value"},
    {"array_keyword_name", obj("array if[3]; m = 1;"), 1, 23, E,
     "'if' is a reserved word and cannot name an array"},
    {"array_decl_name", obj("array 3; m = 1;"), 1, 23, E,
     "expected a name in the array declaration, found number '3'"},
    {"array_decl_lbracket", obj("array c 3]; m = 1;"), 1, 25, E,
     "expected '[' in the array declaration, found number '3'"},
    {"array_decl_rbracket", obj("array c[3; m = 1;"), 1, 26, E,
     "expected ']' in the array declaration, found ';'"},
    {"array_decl_semicolon", obj("array c[3] m = 1;"), 1, 28, E,
     "expected ';' after the array declaration, found 'm'"},
    {"array_after_statement", obj("v = 1; array c[3]; m = v;"), 1, 24, E,
     "array declarations must come before the first statement"},
    {"else_without_if", obj("else m = 1;"), 1, 17, E, "'else' without a matching 'if'"},
    {"endloop_without_while", obj("endloop; m = 1;"), 1, 17, E,
     "'endloop' without a matching 'while'"},
    {"keyword_assigned", obj("loop = 1; m = 1;"), 1, 17, E,
     "'loop' is a reserved word and cannot be assigned"},
    {"expected_statement", obj("5 = 1; m = 1;"), 1, 17, E,
     "expected a statement, found number '5'"},
    {"elseif", obj("v = 0; if v > 0 then v = 1; elseif v < 0 then v = 2; endif; m = v;"), 1, 45, E,
     "'elseif' is not HyperFun"},
    {"literal_not_number", obj("array c[2]; c = [1, v]; m = 1;"), 1, 37, E,
     "array literal values must be numbers, found 'v'"},
    {"literal_separator", obj("array c[2]; c = [1 2]; m = 1;"), 1, 36, E,
     "expected ',' or ']' in the array literal, found number '2'"},
    {"expected_eq", obj("v 1; m = 1;"), 1, 19, E, "expected '=' after 'v', found number '1'"},
    {"expected_semicolon", obj("v = 1 m = 1;"), 1, 23, E,
     "expected ';' after the statement, found 'm'"},
    {"missing_endif", obj("if 1 then v = 1; m = 1;"), 1, 41, E,
     "missing 'endif' for the 'if' at 1:17, found '}'"},
    {"missing_endloop", obj("while 1 loop v = 1; m = 1;"), 1, 44, E,
     "missing 'endloop' for the 'while' at 1:17, found '}'"},
    {"then_expected", obj("if 1 v = 1; endif; m = 1;"), 1, 22, E,
     "expected 'then' after the condition of 'if', found 'v'"},
    {"loop_expected", obj("while 1 v = 1; endloop; m = 1;"), 1, 25, E,
     "expected 'loop' after the condition of 'while', found 'v'"},
    {"endif_semicolon", obj("if 1 then endif m = 1;"), 1, 33, E,
     "expected ';' after 'endif', found 'm'"},
    {"endloop_semicolon", obj("while 0 loop endloop m = 1;"), 1, 38, E,
     "expected ';' after 'endloop', found 'm'"},
    {"rparen", obj("m = (1 + 2;"), 1, 27, E, "expected ')' to close the '(' at 1:21, found ';'"},
    {"rbracket_index", obj("m = x[1;"), 1, 24, E,
     "expected ']' to close the '[' at 1:22, found ';'"},
    {"rbracket_element", obj("array c[2]; c[1 = 2; m = 1;"), 1, 33, E,
     "expected ']' to close the '[' at 1:30, found '='"},
    {"eq_after_element", obj("array c[2]; c[1] 2; m = 1;"), 1, 34, E,
     "expected '=' after 'c[...]', found number '2'"},
    {"call_arguments", obj("m = max(1 2);"), 1, 27, E,
     "expected ',' or ')' in the arguments of 'max', found number '2'"},
    {"expected_expression", obj("m = ;"), 1, 21, E, "expected an expression, found ';'"},
    {"nesting", obj("m = " + std::string(300, '(') + "1" + std::string(300, ')') + ";"), 1, 277, E,
     "nesting is too deep (more than 256 levels of parentheses, calls, operators or blocks)"},
    {"operator_chain",
     obj("m = 1" +
         [] {
           std::string s;
           for (int i = 0; i < 1100; ++i) s += "+1";
           return s;
         }() +
         ";"),
     1, 2020, E, "expression is too deeply nested (more than 1000 levels of operators)"},
    // semantic checks
    {"duplicate_object", "m(x[3], a[1]) { m = 1; }\nM(x[3], a[1]) { M = 1; }", 2, 1, E,
     "object 'M' is already defined (at 1:1)"},
    {"reserved_object", "sqrt(x[3], a[1]) { sqrt = 1; }", 1, 1, E,
     "'sqrt' is a built-in function and cannot be used as an object name"},
    {"reserved_array", obj("array hfSphere[3]; m = 1;"), 1, 23, E,
     "'hfSphere' is a library function and cannot be used as an array name"},
    {"array_named_like_object", obj("array m[3]; m = 1;"), 1, 23, E,
     "'m' is the name of this object and cannot be used as an array name"},
    {"duplicate_array", obj("array c[3], c[2]; m = 1;"), 1, 29, E,
     "array 'c' is already declared (at 1:23)"},
    {"no_s", obj("m = s[1];"), 1, 21, E, "object 'm' has no 's' array in its header"},
    {"scalar_not_array", obj("v = 1; m = v[1];"), 1, 28, E,
     "'v' is a scalar variable, not an array"},
    {"not_declared_array", obj("m = q[1];"), 1, 21, E, "'q' is not a declared array"},
    {"read_only", obj("x[1] = 1; m = 1;"), 1, 17, E,
     "cannot assign to 'x': x and a are read-only inputs of the object"},
    {"whole_array", obj("array c[2]; c = 1; m = 1;"), 1, 29, E,
     "'c' is an array and cannot be assigned a single value"},
    {"own_value_assigned", obj("m = 1; v = 2; m = v;"), 1, 17, E,
     "'m' is the value of the object and can only be assigned by the last statement"},
    {"reserved_variable", obj("max = 1; m = 1;"), 1, 17, E,
     "'max' is a built-in function and cannot be used as a variable name"},
    {"literal_size", obj("array c[3]; c = [1, 2]; m = 1;"), 1, 29, E,
     "the array literal has 2 values, but 'c' has 3 elements"},
    {"index_out_of_range", obj("m = x[4];"), 1, 23, W,
     "index 4 is out of range for 'x', which has 3 elements"},
    {"array_as_number", obj("m = x;"), 1, 21, E, "'x' is an array and cannot be used as a number"},
    {"maybe_uninitialised", obj("if x[1] > 0 then v = 1; endif; m = v;"), 1, 52, W,
     "'v' may be used before it is assigned"},
    {"own_value_read", obj("m = m + 1;"), 1, 21, E, "object 'm' cannot use its own value"},
    {"object_without_arguments", "o(x[3], a[1]) { o = 1; }\nm(x[3], a[1]) { m = o; }", 2, 21, E,
     "object 'o' must be called with array arguments"},
    {"function_without_arguments", obj("m = sqrt;"), 1, 21, E,
     "function 'sqrt' must be called with arguments"},
    {"undefined", obj("m = foo;"), 1, 21, E, "'foo' is used but never assigned"},
    {"real_argument_is_array", obj("m = sqrt(x);"), 1, 26, E,
     "argument 1 of 'sqrt' must be a number, not the array 'x'"},
    {"array_argument_expected", obj("m = hfSphere(x, 1, 1);"), 1, 33, E,
     "argument 2 of 'hfSphere' must be an array name (x, a, s or a declared array)"},
    {"arity", obj("m = max(1);"), 1, 21, E, "'max' takes 2 arguments, but 1 was given"},
    {"self_call", obj("m = m(x, a);"), 1, 21, E, "object 'm' cannot call itself"},
    {"forward_reference", obj("m = o(x, a);") + "\no(x[3], a[1]) { o = 1; }", 1, 21, E,
     "object 'o' is defined after 'm'; an object can only call objects defined before it"},
    {"object_argument_count", "o(x[3], a[1]) { o = 1; }\nm(x[3], a[1]) { m = o(x); }", 2, 21, E,
     "object 'o' takes 2 array arguments (x, a), but 1 was given"},
    {"object_argument_size", "o(x[2], a[1]) { o = 1; }\nm(x[3], a[1]) { m = o(x, a); }", 2, 23, E,
     "array 'x' has 3 elements, but object 'o' expects x[2]"},
    {"not_a_function", obj("v = 1; m = v(1);"), 1, 28, E, "'v' is not a function"},
    {"unknown_function", obj("m = foo(1);"), 1, 21, E, "unknown function 'foo'"},
    // mesh and patch leaves (issue 10): a string only as their file argument
    {"string_other_call", obj("m = hfSphere(x, \"c\", 1);"), 1, 33, E,
     "strings are not part of HyperFun"},
    {"string_first_arg", obj("m = hfMesh(\"f.off\", x);"), 1, 28, E,
     "strings are not part of HyperFun"},
    {"string_third_arg", obj("m = hfMesh(x, \"f.off\", \"g\");"), 1, 40, E,
     "strings are not part of HyperFun"},
    {"string_in_expression", obj("m = hfMesh(x, \"f.off\") + \"g\";"), 1, 42, E,
     "strings are not part of HyperFun"},
    {"string_in_condition", obj("v = 0; if \"a\" then v = 1; endif; m = v;"), 1, 27, E,
     "strings are not part of HyperFun"},
    {"mesh_file_not_string", obj("m = hfMesh(x, 1);"), 1, 31, E,
     "argument 2 of 'hfMesh' must be a file name in double quotes"},
    {"patch_file_not_string", obj("m = hfBezierSurface(x, a);"), 1, 40, E,
     "argument 2 of 'hfBezierSurface' must be a file name in double quotes"},
    {"mesh_empty_file", obj("m = hfMesh(x, \"\");"), 1, 31, E,
     "the file name of 'hfMesh' is empty"},
    {"mesh_arity", obj("m = hfMesh(x);"), 1, 21, E, "'hfMesh' takes 2 arguments, but 1 was given"},
    {"mesh_point_size", "m(x[2], a[1]) { m = hfMesh(x, \"f.off\"); }", 1, 28, E,
     "'hfMesh' needs a point of 3 coordinates, but 'x' has 2 elements"},
    {"triangles_array_kind", obj("m = hfTriangles(x, 1, a);"), 1, 36, E,
     "argument 2 of 'hfTriangles' must be an array name (x, a, s or a declared array)"},
    {"patches_arity", obj("m = hfBezierPatches(x);"), 1, 21, E,
     "'hfBezierPatches' takes 2 arguments, but 1 was given"},
    // the error limit
    {"too_many_errors", many_errors(), 23, 5, Severity::kNote,
     "too many errors (20); stopping here — fix these first", true},
};

class Message : public ::testing::TestWithParam<MessageCase> {};

TEST_P(Message, TextAndLocation) {
  const MessageCase& mc = GetParam();
  Compiled c = compile(mc.source, "case.hf");
  const auto& all = c.diags->diagnostics();
  ASSERT_FALSE(all.empty()) << "no diagnostic for " << mc.id;
  const Diagnostic& d = mc.last ? all.back() : all.front();
  EXPECT_EQ(d.message, mc.message) << c.rendered();
  EXPECT_EQ(d.severity, mc.severity) << c.rendered();
  EXPECT_EQ(d.range.begin.line, mc.line) << c.rendered();
  EXPECT_EQ(d.range.begin.col, mc.col) << c.rendered();
  // Every error and warning says what to do, and renders with its location.
  if (d.severity != Severity::kNote) {
    EXPECT_FALSE(d.hint.empty() && d.message.find("expected") == std::string::npos) << mc.id;
  }
  std::string loc = "case.hf:" + std::to_string(mc.line) + ":" + std::to_string(mc.col) + ": ";
  EXPECT_NE(c.rendered().find(loc), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(AllMessages, Message, ::testing::ValuesIn(kMessages),
                         [](const ::testing::TestParamInfo<MessageCase>& info) {
                           return std::string(info.param.id);
                         });

}  // namespace
}  // namespace hfrt::lang

namespace hfrt::lang {
namespace {

// The brief form (no source excerpt) used by the REPL, `hfrt ir` and Model::compile for a
// missing object: one located line, then the hint indented.
TEST(RenderBrief, LocationSeverityMessageAndHint) {
  EXPECT_EQ(render_brief("m.hf:3:7", Severity::kWarning, "unused variable 'k'"),
            "m.hf:3:7: warning: unused variable 'k'\n");
  EXPECT_EQ(render_brief("m.hf", Severity::kError, "no object named 'x' in the file",
                         "the objects are: a, b"),
            "m.hf: error: no object named 'x' in the file\n  hint: the objects are: a, b\n");
  EXPECT_EQ(render_brief("<session>:2:1", Severity::kNote, "declared here"),
            "<session>:2:1: note: declared here\n");
}

}  // namespace
}  // namespace hfrt::lang
