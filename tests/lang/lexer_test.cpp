// Lexer: token kinds, numbers per the spec, case-insensitive keywords, comments, CRLF, and
// malformed input reported with a location while lexing goes on.
#include "lang/lexer.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "lang/diagnostics.h"

namespace hfrt::lang {
namespace {

struct Lexed {
  std::vector<Token> tokens;  // without the final kEof
  std::vector<std::string> texts;
  std::vector<Diagnostic> errors;
};

Lexed lex(const std::string& text) {
  SourceFile file("lex.hf", text);
  Lexed out;
  Lexer lexer(file, [&](SourceRange r, std::string m, std::string h) {
    out.errors.push_back({Severity::kError, r, std::move(m), std::move(h)});
  });
  for (int guard = 0; guard < 100000; ++guard) {
    Token t = lexer.next();
    if (t.kind == TokenKind::kEof) break;
    out.tokens.push_back(t);
    out.texts.emplace_back(lexer.text(t));
  }
  return out;
}

std::vector<TokenKind> kinds(const std::string& text) {
  std::vector<TokenKind> out;
  for (const Token& t : lex(text).tokens) out.push_back(t.kind);
  return out;
}

using K = TokenKind;

TEST(Lexer, OperatorsAndPunctuation) {
  EXPECT_EQ(kinds("+ - * / ^ | & \\ @ ~ = /= < <= > >= ( ) [ ] { } , ;"),
            (std::vector<K>{K::kPlus,   K::kMinus,  K::kStar,      K::kSlash,    K::kCaret,
                            K::kBar,    K::kAmp,    K::kBackslash, K::kAt,       K::kTilde,
                            K::kEq,     K::kNe,     K::kLt,        K::kLe,       K::kGt,
                            K::kGe,     K::kLParen, K::kRParen,    K::kLBracket, K::kRBracket,
                            K::kLBrace, K::kRBrace, K::kComma,     K::kSemicolon}));
  // No spaces needed between tokens.
  EXPECT_EQ(kinds("a/=b<=c/d"), (std::vector<K>{K::kIdent, K::kNe, K::kIdent, K::kLe, K::kIdent,
                                                K::kSlash, K::kIdent}));
}

TEST(Lexer, KeywordsAreCaseInsensitive) {
  EXPECT_EQ(kinds("array IF Then eLsE ENDIF while LOOP EndLoop and OR Not xor"),
            (std::vector<K>{K::kArray, K::kIf, K::kThen, K::kElse, K::kEndif, K::kWhile, K::kLoop,
                            K::kEndloop, K::kAnd, K::kOr, K::kNot, K::kXor}));
  // Keywords inside longer names are names.
  EXPECT_EQ(kinds("iffy endif2 array_ x a s"),
            (std::vector<K>{K::kIdent, K::kIdent, K::kIdent, K::kIdent, K::kIdent, K::kIdent}));
}

TEST(Lexer, IdentifiersKeepTheirSpelling) {
  Lexed l = lex("My_Model hfSphere x1_2");
  ASSERT_EQ(l.texts.size(), 3u);
  EXPECT_EQ(l.texts[0], "My_Model");
  EXPECT_EQ(l.texts[1], "hfSphere");
  EXPECT_EQ(l.texts[2], "x1_2");
  EXPECT_TRUE(l.errors.empty());
}

TEST(Lexer, NumberForms) {
  Lexed l = lex(".5 5. 1.5E+2 2e-3 0 0.25 7 1e0 12.75e1");
  ASSERT_TRUE(l.errors.empty());
  std::vector<double> want = {0.5, 5.0, 150.0, 0.002, 0, 0.25, 7, 1, 127.5};
  ASSERT_EQ(l.tokens.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(l.tokens[i].kind, K::kNumber) << l.texts[i];
    EXPECT_DOUBLE_EQ(l.tokens[i].number, want[i]) << l.texts[i];
  }
}

TEST(Lexer, LeadingZeroIsAnError) {
  Lexed l = lex("v = 01;");
  ASSERT_EQ(l.errors.size(), 1u);
  EXPECT_EQ(l.errors[0].message, "number '01' starts with 0");
  EXPECT_EQ(l.errors[0].range.begin.col, 5u);
  EXPECT_EQ(l.errors[0].range.length, 2u);
  // The token is still a number, so that parsing can go on.
  EXPECT_EQ(l.tokens[2].kind, K::kNumber);
  EXPECT_EQ(lex("00.5").errors.size(), 1u);
  EXPECT_TRUE(lex("0.5").errors.empty());
}

TEST(Lexer, ExponentLeadingZeroIsAnError) {
  Lexed l = lex("1e05");
  ASSERT_EQ(l.errors.size(), 1u);
  EXPECT_EQ(l.errors[0].message, "exponent of '1e05' starts with 0");
  EXPECT_EQ(l.tokens.size(), 1u);
  EXPECT_TRUE(lex("1e5 1E-5 1e+10").errors.empty());
}

TEST(Lexer, ExponentWithoutDigits) {
  Lexed l = lex("2e+ 1");
  ASSERT_EQ(l.errors.size(), 1u);
  EXPECT_EQ(l.errors[0].message, "number '2e+' has no exponent digits");
  // "2e" followed by a letter is the number 2 and a name (not a malformed exponent).
  EXPECT_EQ(kinds("2ex"), (std::vector<K>{K::kNumber, K::kIdent}));
  EXPECT_EQ(kinds("2else"), (std::vector<K>{K::kNumber, K::kElse}));
}

TEST(Lexer, HugeNumberIsAnError) {
  Lexed l = lex("1e999");
  ASSERT_EQ(l.errors.size(), 1u);
  EXPECT_EQ(l.errors[0].message, "number '1e999' is too large");
  EXPECT_TRUE(lex("1e-999").errors.empty());  // underflows to 0, harmless
}

TEST(Lexer, CommentsRunToEndOfLine) {
  EXPECT_EQ(kinds("a -- b c ( ) \n d"), (std::vector<K>{K::kIdent, K::kIdent}));
  EXPECT_EQ(kinds("a--b"), (std::vector<K>{K::kIdent}));
  EXPECT_EQ(kinds("a - -b"), (std::vector<K>{K::kIdent, K::kMinus, K::kMinus, K::kIdent}));
  EXPECT_TRUE(kinds("-- only a comment").empty());
}

TEST(Lexer, CrLfIsWhitespace) {
  Lexed l = lex("a\r\nb\r\n");
  EXPECT_TRUE(l.errors.empty());
  ASSERT_EQ(l.tokens.size(), 2u);
  SourceFile f("crlf.hf", "a\r\nb\r\n");
  SourceLoc loc = f.loc_at(l.tokens[1].offset);
  EXPECT_EQ(loc.line, 2u);
  EXPECT_EQ(loc.col, 1u);
  EXPECT_EQ(f.line_text(1), "a");  // no '\r' in the shown line
}

TEST(Lexer, LocationsAreOneBasedLineAndByteColumn) {
  SourceFile f("loc.hf", "ab\n  cd\n\tx");
  EXPECT_EQ(f.loc_at(0).line, 1u);
  EXPECT_EQ(f.loc_at(0).col, 1u);
  EXPECT_EQ(f.loc_at(5).line, 2u);
  EXPECT_EQ(f.loc_at(5).col, 3u);
  EXPECT_EQ(f.loc_at(9).line, 3u);
  EXPECT_EQ(f.loc_at(9).col, 2u);
  EXPECT_EQ(f.line_count(), 3u);
  EXPECT_EQ(f.line_text(4), "");
  EXPECT_EQ(f.loc_at(1000).offset, 10u);  // clamped to the end
}

TEST(Lexer, IdentifierLengthLimit) {
  std::string ok(256, 'a');
  EXPECT_TRUE(lex(ok).errors.empty());
  Lexed l = lex(" " + std::string(257, 'b'));
  ASSERT_EQ(l.errors.size(), 1u);
  EXPECT_EQ(l.errors[0].message, "name is 257 characters long; at most 256 are allowed");
  EXPECT_EQ(l.errors[0].range.begin.col, 2u);
  EXPECT_EQ(l.tokens.size(), 1u);
}

TEST(Lexer, InvalidCharactersAreGroupedIntoOneError) {
  Lexed l = lex("a $#? b");
  ASSERT_EQ(l.errors.size(), 1u);
  EXPECT_EQ(l.errors[0].message, "unexpected characters '$#?'");
  EXPECT_EQ(l.errors[0].range.begin.col, 3u);
  EXPECT_EQ(l.errors[0].range.length, 3u);
  EXPECT_EQ(kinds("a $#? b"), (std::vector<K>{K::kIdent, K::kInvalid, K::kIdent}));
}

TEST(Lexer, NulByte) {
  Lexed l = lex(std::string("a \0 b", 5));
  ASSERT_EQ(l.errors.size(), 1u);
  EXPECT_EQ(l.errors[0].message, "NUL byte in the source text");
  EXPECT_EQ(l.errors[0].range.begin.col, 3u);
}

TEST(Lexer, ForeignOperatorsAreReportedAndMapped) {
  Lexed l = lex("a != b == c && d || e ! f");
  ASSERT_EQ(l.errors.size(), 5u);
  EXPECT_EQ(kinds("a != b == c && d || e ! f"),
            (std::vector<K>{K::kIdent, K::kNe, K::kIdent, K::kEq, K::kIdent, K::kAnd, K::kIdent,
                            K::kOr, K::kIdent, K::kNot, K::kIdent}));
}

TEST(Lexer, StringIsOneInvalidToken) {
  Lexed l = lex("f(x, \"abc def\", 1)");
  ASSERT_EQ(l.errors.size(), 1u);
  EXPECT_EQ(l.errors[0].range.length, 9u);
  EXPECT_EQ(kinds("f(x, \"abc def\", 1)"),
            (std::vector<K>{K::kIdent, K::kLParen, K::kIdent, K::kComma, K::kInvalid, K::kComma,
                            K::kNumber, K::kRParen}));
  // Unterminated: stops at the end of the line.
  EXPECT_EQ(kinds("\"abc\nx"), (std::vector<K>{K::kInvalid, K::kIdent}));
}

TEST(Lexer, UnterminatedBlockCommentEndsAtEof) {
  Lexed l = lex("a /* never closed\n b c");
  ASSERT_EQ(l.errors.size(), 1u);
  EXPECT_EQ(l.tokens.size(), 1u);
}

TEST(Lexer, RewindReplaysTheSameTokens) {
  SourceFile file("r.hf", "a + 12 * (b)");
  Lexer lexer(file, [](SourceRange, std::string, std::string) {});
  lexer.next();
  uint32_t saved = lexer.position();
  Token first = lexer.next();
  lexer.next();
  lexer.rewind(saved);
  Token again = lexer.next();
  EXPECT_EQ(first.kind, again.kind);
  EXPECT_EQ(first.offset, again.offset);
}

TEST(Lexer, EofRepeats) {
  SourceFile file("e.hf", "  ");
  Lexer lexer(file, [](SourceRange, std::string, std::string) {});
  EXPECT_EQ(lexer.next().kind, K::kEof);
  EXPECT_EQ(lexer.next().kind, K::kEof);
}

TEST(Lexer, EveryByteValueTerminates) {
  // Each single byte, and each byte after a digit, a letter and a dot, lexes to the end.
  for (int b = 0; b < 256; ++b) {
    for (std::string prefix : {"", "1", "a", ".", "1e", "-", "/"}) {
      std::string text = prefix + std::string(1, static_cast<char>(b));
      Lexed l = lex(text);
      size_t covered = 0;
      for (const Token& t : l.tokens) covered = std::max<size_t>(covered, t.offset + t.length);
      EXPECT_LE(covered, text.size());
    }
  }
}

}  // namespace
}  // namespace hfrt::lang
