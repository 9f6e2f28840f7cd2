// Recursive-descent parser for HyperFun (spec sections 2 and 3).
//
// Error handling: the first syntax error of a statement is reported and the parser enters
// "panic" mode, in which further syntax errors are suppressed until it re-synchronises at a
// statement boundary (`;`, a block keyword or `}`). That way one mistake gives one message
// and every statement of the file is still looked at.
//
// Conditions need one token of backtracking-by-reparse: a `(` right after `if`/`while` (or
// `not`, `and`, `or`, a comparison) is first read as a parenthesised condition, as the
// original does; when that fails, or when an arithmetic operator follows the `)`, the same
// text is read again as an arithmetic expression (the hfrt deviation that accepts
// `if (a+1)*2 > 0 then`). Diagnostics of an attempt are buffered and only the chosen
// attempt's are kept.
#include "lang/parser.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "base/check.h"
#include "lang/frontend.h"
#include "lang/lexer.h"
#include "lang/library_table.h"
#include "lang/names.h"

namespace hfrt::lang {
namespace {

constexpr const char* kStatementHint =
    "statements are assignments 'name = expression;', 'if ... then ... endif;' or "
    "'while ... loop ... endloop;'";

// An expression with the height of its tree (the parser bounds it, see kMaxExprDepth).
struct Node {
  ExprPtr expr;
  int height = 1;
};

// True when argument `index` (0-based) of the library function `name` is a file name
// (kind 'F' in library_table.h: hfMesh, hfBezierSurface).
bool takes_file_argument(std::string_view name, size_t index) {
  std::optional<LibraryFn> f = find_library_fn(name);
  if (!f) return false;
  std::string_view kinds = library_fn_kinds(*f);
  return index < kinds.size() && kinds[index] == 'F';
}

bool is_relop(TokenKind k) {
  return k == TokenKind::kLt || k == TokenKind::kLe || k == TokenKind::kGt || k == TokenKind::kGe ||
         k == TokenKind::kEq || k == TokenKind::kNe;
}

bool is_additive(TokenKind k) {
  return k == TokenKind::kPlus || k == TokenKind::kMinus || k == TokenKind::kBar ||
         k == TokenKind::kAmp || k == TokenKind::kBackslash || k == TokenKind::kAt;
}

bool is_multiplicative(TokenKind k) {
  return k == TokenKind::kStar || k == TokenKind::kSlash;
}

bool is_power(TokenKind k) {
  return k == TokenKind::kCaret;
}

bool is_logical(TokenKind k) {
  return k == TokenKind::kAnd || k == TokenKind::kOr;
}

bool is_arith_binary(TokenKind k) {
  return is_additive(k) || is_multiplicative(k) || is_power(k);
}

BinaryOp binary_op(TokenKind k) {
  switch (k) {
    case TokenKind::kPlus:
      return BinaryOp::kAdd;
    case TokenKind::kMinus:
      return BinaryOp::kSub;
    case TokenKind::kStar:
      return BinaryOp::kMul;
    case TokenKind::kSlash:
      return BinaryOp::kDiv;
    case TokenKind::kCaret:
      return BinaryOp::kPow;
    case TokenKind::kBar:
      return BinaryOp::kUnion;
    case TokenKind::kAmp:
      return BinaryOp::kIntersect;
    case TokenKind::kBackslash:
      return BinaryOp::kSubtract;
    case TokenKind::kAt:
      return BinaryOp::kProduct;
    case TokenKind::kLt:
      return BinaryOp::kLt;
    case TokenKind::kLe:
      return BinaryOp::kLe;
    case TokenKind::kGt:
      return BinaryOp::kGt;
    case TokenKind::kGe:
      return BinaryOp::kGe;
    case TokenKind::kEq:
      return BinaryOp::kEq;
    case TokenKind::kNe:
      return BinaryOp::kNe;
    case TokenKind::kAnd:
      return BinaryOp::kAnd;
    case TokenKind::kOr:
      return BinaryOp::kOr;
    default:
      break;
  }
  HFRT_CHECK_MSG(false, "not a binary operator token");
  return BinaryOp::kAdd;
}

class Parser {
 public:
  Parser(std::shared_ptr<const SourceFile> file, DiagnosticSink& sink, const Limits& limits)
      : file_(std::move(file)),
        sink_(sink),
        // Sizes are ints: a larger limit would not fit (and could never be met anyway).
        max_array_size_(static_cast<int>(std::min<int64_t>(limits.max_array_size, 1 << 30))),
        lexer_(*file_, [this](SourceRange r, std::string m, std::string h) {
          if (!lex_quiet_) report({Severity::kError, r, std::move(m), std::move(h)});
        }) {}

