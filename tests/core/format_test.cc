#include "core/format.h"

#include <limits>

#include <gtest/gtest.h>

#include "core/field_error.h"
#include "core/progress.h"

namespace scanbench {
namespace {

TEST(FormatTest, FixedDigits) {
  EXPECT_EQ(Fixed(0.3776, 3), "0.378");
  EXPECT_EQ(Fixed(2, 1), "2.0");
  EXPECT_EQ(Fixed(-1.25, 0), "-1");
}

// Report times (issue #36): three significant digits, never "0.0797305 s" nor "7.97e-02 s".
TEST(FormatTest, SignificantDigits) {
  EXPECT_EQ(Significant(0.0797305), "0.0797");
  EXPECT_EQ(Significant(12.345), "12.3");
  EXPECT_EQ(Significant(1.5), "1.50");
  EXPECT_EQ(Significant(1234.6), "1235");
  EXPECT_EQ(Significant(0.000123456), "0.000123");
  EXPECT_EQ(Significant(0.09996), "0.100");
  EXPECT_EQ(Significant(9.996), "10.0");
  EXPECT_EQ(Significant(-0.0797305), "-0.0797");
  EXPECT_EQ(Significant(0), "0");
  EXPECT_EQ(Significant(3.14159, 2), "3.1");
}

TEST(FormatTest, DurationOnAClockFace) {
  EXPECT_EQ(FormatDuration(0), "0:00");
  EXPECT_EQ(FormatDuration(42.4), "0:42");
  EXPECT_EQ(FormatDuration(187), "3:07");
  EXPECT_EQ(FormatDuration(3729), "1h02:09");
  EXPECT_EQ(FormatDuration(-5), "0:00");
  EXPECT_EQ(FormatDuration(std::numeric_limits<double>::infinity()), "0:00");
}

TEST(FormatTest, SecondsSinceIsNonNegative) {
  const auto start = std::chrono::steady_clock::now();
  EXPECT_GE(SecondsSince(start), 0.0);
  EXPECT_LT(SecondsSince(start), 60.0);
}

TEST(FieldErrorTest, NamesWhereFieldValueAndRule) {
  const std::invalid_argument error = FieldError("SolverOptions", "min_lights", 2, "must lie in [3, 1000]");
  EXPECT_STREQ(error.what(), "SolverOptions.min_lights = 2 must lie in [3, 1000]");
}

TEST(ProgressTest, SubRangeMapsOntoTheCallersRange) {
  double last = -1;
  const ProgressCallback outer = [&](double fraction) {
    last = fraction;
    return fraction < 0.7;
  };
  const ProgressCallback inner = SubRange(outer, 0.5, 0.9);
  EXPECT_TRUE(inner(0.25));
  EXPECT_DOUBLE_EQ(last, 0.6);
  EXPECT_FALSE(inner(1.0));
  EXPECT_DOUBLE_EQ(last, 0.9);
  EXPECT_FALSE(SubRange({}, 0, 1));
}

}  // namespace
TEST(FormatTest, XmlEscapedEscapesTheFiveEntitiesAndNothingElse) {
  EXPECT_EQ(XmlEscaped("a<b>&\"c\" 'd' — é"), "a&lt;b&gt;&amp;&quot;c&quot; &apos;d&apos; — é");
  EXPECT_EQ(XmlEscaped(""), "");
}

}  // namespace scanbench
