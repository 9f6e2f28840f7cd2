#pragma once
// The HyperFun lexer: bytes -> tokens, on demand. The parser pulls one token at a time and
// can rewind to a saved position (the condition backtracking of the parser needs that), so
// the lexer keeps no state besides its position; lexical errors are handed to a callback
// that the parser owns (it buffers them while it parses speculatively).

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "lang/source.h"

namespace hfrt::lang {

#define HFRT_TOKENS(X)        \
  X(kEof, "end of file")      \
  X(kIdent, "a name")         \
  X(kNumber, "a number")      \
  X(kInvalid, "invalid text") \
  X(kString, "a string")      \
  X(kArray, "'array'")        \
  X(kIf, "'if'")              \
  X(kThen, "'then'")          \
  X(kElse, "'else'")          \
  X(kEndif, "'endif'")        \
  X(kWhile, "'while'")        \
  X(kLoop, "'loop'")          \
  X(kEndloop, "'endloop'")    \
  X(kAnd, "'and'")            \
  X(kOr, "'or'")              \
  X(kNot, "'not'")            \
  X(kXor, "'xor'")            \
  X(kPlus, "'+'")             \
  X(kMinus, "'-'")            \
  X(kStar, "'*'")             \
  X(kSlash, "'/'")            \
  X(kCaret, "'^'")            \
  X(kBar, "'|'")              \
  X(kAmp, "'&'")              \
  X(kBackslash, "'\\'")       \
  X(kAt, "'@'")               \
  X(kTilde, "'~'")            \
  X(kEq, "'='")               \
  X(kNe, "'/='")              \
  X(kLt, "'<'")               \
  X(kLe, "'<='")              \
  X(kGt, "'>'")               \
  X(kGe, "'>='")              \
  X(kLParen, "'('")           \
  X(kRParen, "')'")           \
  X(kLBracket, "'['")         \
  X(kRBracket, "']'")         \
  X(kLBrace, "'{'")           \
  X(kRBrace, "'}'")           \
  X(kComma, "','")            \
  X(kSemicolon, "';'")

enum class TokenKind {
#define HFRT_X(e, s) e,
  HFRT_TOKENS(HFRT_X)
#undef HFRT_X
};

/// How a token kind is named in messages ("';'", "'endif'", "name").
std::string_view token_kind_name(TokenKind kind);

/// True for the reserved words (`array if then ... xor`).
bool is_keyword(TokenKind kind);

struct Token {
  TokenKind kind = TokenKind::kEof;
  uint32_t offset = 0;
  uint32_t length = 0;
  double number = 0;  ///< kNumber: the value (also set for a malformed number, to recover)
};

/// Longest identifier accepted (spec: at most 256 characters).
inline constexpr uint32_t kMaxIdentifierLength = 256;

class Lexer {
 public:
  using ErrorFn = std::function<void(SourceRange, std::string message, std::string hint)>;

  Lexer(const SourceFile& file, ErrorFn on_error) : file_(file), on_error_(std::move(on_error)) {}

  /// The next token; kEof (repeatedly) at the end. Reports malformed input through the
  /// callback and still returns a token that lets the parser go on (kInvalid for bytes that
  /// start no token, the nearest valid token for common mistakes such as `!=` or `&&`).
  Token next();

  /// Byte offset of the next token to lex; `rewind` restores a saved one.
  uint32_t position() const { return pos_; }
  void rewind(uint32_t pos) { pos_ = pos; }

  /// While set, a string literal `"..."` (on one line) lexes as one kString token instead of
  /// the error "strings are not part of HyperFun". The parser sets it only to read the file
  /// argument of hfMesh / hfBezierSurface (an hfrt extension, docs/meshes.md).
  void set_allow_strings(bool allow) { allow_strings_ = allow; }

  /// The text of a token.
  std::string_view text(const Token& t) const { return file_.text().substr(t.offset, t.length); }

 private:
  void skip_space_and_comments();
  Token lex_number(uint32_t start);
  Token lex_invalid(uint32_t start);
  Token make(TokenKind kind, uint32_t start) const;
  void error(uint32_t begin, uint32_t length, std::string message, std::string hint = {});

  const SourceFile& file_;
  ErrorFn on_error_;
  uint32_t pos_ = 0;
  bool allow_strings_ = false;
};

}  // namespace hfrt::lang