  std::unique_ptr<Program> run();

 private:
  // ---- tokens -------------------------------------------------------------------------
  void advance() {
    prev_ = tok_;
    tok_ = lexer_.next();
  }
  bool at(TokenKind k) const { return tok_.kind == k; }
  bool accept(TokenKind k) {
    if (!at(k)) return false;
    advance();
    return true;
  }
  // The token after the current one, without reporting its lexical errors (they are
  // reported when it is really read).
  Token peek() {
    uint32_t pos = lexer_.position();
    lex_quiet_ = true;
    Token t = lexer_.next();
    lex_quiet_ = false;
    lexer_.rewind(pos);
    return t;
  }
  std::string_view text(const Token& t) const { return lexer_.text(t); }
  SourceRange range_of(const Token& t) const { return {file_->loc_at(t.offset), t.length}; }
  // From `begin` to the end of the last consumed token.
  SourceRange range_from(uint32_t begin) const {
    uint32_t end = std::max(begin, prev_.offset + prev_.length);
    return {file_->loc_at(begin), end - begin};
  }
  std::string describe(const Token& t) const {
    switch (t.kind) {
      case TokenKind::kIdent:
        return "'" + std::string(text(t).substr(0, 40)) + "'";
      case TokenKind::kNumber:
        return "number '" + std::string(text(t).substr(0, 40)) + "'";
      default:
        return std::string(token_kind_name(t.kind));
    }
  }
  std::string where(const Token& t) const {
    SourceLoc l = file_->loc_at(t.offset);
    return std::to_string(l.line) + ":" + std::to_string(l.col);
  }

  // ---- diagnostics --------------------------------------------------------------------
  void report(Diagnostic d) {
    if (!buffers_.empty()) {
      buffers_.back().push_back(std::move(d));
      return;
    }
    if (d.severity == Severity::kError) ++syntax_errors_;
    switch (d.severity) {
      case Severity::kError:
        sink_.error(d.range, std::move(d.message), std::move(d.hint));
        break;
      case Severity::kWarning:
        sink_.warning(d.range, std::move(d.message), std::move(d.hint));
        break;
      case Severity::kNote:
        sink_.note(d.range, std::move(d.message));
        break;
    }
  }
  // A syntax error at the current token; suppressed in panic mode and at kInvalid tokens
  // (the lexer has already reported those).
  void syntax_error(std::string message, std::string hint = {}) {
    syntax_error_at(range_of(tok_), std::move(message), std::move(hint));
  }
  void syntax_error_at(SourceRange range, std::string message, std::string hint = {}) {
    if (panic_) return;
    panic_ = true;
    if (at(TokenKind::kInvalid)) return;
    if (at(TokenKind::kXor)) {
      report({Severity::kError, range_of(tok_), "'xor' is reserved but is not an operator",
              "write (p or q) and not (p and q)"});
      return;
    }
    report({Severity::kError, range, std::move(message), std::move(hint)});
  }
  // Expects `k`; on a mismatch reports "expected WHAT CONTEXT, found X".
  bool expect(TokenKind k, std::string_view context, std::string hint = {}) {
    if (accept(k)) return true;
    std::string msg = "expected " + std::string(token_kind_name(k));
    if (!context.empty()) msg += " " + std::string(context);
    msg += ", found " + describe(tok_);
    if (hint.empty() && is_relop(tok_.kind)) {
      hint = "comparisons are only allowed in the conditions of 'if' and 'while'";
    }
    syntax_error(std::move(msg), std::move(hint));
    return false;
  }
  bool stopped() const { return sink_.truncated() && buffers_.empty(); }

  // ---- speculation ----------------------------------------------------------------------
  struct State {
    uint32_t lex_pos;
    Token tok, prev;
    bool panic;
  };
  State save() const { return {lexer_.position(), tok_, prev_, panic_}; }
  void restore(const State& s) {
    lexer_.rewind(s.lex_pos);
    tok_ = s.tok;
    prev_ = s.prev;
    panic_ = s.panic;
  }
  static bool has_error(const std::vector<Diagnostic>& v) {
    return std::any_of(v.begin(), v.end(),
                       [](const Diagnostic& d) { return d.severity == Severity::kError; });
  }
  void flush(std::vector<Diagnostic>& v) {
    for (Diagnostic& d : v) report(std::move(d));
    v.clear();
  }

