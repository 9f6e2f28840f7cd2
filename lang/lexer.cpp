// The HyperFun lexer (spec section 1).
#include "lang/lexer.h"

#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>

#include "lang/names.h"

namespace hfrt::lang {
namespace {

constexpr std::array kTokenNames = {
#define HFRT_X(e, s) std::string_view(s),
    HFRT_TOKENS(HFRT_X)
#undef HFRT_X
};

struct Keyword {
  std::string_view spelling;
  TokenKind kind;
};

constexpr Keyword kKeywords[] = {
    {"array", TokenKind::kArray}, {"if", TokenKind::kIf},           {"then", TokenKind::kThen},
    {"else", TokenKind::kElse},   {"endif", TokenKind::kEndif},     {"while", TokenKind::kWhile},
    {"loop", TokenKind::kLoop},   {"endloop", TokenKind::kEndloop}, {"and", TokenKind::kAnd},
    {"or", TokenKind::kOr},       {"not", TokenKind::kNot},         {"xor", TokenKind::kXor},
};

bool is_letter(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
}
bool is_digit(char c) {
  return c >= '0' && c <= '9';
}
bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r';
}

// Characters that can begin a token (or whitespace/comment): everything else is invalid.
bool starts_token(char c) {
  if (is_letter(c) || is_digit(c) || is_space(c)) return true;
  switch (c) {
    case '+':
    case '-':
    case '*':
    case '/':
    case '^':
    case '|':
    case '&':
    case '\\':
    case '@':
    case '~':
    case '=':
    case '<':
    case '>':
    case '(':
    case ')':
    case '[':
    case ']':
    case '{':
    case '}':
    case ',':
    case ';':
    case '.':
    case '"':
    case '!':
      return true;
    default:
      return false;
  }
}

// A byte as it can be shown inside quotes in a message.
std::string show_byte(char c) {
  auto u = static_cast<unsigned char>(c);
  if (u >= 0x20 && u < 0x7F) return std::string(1, c);
  char buf[8];
  std::snprintf(buf, sizeof buf, "\\x%02X", u);
  return buf;
}

}  // namespace

std::string_view token_kind_name(TokenKind kind) {
  return kTokenNames[static_cast<size_t>(kind)];
}

bool is_keyword(TokenKind kind) {
  return kind >= TokenKind::kArray && kind <= TokenKind::kXor;
}

void Lexer::error(uint32_t begin, uint32_t length, std::string message, std::string hint) {
  SourceRange range{file_.loc_at(begin), length};
  on_error_(range, std::move(message), std::move(hint));
}

Token Lexer::make(TokenKind kind, uint32_t start) const {
  return Token{kind, start, pos_ - start, 0};
}

void Lexer::skip_space_and_comments() {
  std::string_view s = file_.text();
  const auto n = static_cast<uint32_t>(s.size());
  while (pos_ < n) {
    char c = s[pos_];
    if (is_space(c)) {
      ++pos_;
    } else if (c == '-' && pos_ + 1 < n && s[pos_ + 1] == '-') {
      while (pos_ < n && s[pos_] != '\n') ++pos_;
    } else if (c == '/' && pos_ + 1 < n && s[pos_ + 1] == '/') {
      error(pos_, 2, "'//' does not start a comment in HyperFun",
            "comments start with '--' and run to the end of the line");
      while (pos_ < n && s[pos_] != '\n') ++pos_;
    } else if (c == '/' && pos_ + 1 < n && s[pos_ + 1] == '*') {
      error(pos_, 2, "'/* ... */' comments are not HyperFun",
            "comments start with '--' and run to the end of the line");
      size_t end = s.find("*/", pos_ + 2);
      pos_ = end == std::string_view::npos ? n : static_cast<uint32_t>(end + 2);
    } else {
      break;
    }
  }
}

