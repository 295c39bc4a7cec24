#include "core/field_error.h"

#include <limits>
#include <string>

#include <gtest/gtest.h>

namespace scanbench {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// The message a check threw, or "" when it passed.
template <typename Check>
std::string MessageOf(Check check) {
  try {
    check();
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "";
}

TEST(RequireTest, NamesWhereFieldValueAndTheRuleAsToday) {
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GE_LE("PhotometricSolverOptions", "min_lights", 2, 3, 1000); }),
            "PhotometricSolverOptions.min_lights = 2 must lie in [3, 1000]");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GE_LT("O", "f", 1.0, 0, 1); }), "O.f = 1 must lie in [0, 1)");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GT_LE("O", "f", 0.0, 0, 1); }), "O.f = 0 must lie in (0, 1]");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GT_LT("O", "f", 2.5, 0, 2); }), "O.f = 2.5 must lie in (0, 2)");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GT("O", "f", 1, 1); }), "O.f = 1 must be > 1");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GE("O", "f", -1, 0); }), "O.f = -1 must be >= 0");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_LE("O", "f", 11, 10); }), "O.f = 11 must be <= 10");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_FINITE("O", "f", kInf); }), "O.f = inf must be finite");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_FINITE_GT("O", "f", 0.0, 0); }), "O.f = 0 must be finite and > 0");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_FINITE_GE("O", "f", -0.5, 0); }), "O.f = -0.5 must be finite and >= 0");
}

TEST(RequireTest, BoundsReadAsWrittenInTheSource) {
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GE_LE("O", "f", 1e-7, 1e-6, 0.45); }),
            "O.f = 1e-07 must lie in [1e-6, 0.45]");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GE_LE("O", "f", 0.2f, 0, 0.1); }), "O.f = 0.2 must lie in [0, 0.1]");
}

TEST(RequireTest, NoteFollowsTheRule) {
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GT_LE("O", "lens_focal_mm", 0.0, 0, 1000, "mm"); }),
            "O.lens_focal_mm = 0 must lie in (0, 1000] mm");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GE("O", "tile_width", -1, 0, "(0 = automatic)"); }),
            "O.tile_width = -1 must be >= 0 (0 = automatic)");
}

TEST(RequireTest, BoundsHoldOrNotAsTheirBracketsSay) {
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GE_LE("O", "f", 3, 3, 1000); }), "");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GE_LE("O", "f", 1000, 3, 1000); }), "");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_GE_LE("O", "f", 1001, 3, 1000); }), "");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GE_LT("O", "f", 0.0, 0, 1); }), "");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_GE_LT("O", "f", -0.1, 0, 1); }), "");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GT_LE("O", "f", 1.0, 0, 1); }), "");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_GT_LE("O", "f", 1.5, 0, 1); }), "");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GT_LT("O", "f", 1.0, 0, 2); }), "");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_GT_LT("O", "f", 0.0, 0, 2); }), "");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GT("O", "f", 2, 1); }), "");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GE("O", "f", 0, 0); }), "");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_LE("O", "f", 10, 10); }), "");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_FINITE("O", "f", -1e300); }), "");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_FINITE_GT("O", "f", 1e-300, 0); }), "");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_FINITE_GE("O", "f", 0.0, 0); }), "");
}

TEST(RequireTest, NaNFailsEveryRule) {
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GE_LE("O", "f", kNaN, 0, 1); }), "O.f = nan must lie in [0, 1]");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_GE_LT("O", "f", kNaN, 0, 1); }), "");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_GT_LE("O", "f", kNaN, 0, 1); }), "");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_GT_LT("O", "f", kNaN, 0, 1); }), "");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_GT("O", "f", kNaN, 0); }), "");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_GE("O", "f", kNaN, 0); }), "");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_LE("O", "f", kNaN, 0); }), "");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_FINITE("O", "f", kNaN); }), "");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_FINITE_GT("O", "f", kNaN, 0); }), "");
  EXPECT_NE(MessageOf([] { SCANBENCH_REQUIRE_FINITE_GE("O", "f", kNaN, 0); }), "");
}

TEST(RequireTest, InfinityPassesOnlyTheRulesThatDoNotAskForFinite) {
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GE("O", "f", kInf, 0); }), "");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_GT("O", "f", kInf, 0); }), "");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_FINITE_GE("O", "f", kInf, 0); }), "O.f = inf must be finite and >= 0");
  EXPECT_EQ(MessageOf([] { SCANBENCH_REQUIRE_FINITE_GT("O", "f", kInf, 0); }), "O.f = inf must be finite and > 0");
}

TEST(RequireTest, ValueReadOnceAndFieldBuiltOnlyOnFailure) {
  int reads = 0;
  int names = 0;
  const auto value = [&] { return ++reads; };
  const auto field = [&] { return "f[" + std::to_string(++names) + "]"; };
  SCANBENCH_REQUIRE_GE_LE("O", field(), value(), 0, 10);
  EXPECT_EQ(reads, 1);
  EXPECT_EQ(names, 0);
  EXPECT_EQ(MessageOf([&] { SCANBENCH_REQUIRE_GT("O", field(), value(), 5); }), "O.f[1] = 2 must be > 5");
  EXPECT_EQ(reads, 2);
  EXPECT_EQ(names, 1);
}

}  // namespace
}  // namespace scanbench
