// Asserts that an options struct's Check() rejects it with an error naming
// the field ("NormalFlatteningOptions.low_pass_sigma_px = 0 must be > 0").
#pragma once

#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace scanbench::testing {

template <typename Options>
void ExpectCheckRejects(const Options& options, const std::string& qualified_field) {
  try {
    options.Check();
    ADD_FAILURE() << qualified_field << " accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(), ::testing::HasSubstr(qualified_field));
  }
}

}  // namespace scanbench::testing