Token Lexer::next() {
  skip_space_and_comments();
  std::string_view s = file_.text();
  const auto n = static_cast<uint32_t>(s.size());
  const uint32_t start = pos_;
  if (pos_ >= n) return Token{TokenKind::kEof, n, 0, 0};
  char c = s[pos_];
  auto peek = [&](uint32_t k) { return pos_ + k < n ? s[pos_ + k] : '\0'; };

  if (is_letter(c)) {
    while (pos_ < n && (is_letter(s[pos_]) || is_digit(s[pos_]) || s[pos_] == '_')) ++pos_;
    Token t = make(TokenKind::kIdent, start);
    if (t.length > kMaxIdentifierLength) {
      error(start, t.length,
            "name is " + std::to_string(t.length) + " characters long; at most " +
                std::to_string(kMaxIdentifierLength) + " are allowed",
            "use a shorter name");
    } else if (t.length <= 7) {
      std::string folded = fold_case(text(t));
      for (const Keyword& k : kKeywords) {
        if (folded == k.spelling) t.kind = k.kind;
      }
    }
    return t;
  }
  if (is_digit(c) || (c == '.' && is_digit(peek(1)))) return lex_number(start);

  auto one = [&](TokenKind k) {
    ++pos_;
    return make(k, start);
  };
  auto two = [&](TokenKind k) {
    pos_ += 2;
    return make(k, start);
  };
  switch (c) {
    case '+':
      return one(TokenKind::kPlus);
    case '-':
      return one(TokenKind::kMinus);
    case '*':
      return one(TokenKind::kStar);
    case '/':
      return peek(1) == '=' ? two(TokenKind::kNe) : one(TokenKind::kSlash);
    case '^':
      return one(TokenKind::kCaret);
    case '\\':
      return one(TokenKind::kBackslash);
    case '@':
      return one(TokenKind::kAt);
    case '~':
      return one(TokenKind::kTilde);
    case '(':
      return one(TokenKind::kLParen);
    case ')':
      return one(TokenKind::kRParen);
    case '[':
      return one(TokenKind::kLBracket);
    case ']':
      return one(TokenKind::kRBracket);
    case '{':
      return one(TokenKind::kLBrace);
    case '}':
      return one(TokenKind::kRBrace);
    case ',':
      return one(TokenKind::kComma);
    case ';':
      return one(TokenKind::kSemicolon);
    case '<':
      return peek(1) == '=' ? two(TokenKind::kLe) : one(TokenKind::kLt);
    case '>':
      return peek(1) == '=' ? two(TokenKind::kGe) : one(TokenKind::kGt);
    // Operators from C-like languages: report them, then go on with the HyperFun
    // spelling so that the rest of the statement is still checked.
    case '=':
      if (peek(1) == '=') {
        error(start, 2, "'==' is not a HyperFun operator", "write '=' to compare for equality");
        return two(TokenKind::kEq);
      }
      return one(TokenKind::kEq);
    case '!':
      if (peek(1) == '=') {
        error(start, 2, "'!=' is not a HyperFun operator", "write '/=' for 'not equal'");
        return two(TokenKind::kNe);
      }
      error(start, 1, "'!' is not a HyperFun operator", "write 'not' to negate a condition");
      return one(TokenKind::kNot);
    case '&':
      if (peek(1) == '&') {
        error(start, 2, "'&&' is not a HyperFun operator",
              "write 'and' in conditions; a single '&' is the set intersection");
        return two(TokenKind::kAnd);
      }
      return one(TokenKind::kAmp);
    case '|':
      if (peek(1) == '|') {
        error(start, 2, "'||' is not a HyperFun operator",
              "write 'or' in conditions; a single '|' is the set union");
        return two(TokenKind::kOr);
      }
      return one(TokenKind::kBar);
    case '"': {
      // Skip the whole string literal (to the closing quote on this line) as one token.
      ++pos_;
      while (pos_ < n && s[pos_] != '"' && s[pos_] != '\n') ++pos_;
      if (pos_ < n && s[pos_] == '"') {
        ++pos_;
        if (allow_strings_) return make(TokenKind::kString, start);
      }
      error(start, pos_ - start, "strings are not part of HyperFun",
            "arguments are numbers, expressions or array names");
      return make(TokenKind::kInvalid, start);
    }
    case '.':
      error(start, 1, "'.' must be followed by digits here", "write a number like .5 or 0.5");
      return one(TokenKind::kInvalid);
    default:
      return lex_invalid(start);
  }
}