  // ---- nesting ------------------------------------------------------------------------
  // RAII depth counter; `ok()` is false (after one error) beyond kMaxNesting.
  class Nest {
   public:
    explicit Nest(Parser& p) : p_(p) {
      if (++p_.depth_ > kMaxNesting) {
        ok_ = false;
        // Once per file: after recovery the rest of a deep construct would hit the limit
        // again at every level.
        if (p_.nesting_reported_) {
          p_.panic_ = true;
        } else {
          p_.nesting_reported_ = true;
          p_.syntax_error("nesting is too deep (more than " + std::to_string(kMaxNesting) +
                              " levels of parentheses, calls, operators or blocks)",
                          "split the expression into several assignments, or nest blocks "
                          "less deeply");
        }
      }
    }
    ~Nest() { --p_.depth_; }
    bool ok() const { return ok_; }

   private:
    Parser& p_;
    bool ok_ = true;
  };

  Node placeholder(uint32_t offset) {
    auto e = std::make_unique<Expr>();
    e->kind = ExprKind::kNumber;
    e->range = {file_->loc_at(offset), 0};
    return {std::move(e), 1};
  }
  Node make_binary(BinaryOp op, Node l, Node r, uint32_t begin) {
    auto e = std::make_unique<Expr>();
    e->kind = ExprKind::kBinary;
    e->binary_op = op;
    e->range = range_from(begin);
    int h = 1 + std::max(l.height, r.height);
    e->args.push_back(std::move(l.expr));
    e->args.push_back(std::move(r.expr));
    return {std::move(e), h};
  }
  // False (after an error) when combining `l` and `r` would exceed kMaxExprDepth.
  bool height_ok(const Node& l, const Node& r, const Token& op) {
    if (1 + std::max(l.height, r.height) <= kMaxExprDepth) return true;
    syntax_error_at(range_of(op),
                    "expression is too deeply nested (more than " + std::to_string(kMaxExprDepth) +
                        " levels of operators)",
                    "split it into several assignments, e.g. t1 = ...; t2 = t1 + ...;");
    return false;
  }

  // ---- grammar ------------------------------------------------------------------------
  void parse_object(Program& prog);
  bool parse_header(Object& obj);
  bool parse_size(int& size, std::string_view context);
  void parse_array_decl(Object& obj);
  std::vector<StmtPtr> parse_statements(std::initializer_list<TokenKind> terminators);
  StmtPtr parse_statement(Object* obj);
  StmtPtr parse_if();
  StmtPtr parse_while();
  void synchronize(uint32_t stmt_begin);
  void skip_block();

  /// One loop for every left-associative binary level: `operand` parses the operands and
  /// `is_op` tells this level's operator tokens (all levels of the spec associate left).
  Node parse_left_assoc(Node (Parser::*operand)(), bool (*is_op)(TokenKind));
  Node parse_condition();
  Node parse_comparison();
  Node parse_condition_primary();
  Node parse_paren_condition();
  Node parse_expr();
  Node parse_term();
  Node parse_power();
  Node parse_unary();
  Node parse_primary();
  Node parse_string();

