#include "policy/lex/lex.h"

#include <gtest/gtest.h>

namespace contego::policy {
namespace {

struct Lexed {
  std::vector<Token> tokens;
  std::vector<Diagnostic> diags;
};

Lexed run(const std::string& text) {
  SourceBuffer src("t.policy", text);
  DiagnosticEmitter d(src);
  Lexed l;
  l.tokens = lex(src, d);
  l.diags = d.take();
  return l;
}

TEST(Lex, DurationsAreMicroseconds) {
  const Lexed l = run("200ms 250us 1s 5min 1.5ms");
  ASSERT_EQ(l.tokens.size(), 6u);
  EXPECT_EQ(l.tokens[0].kind, Tok::kDuration);
  EXPECT_EQ(l.tokens[0].value, 200000);
  EXPECT_EQ(l.tokens[1].value, 250);
  EXPECT_EQ(l.tokens[2].value, 1000000);
  EXPECT_EQ(l.tokens[3].value, 300000000);
  EXPECT_EQ(l.tokens[4].value, 1500);
  EXPECT_TRUE(l.diags.empty());
}

TEST(Lex, RangeIsNotAFraction) {
  const Lexed l = run("80..90");
  ASSERT_EQ(l.tokens.size(), 4u);
  EXPECT_EQ(l.tokens[0].value, 80);
  EXPECT_EQ(l.tokens[1].kind, Tok::kDotDot);
  EXPECT_EQ(l.tokens[2].value, 90);
}

TEST(Lex, HexAndBusSpelling) {
  const Lexed l = run("i2c-1 0x08");
  ASSERT_EQ(l.tokens.size(), 5u);
  EXPECT_EQ(l.tokens[0].text, "i2c");
  EXPECT_EQ(l.tokens[1].kind, Tok::kMinus);
  EXPECT_EQ(l.tokens[3].value, 8);
}

// A text the lexer refuses with one diagnostic: its id and, unless 0, its column.
struct Refused {
  const char* text;
  const char* id;
  uint32_t column;
};

class LexRefuses : public ::testing::TestWithParam<Refused> {};

TEST_P(LexRefuses, WithOneDiagnostic) {
  const Lexed l = run(GetParam().text);
  ASSERT_EQ(l.diags.size(), 1u);
  EXPECT_EQ(l.diags[0].id, GetParam().id);
  if (GetParam().column != 0) {
    EXPECT_EQ(l.diags[0].column, GetParam().column);
  }
}

INSTANTIATE_TEST_SUITE_P(Lex, LexRefuses,
                         ::testing::Values(Refused{"0.5", "E0106", 0},   // a fraction needs a unit
                                           Refused{"10kg", "E0104", 3},  // reported on the unit
                                           Refused{"99999999999999999999", "E0105", 0}));

TEST(Lex, LineStartIsRecorded) {
  const Lexed l = run("a b\n  c # comment\nd");
  ASSERT_EQ(l.tokens.size(), 5u);
  EXPECT_TRUE(l.tokens[0].line_start);
  EXPECT_FALSE(l.tokens[1].line_start);
  EXPECT_TRUE(l.tokens[2].line_start);
  EXPECT_TRUE(l.tokens[3].line_start);
}

TEST(Lex, UnexpectedCharacterShowsTheWholeUtf8Character) {
  const Lexed l = run("a \xc2\xb5 b");
  ASSERT_EQ(l.diags.size(), 1u);
  EXPECT_EQ(l.diags[0].message.substr(0, 27), "unexpected character `\xc2\xb5`; ");
}

}  // namespace
}  // namespace contego::policy