Token Lexer::lex_invalid(uint32_t start) {
  std::string_view s = file_.text();
  const auto n = static_cast<uint32_t>(s.size());
  bool has_nul = false;
  while (pos_ < n && !starts_token(s[pos_])) {
    has_nul |= s[pos_] == '\0';
    ++pos_;
  }
  Token t = make(TokenKind::kInvalid, start);
  if (has_nul) {
    error(start, t.length, "NUL byte in the source text",
          "HyperFun files are plain text; is this a binary file?");
  } else {
    std::string shown;
    for (uint32_t i = start; i < pos_ && i < start + 12; ++i) shown += show_byte(s[i]);
    if (t.length > 12) shown += "...";
    error(start, t.length,
          std::string(t.length == 1 ? "unexpected character '" : "unexpected characters '") +
              shown + "'",
          "HyperFun uses letters, digits, '_' in names, and + - * / ^ | & \\ @ ~ = < > ( ) "
          "[ ] { } , ;");
  }
  return t;
}

Token Lexer::lex_number(uint32_t start) {
  std::string_view s = file_.text();
  const auto n = static_cast<uint32_t>(s.size());
  auto at = [&](uint32_t i) { return i < n ? s[i] : '\0'; };
  uint32_t int_begin = pos_;
  while (is_digit(at(pos_))) ++pos_;
  uint32_t int_len = pos_ - int_begin;
  if (at(pos_) == '.') {
    ++pos_;
    while (is_digit(at(pos_))) ++pos_;
  }
  uint32_t exp_begin = 0, exp_len = 0;
  bool exp_missing = false;
  if (at(pos_) == 'e' || at(pos_) == 'E') {
    uint32_t k = pos_ + 1;
    if (at(k) == '+' || at(k) == '-') ++k;
    if (is_digit(at(k))) {
      exp_begin = k;
      while (is_digit(at(k))) ++k;
      exp_len = k - exp_begin;
      pos_ = k;
    } else if (k != pos_ + 1) {
      // "1e+" with no digits: take it as part of the (bad) number.
      exp_missing = true;
      pos_ = k;
    }
  }
  Token t = make(TokenKind::kNumber, start);
  std::string_view txt = text(t);
  if (int_len > 1 && s[int_begin] == '0') {
    error(start, t.length, "number '" + std::string(txt) + "' starts with 0",
          "HyperFun does not allow leading zeros: write 1, not 01 (0.5 is fine)");
  } else if (exp_len > 1 && s[exp_begin] == '0') {
    error(start, t.length, "exponent of '" + std::string(txt) + "' starts with 0",
          "HyperFun does not allow leading zeros in exponents; write 1e5, not 1e05");
  } else if (exp_missing) {
    error(start, t.length, "number '" + std::string(txt) + "' has no exponent digits",
          "write the exponent like 1e+5 or 2.5E-3");
  }
  // The value, also for a malformed number (so that the parser can go on).
  std::string clean(txt);
  if (exp_missing) clean = clean.substr(0, clean.find_first_of("eE"));
  double v = 0;
  auto [ptr, ec] = std::from_chars(clean.data(), clean.data() + clean.size(), v);
  if (ec == std::errc::result_out_of_range) {
    // from_chars leaves v unchanged on overflow and underflow; tell them apart by size.
    bool tiny =
        clean.find_first_of("eE") != std::string::npos && clean.find("e-") != std::string::npos;
    tiny = tiny || clean.find("E-") != std::string::npos;
    if (!tiny) {
      error(start, t.length, "number '" + std::string(txt) + "' is too large",
            "numbers must fit in a double (at most about 1.8e308)");
      v = 0;
    } else {
      v = 0;  // underflow to zero is harmless
    }
  }
  t.number = v;
  return t;
}

}  // namespace hfrt::lang