  std::shared_ptr<const SourceFile> file_;
  DiagnosticSink& sink_;
  int max_array_size_;  ///< Limits::max_array_size
  Lexer lexer_;
  Token tok_, prev_;
  bool panic_ = false;
  bool lex_quiet_ = false;
  int depth_ = 0;
  bool nesting_reported_ = false;
  int syntax_errors_ = 0;
  std::vector<std::vector<Diagnostic>> buffers_;
  Object* object_ = nullptr;  // the object being parsed (for array declarations)
};

std::unique_ptr<Program> Parser::run() {
  auto prog = std::make_unique<Program>();
  prog->source = file_;
  advance();
  while (!at(TokenKind::kEof) && !stopped()) {
    if (at(TokenKind::kIdent)) {
      parse_object(*prog);
      continue;
    }
    panic_ = false;
    syntax_error("expected an object definition, found " + describe(tok_),
                 "an object looks like: my_model(x[3], a[1]) { my_model = ...; }");
    // Skip to the end of whatever this is: past the next '}', or to the next name that
    // could start an object.
    advance();
    while (!at(TokenKind::kEof) && !at(TokenKind::kIdent)) {
      if (accept(TokenKind::kRBrace)) break;
      advance();
    }
    panic_ = false;
  }
  if (prog->objects.empty() && syntax_errors_ == 0 && !sink_.has_errors()) {
    bool blank = file_->text().find_first_not_of(" \t\r\n") == std::string_view::npos;
    report({Severity::kError,
            {file_->loc_at(0), 0},
            blank ? "the file is empty" : "the file contains no object definition",
            "a HyperFun file holds at least one object: my_model(x[3], a[1]) { my_model = ...; }"});
  }
  return prog;
}

void Parser::parse_object(Program& prog) {
  const int errors_before = syntax_errors_;
  Object obj;
  object_ = &obj;
  const uint32_t begin = tok_.offset;
  obj.name = std::string(text(tok_));
  obj.name_range = range_of(tok_);
  advance();
  panic_ = false;
  if (!parse_header(obj)) {
    // Skip the rest of a broken header up to the body.
    while (!at(TokenKind::kEof) && !at(TokenKind::kLBrace)) advance();
    panic_ = false;
  }
  const Token open = tok_;
  if (!expect(TokenKind::kLBrace, "to start the body of object '" + obj.name + "'",
              "an object looks like: " + obj.name + "(x[3], a[1]) { " + obj.name + " = ...; }")) {
    obj.had_syntax_errors = true;
    obj.range = range_from(begin);
    prog.objects.push_back(std::move(obj));
    object_ = nullptr;
    return;
  }
  while (at(TokenKind::kArray) && !stopped()) parse_array_decl(obj);
  obj.body = parse_statements({TokenKind::kRBrace});
  bool closed = true;
  if (!accept(TokenKind::kRBrace)) {
    closed = false;
    panic_ = false;
    syntax_error(
        "missing '}' at the end of object '" + obj.name + "' (its '{' is at " + where(open) + ")",
        "close the object body with '}'");
  }
  const bool clean = syntax_errors_ == errors_before;
  // The model assignment is the last statement; it moves from the body to `result`.
  if (!obj.body.empty() && obj.body.back()->kind == StmtKind::kAssign &&
      same_name(obj.body.back()->name, obj.name)) {
    StmtPtr last = std::move(obj.body.back());
    obj.body.pop_back();
    obj.result = std::move(last->value);
    obj.result_range = last->range;
  } else if (clean && closed) {
    panic_ = false;
    syntax_error_at(range_of(prev_), "object '" + obj.name + "' must end by assigning its value",
                    "make the last statement '" + obj.name + " = <expression>;'");
  }
  panic_ = false;
  obj.range = range_from(begin);
  obj.had_syntax_errors = syntax_errors_ != errors_before;
  prog.objects.push_back(std::move(obj));
  object_ = nullptr;
}

bool Parser::parse_size(int& size, std::string_view context) {
  if (!at(TokenKind::kNumber)) {
    syntax_error("expected an array size " + std::string(context) + ", found " + describe(tok_),
                 "sizes are whole numbers, like x[3]");
    return false;
  }
  double v = tok_.number;
  if (!(v >= 1 && v == std::floor(v))) {
    syntax_error("array size must be a whole number from 1 to " + std::to_string(max_array_size_) +
                     ", found " + describe(tok_),
                 "sizes are whole numbers, like x[3]");
    advance();
    return false;
  }
  if (v > max_array_size_) {
    syntax_error("array size " + std::string(text(tok_)) + " is more than the limit of " +
                     std::to_string(max_array_size_) + " elements",
                 limit_hint("max_array_size"));
    advance();
    return false;
  }
  size = static_cast<int>(v);
  advance();
  return true;
}

bool Parser::parse_header(Object& obj) {
  const std::string ctx = "in the header of object '" + obj.name + "'";
  const std::string hint = "an object header looks like " + obj.name + "(x[3], a[1]) or " +
                           obj.name + "(x[3], a[1], s[3])";
  auto param = [&](std::string_view want, int& size) {
    if (!at(TokenKind::kIdent) || !same_name(text(tok_), want)) {
      syntax_error("expected '" + std::string(want) + "[...]' " + ctx + ", found " + describe(tok_),
                   hint);
      return false;
    }
    advance();
    if (!expect(TokenKind::kLBracket, ctx, hint)) return false;
    if (!parse_size(size, ctx)) return false;
    return expect(TokenKind::kRBracket, ctx, hint);
  };
  if (!expect(TokenKind::kLParen, "after the object name '" + obj.name + "'", hint)) return false;
  if (!param("x", obj.x_size)) return false;
  if (!expect(TokenKind::kComma, ctx, hint)) return false;
  if (!param("a", obj.a_size)) return false;
  if (accept(TokenKind::kComma)) {
    if (!param("s", obj.s_size)) return false;
    obj.has_s = true;
  }
  return expect(TokenKind::kRParen, ctx, hint);
}

void Parser::parse_array_decl(Object& obj) {
  const uint32_t stmt_begin = tok_.offset;
  advance();  // 'array'
  const std::string ctx = "in the array declaration";
  do {
    if (!at(TokenKind::kIdent)) {
      if (is_keyword(tok_.kind)) {
        syntax_error(describe(tok_) + " is a reserved word and cannot name an array",
                     "choose another name for the array");
      } else {
        expect(TokenKind::kIdent, ctx, "declare arrays like: array c[3], w[10];");
      }
      break;
    }
    ArrayDecl d;
    d.name = std::string(text(tok_));
    const uint32_t begin = tok_.offset;
    advance();
    if (!expect(TokenKind::kLBracket, ctx, "declare arrays like: array c[3], w[10];")) break;
    if (!parse_size(d.size, ctx)) break;
    if (!expect(TokenKind::kRBracket, ctx)) break;
    d.range = range_from(begin);
    obj.arrays.push_back(std::move(d));
  } while (accept(TokenKind::kComma));
  if (!panic_) expect(TokenKind::kSemicolon, "after the array declaration");
  if (panic_) synchronize(stmt_begin);
}

// Skips a whole if/while construct (for one nested too deeply), balancing the block
// keywords, so that its inner 'endif's and 'endloop's are not reported one by one.
void Parser::skip_block() {
  long open = 0;
  while (!at(TokenKind::kEof) && !at(TokenKind::kRBrace)) {
    TokenKind k = tok_.kind;
    advance();
    if (k == TokenKind::kIf || k == TokenKind::kWhile) ++open;
    if ((k == TokenKind::kEndif || k == TokenKind::kEndloop) && --open <= 0) break;
  }
  accept(TokenKind::kSemicolon);
  panic_ = false;
}

// Skips to the next statement boundary after an error and leaves panic mode. Always
// makes progress when the statement consumed nothing.
void Parser::synchronize(uint32_t stmt_begin) {
  if (prev_.kind == TokenKind::kSemicolon && prev_.offset >= stmt_begin) {
    panic_ = false;
    return;
  }
  bool moved = tok_.offset > stmt_begin;
  for (;;) {
    switch (tok_.kind) {
      case TokenKind::kEof:
        panic_ = false;
        return;
      case TokenKind::kSemicolon:
        advance();
        panic_ = false;
        return;
      case TokenKind::kRBrace:
      case TokenKind::kIf:
      case TokenKind::kWhile:
      case TokenKind::kElse:
      case TokenKind::kEndif:
      case TokenKind::kEndloop:
      case TokenKind::kArray:
        if (moved) {
          panic_ = false;
          return;
        }
        break;
      default:
        break;
    }
    advance();
    moved = true;
  }
}

std::vector<StmtPtr> Parser::parse_statements(std::initializer_list<TokenKind> terminators) {
  std::vector<StmtPtr> out;
  auto is_terminator = [&] {
    if (at(TokenKind::kEof)) return true;
    return std::find(terminators.begin(), terminators.end(), tok_.kind) != terminators.end();
  };
  while (!is_terminator() && !stopped()) {
    const uint32_t begin = tok_.offset;
    StmtPtr s = parse_statement(object_);
    if (s) out.push_back(std::move(s));
    if (panic_) synchronize(begin);
  }
  return out;
}

StmtPtr Parser::parse_statement(Object* obj) {
  const uint32_t begin = tok_.offset;
  if (is_keyword(tok_.kind) && peek().kind == TokenKind::kEq) {
    syntax_error(describe(tok_) + " is a reserved word and cannot be assigned",
                 "choose another variable name");
    return nullptr;
  }
  switch (tok_.kind) {
    case TokenKind::kIf:
      return parse_if();
    case TokenKind::kWhile:
      return parse_while();
    case TokenKind::kArray: {
      syntax_error("array declarations must come before the first statement",
                   "move 'array ...;' to the top of the object body");
      // Keep the declaration so that later uses of the array are not reported again.
      panic_ = false;
      if (obj) {
        parse_array_decl(*obj);
      } else {
        advance();
      }
      return nullptr;
    }
    case TokenKind::kIdent:
      break;
    case TokenKind::kElse:
    case TokenKind::kEndif:
    case TokenKind::kThen:
      syntax_error(describe(tok_) + " without a matching 'if'", kStatementHint);
      return nullptr;
    case TokenKind::kLoop:
    case TokenKind::kEndloop:
      syntax_error(describe(tok_) + " without a matching 'while'", kStatementHint);
      return nullptr;
    default:
      syntax_error("expected a statement, found " + describe(tok_), kStatementHint);
      return nullptr;
  }

  if (same_name(text(tok_), "elseif")) {
    syntax_error("'elseif' is not HyperFun",
                 "write 'else if ... then ... endif;' and close both: 'endif; endif;'");
    return nullptr;
  }
  auto stmt = std::make_unique<Stmt>();
  stmt->name = std::string(text(tok_));
  stmt->name_range = range_of(tok_);
  advance();
  if (at(TokenKind::kLBracket)) {
    const Token open = tok_;
    advance();
    stmt->kind = StmtKind::kAssignIndex;
    stmt->index = parse_expr().expr;
    if (!panic_) expect(TokenKind::kRBracket, "to close the '[' at " + where(open));
    if (!panic_) expect(TokenKind::kEq, "after '" + stmt->name + "[...]'", kStatementHint);
    if (!panic_) stmt->value = parse_expr().expr;
  } else if (accept(TokenKind::kEq)) {
    if (at(TokenKind::kLBracket)) {
      stmt->kind = StmtKind::kAssignArray;
      advance();
      for (;;) {
        const uint32_t vbegin = tok_.offset;
        double sign = 1;
        if (at(TokenKind::kMinus) || at(TokenKind::kPlus)) {
          if (at(TokenKind::kMinus)) sign = -1;
          advance();
        }
        if (!at(TokenKind::kNumber)) {
          // Step over a whole expression so the message can underline it.
          if (!at(TokenKind::kComma) && !at(TokenKind::kRBracket) && !at(TokenKind::kSemicolon) &&
              !at(TokenKind::kEof)) {
            const Token bad = tok_;
            State s = save();
            buffers_.emplace_back();
            parse_expr();
            buffers_.pop_back();
            SourceRange r = range_from(bad.offset);
            restore(s);
            syntax_error_at(
                r, "array literal values must be numbers, found " + describe(bad),
                "set computed values element by element, e.g. " + stmt->name + "[1] = x[1];");
          } else {
            syntax_error("array literal values must be numbers, found " + describe(tok_),
                         "write the values like " + stmt->name + " = [1, -2.5, 3];");
          }
          (void)vbegin;
          break;
        }
        stmt->literal.push_back(sign * tok_.number);
        advance();
        if (accept(TokenKind::kComma)) continue;
        if (!at(TokenKind::kRBracket)) {
          syntax_error("expected ',' or ']' in the array literal, found " + describe(tok_),
                       "write the values like " + stmt->name + " = [1, -2.5, 3];");
          break;
        }
        advance();
        break;
      }
    } else {
      stmt->kind = StmtKind::kAssign;
      stmt->value = parse_expr().expr;
    }
  } else {
    syntax_error("expected '=' after '" + stmt->name + "', found " + describe(tok_),
                 kStatementHint);
    return nullptr;
  }
  if (!panic_) {
    expect(TokenKind::kSemicolon, "after the statement",
           at(TokenKind::kIdent) || at(TokenKind::kRBrace) ? "every statement ends with ';'" : "");
  }
  stmt->range = range_from(begin);
  return stmt;
}

StmtPtr Parser::parse_if() {
  const Token kw = tok_;
  Nest nest(*this);
  if (!nest.ok()) {
    skip_block();
    return nullptr;
  }
  advance();
  auto stmt = std::make_unique<Stmt>();
  stmt->kind = StmtKind::kIf;
  stmt->cond = parse_condition().expr;
  if (expect(TokenKind::kThen, "after the condition of 'if'")) panic_ = false;
  stmt->then_body = parse_statements(
      {TokenKind::kElse, TokenKind::kEndif, TokenKind::kRBrace, TokenKind::kEndloop});
  if (accept(TokenKind::kElse)) {
    panic_ = false;
    stmt->has_else = true;
    stmt->else_body =
        parse_statements({TokenKind::kEndif, TokenKind::kRBrace, TokenKind::kEndloop});
  }
  if (!accept(TokenKind::kEndif)) {
    syntax_error("missing 'endif' for the 'if' at " + where(kw) + ", found " + describe(tok_),
                 "close every 'if' with 'endif;'");
    stmt->range = range_from(kw.offset);
    return stmt;
  }
  panic_ = false;
  expect(TokenKind::kSemicolon, "after 'endif'");
  stmt->range = range_from(kw.offset);
  return stmt;
}

StmtPtr Parser::parse_while() {
  const Token kw = tok_;
  Nest nest(*this);
  if (!nest.ok()) {
    skip_block();
    return nullptr;
  }
  advance();
  auto stmt = std::make_unique<Stmt>();
  stmt->kind = StmtKind::kWhile;
  stmt->cond = parse_condition().expr;
  if (expect(TokenKind::kLoop, "after the condition of 'while'")) panic_ = false;
  stmt->then_body = parse_statements(
      {TokenKind::kEndloop, TokenKind::kRBrace, TokenKind::kElse, TokenKind::kEndif});
  if (!accept(TokenKind::kEndloop)) {
    syntax_error("missing 'endloop' for the 'while' at " + where(kw) + ", found " + describe(tok_),
                 "close every 'while' with 'endloop;'");
    stmt->range = range_from(kw.offset);
    return stmt;
  }
  panic_ = false;
  expect(TokenKind::kSemicolon, "after 'endloop'");
  stmt->range = range_from(kw.offset);
  return stmt;
}

Node Parser::parse_left_assoc(Node (Parser::*operand)(), bool (*is_op)(TokenKind)) {
  const uint32_t begin = tok_.offset;
  Node left = (this->*operand)();
  while (is_op(tok_.kind) && !panic_) {
    const Token op = tok_;
    advance();
    Node right = (this->*operand)();
    if (!height_ok(left, right, op)) break;
    left = make_binary(binary_op(op.kind), std::move(left), std::move(right), begin);
  }
  return left;
}

// cond = cmp { ('and' | 'or') cmp }   (one level, left to right)
Node Parser::parse_condition() {
  return parse_left_assoc(&Parser::parse_comparison, is_logical);
}

// cmp = prim { relop prim }   (chained numerically)
Node Parser::parse_comparison() {
  return parse_left_assoc(&Parser::parse_condition_primary, is_relop);
}

// prim = 'not' prim | '(' cond ')' | expr
Node Parser::parse_condition_primary() {
  const uint32_t begin = tok_.offset;
  if (at(TokenKind::kNot)) {
    Nest nest(*this);
    if (!nest.ok()) return placeholder(begin);
    advance();
    Node operand = parse_condition_primary();
    auto e = std::make_unique<Expr>();
    e->kind = ExprKind::kUnary;
    e->unary_op = UnaryOp::kNot;
    e->range = range_from(begin);
    int h = operand.height + 1;
    e->args.push_back(std::move(operand.expr));
    return {std::move(e), h};
  }
  if (at(TokenKind::kLParen)) return parse_paren_condition();
  return parse_expr();
}

Node Parser::parse_paren_condition() {
  const State start = save();
  const Token open = tok_;
  // Attempt 1, the original grammar: '(' cond ')'.
  buffers_.emplace_back();
  Node cond;
  {
    Nest nest(*this);
    if (!nest.ok()) {
      std::vector<Diagnostic> diags = std::move(buffers_.back());
      buffers_.pop_back();
      flush(diags);
      return placeholder(open.offset);
    }
    advance();
    cond = parse_condition();
    if (!panic_) expect(TokenKind::kRParen, "to close the '(' at " + where(open));
  }
  if (cond.expr) cond.expr->range = range_from(open.offset);
  cond.height += 0;
  std::vector<Diagnostic> cond_diags = std::move(buffers_.back());
  buffers_.pop_back();
  const bool cond_ok = !has_error(cond_diags) && !panic_ && !is_arith_binary(tok_.kind);
  if (cond_ok) {
    flush(cond_diags);
    return cond;
  }
  // Attempt 2 (hfrt deviation): the same text as an arithmetic expression.
  const State after_cond = save();
  restore(start);
  buffers_.emplace_back();
  Node expr = parse_expr();
  std::vector<Diagnostic> expr_diags = std::move(buffers_.back());
  buffers_.pop_back();
  if (!has_error(expr_diags) && !panic_) {
    flush(expr_diags);
    return expr;
  }
  // Neither reading works: report what the original grammar expected.
  restore(after_cond);
  flush(cond_diags);
  return cond;
}

// expr = term { ('+' | '-' | '|' | '&' | '\' | '@') term }
Node Parser::parse_expr() {
  return parse_left_assoc(&Parser::parse_term, is_additive);
}

// term = power { ('*' | '/') power }
Node Parser::parse_term() {
  return parse_left_assoc(&Parser::parse_power, is_multiplicative);
}

// power = unary { '^' unary }   (left-associative, as the original)
Node Parser::parse_power() {
  return parse_left_assoc(&Parser::parse_unary, is_power);
}

// unary = ('+' | '-' | '~') unary | primary   (binds tighter than '^')
Node Parser::parse_unary() {
  const uint32_t begin = tok_.offset;
  if (!at(TokenKind::kMinus) && !at(TokenKind::kPlus) && !at(TokenKind::kTilde)) {
    return parse_primary();
  }
  Nest nest(*this);
  if (!nest.ok()) return placeholder(begin);
  const TokenKind k = tok_.kind;
  advance();
  Node operand = parse_unary();
  auto e = std::make_unique<Expr>();
  e->kind = ExprKind::kUnary;
  e->unary_op = k == TokenKind::kMinus  ? UnaryOp::kNeg
                : k == TokenKind::kPlus ? UnaryOp::kPlus
                                        : UnaryOp::kComplement;
  e->range = range_from(begin);
  int h = operand.height + 1;
  e->args.push_back(std::move(operand.expr));
  return {std::move(e), h};
}

// A string literal (only ever lexed as the file argument of hfMesh / hfBezierSurface).
Node Parser::parse_string() {
  auto e = std::make_unique<Expr>();
  e->kind = ExprKind::kString;
  e->range = range_of(tok_);
  std::string_view t = text(tok_);
  e->name = std::string(t.substr(1, t.size() >= 2 ? t.size() - 2 : 0));
  advance();
  return {std::move(e), 1};
}

Node Parser::parse_primary() {
  const uint32_t begin = tok_.offset;
  switch (tok_.kind) {
    case TokenKind::kNumber: {
      auto e = std::make_unique<Expr>();
      e->kind = ExprKind::kNumber;
      e->number = tok_.number;
      e->range = range_of(tok_);
      advance();
      return {std::move(e), 1};
    }
    case TokenKind::kLParen: {
      Nest nest(*this);
      if (!nest.ok()) return placeholder(begin);
      const Token open = tok_;
      advance();
      Node inner = parse_expr();
      if (!panic_) expect(TokenKind::kRParen, "to close the '(' at " + where(open));
      if (inner.expr) inner.expr->range = range_from(begin);
      return inner;
    }
    case TokenKind::kIdent: {
      auto e = std::make_unique<Expr>();
      e->name = std::string(text(tok_));
      e->name_range = range_of(tok_);
      advance();
      int h = 1;
      if (at(TokenKind::kLBracket)) {
        Nest nest(*this);
        if (!nest.ok()) return placeholder(begin);
        const Token open = tok_;
        advance();
        e->kind = ExprKind::kIndex;
        Node index = parse_expr();
        h = index.height + 1;
        e->args.push_back(std::move(index.expr));
        if (!panic_) expect(TokenKind::kRBracket, "to close the '[' at " + where(open));
      } else if (at(TokenKind::kLParen)) {
        Nest nest(*this);
        if (!nest.ok()) return placeholder(begin);
        advance();
        e->kind = ExprKind::kCall;
        if (!at(TokenKind::kRParen)) {
          for (;;) {
            Node arg = at(TokenKind::kString) ? parse_string() : parse_expr();
            h = std::max(h, arg.height + 1);
            e->args.push_back(std::move(arg.expr));
            if (panic_) break;
            // The token after this comma may be a file name: the lexer reads a string
            // literal there only (anywhere else it stays the original's error).
            lexer_.set_allow_strings(takes_file_argument(e->name, e->args.size()));
            const bool comma = accept(TokenKind::kComma);
            lexer_.set_allow_strings(false);
            if (comma) continue;
            if (!at(TokenKind::kRParen)) {
              syntax_error("expected ',' or ')' in the arguments of '" + e->name + "', found " +
                           describe(tok_));
            }
            break;
          }
        }
        if (!panic_) advance();  // ')'
      } else {
        e->kind = ExprKind::kName;
      }
      e->range = range_from(begin);
      return {std::move(e), h};
    }
    case TokenKind::kInvalid:
      // Already reported by the lexer; read over it as if it were a value.
      advance();
      return placeholder(begin);
    default:
      syntax_error("expected an expression, found " + describe(tok_),
                   at(TokenKind::kAnd) || at(TokenKind::kOr) || at(TokenKind::kNot)
                       ? "'and', 'or' and 'not' are only allowed in conditions of 'if' and "
                         "'while'"
                       : "");
      return placeholder(begin);
  }
}

}  // namespace

std::unique_ptr<Program> parse_program(std::shared_ptr<const SourceFile> file,
                                       DiagnosticSink& diags, const Limits& limits) {
  HFRT_CHECK(file != nullptr);
  Parser parser(std::move(file), diags, limits);
  return parser.run();
}

std::unique_ptr<Program> compile_source(std::shared_ptr<const SourceFile> file,
                                        DiagnosticSink& diags, const Limits& limits) {
  std::unique_ptr<Program> prog = parse_program(std::move(file), diags, limits);
  bool ok = check_program(*prog, diags);
  if (!ok || diags.has_errors()) return nullptr;
  return prog;
}

}  // namespace hfrt::lang
