// The one reader of typed numbers (decimal.h): what it accepts and what it refuses, with the message each refusal
// gives. The refusals are the cases a user met (issue 17): hexadecimal read as 16, empty text read as 0.
#include "core/decimal.h"

#include <gtest/gtest.h>

#include <cmath>

namespace curvecheck {
namespace {

TEST(Decimal, AcceptsWhatAPersonWrites) {
  const std::pair<const char*, double> cases[] = {{"0", 0},        {"12", 12},         {"-3", -3},   {"+0.5", 0.5},
                                                  {".5", 0.5},     {"5.", 5},          {"010", 10},  {"1e-3", 1e-3},
                                                  {"2.5E+2", 250}, {"-0.0001", -1e-4}, {"1e308", 1e308}};
  for (const auto& [text, value] : cases) {
    const std::optional<double> v = ParseDecimal(text);
    ASSERT_TRUE(v.has_value()) << text;
    EXPECT_DOUBLE_EQ(*v, value) << text;
    EXPECT_EQ(DecimalProblem(text), "") << text;
  }
  EXPECT_EQ(ParseWholeNumber("007"), 7);
  EXPECT_EQ(ParseWholeNumber("-12"), -12);
  EXPECT_EQ(ParseWholeNumber("+4"), 4);
}

TEST(Decimal, RefusesEverythingElseAndSaysWhy) {
  const std::pair<const char*, const char*> cases[] = {
      {"", "'' is not a number"},
      {"0x10", "'0x10' is not a decimal number"},
      {"-0X1p3", "'-0X1p3' is not a decimal number"},
      {"inf", "'inf' is not a finite number"},
      {"-Infinity", "'-Infinity' is not a finite number"},
      {"nan", "'nan' is not a finite number"},
      {"1e999", "'1e999' is out of range"},
      {" 5", "' 5' is not a number"},
      {"5 ", "'5 ' is not a number"},
      {"1,5", "'1,5' is not a number"},
      {"1e", "'1e' is not a number"},
      {".", "'.' is not a number"},
      {"-", "'-' is not a number"},
      {"abc", "'abc' is not a number"},
      {"12mm", "'12mm' is not a number"},
  };
  for (const auto& [text, problem] : cases) {
    EXPECT_FALSE(ParseDecimal(text).has_value()) << text;
    EXPECT_FALSE(ParseWholeNumber(text).has_value()) << text;
    EXPECT_EQ(DecimalProblem(text), problem) << text;
  }
  EXPECT_FALSE(ParseWholeNumber("1.5").has_value());
  EXPECT_FALSE(ParseWholeNumber("1e3").has_value());
  EXPECT_EQ(DecimalProblem("1.5", true), "'1.5' is not a whole number");
  EXPECT_EQ(DecimalProblem("99999999999999999999", true), "'99999999999999999999' is out of range");
  EXPECT_EQ(DecimalProblem("99999999999999999999"), "");  // a fine double
}

}  // namespace
}  // namespace curvecheck
