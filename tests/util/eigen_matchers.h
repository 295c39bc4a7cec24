// GoogleTest matchers for Eigen values.
#pragma once

#include <sstream>

#include <Eigen/Core>
#include <gmock/gmock.h>

namespace scanbench::testing {

// EXPECT_THAT(actual, EigenNear(expected, 1e-6)): same shape, every
// coefficient within the absolute tolerance; prints both on failure.
MATCHER_P2(EigenNear, expected, tolerance,
           "is within " + ::testing::PrintToString(tolerance) + " of\n" +
               [](const auto& m) { std::ostringstream s; s << m; return s.str(); }(expected)) {
  if (arg.rows() != expected.rows() || arg.cols() != expected.cols()) {
    *result_listener << "shape " << arg.rows() << "x" << arg.cols() << " differs from " << expected.rows() << "x"
                     << expected.cols();
    return false;
  }
  const double difference = (arg - expected).cwiseAbs().maxCoeff();
  *result_listener << "largest difference " << difference << ", actual\n" << arg;
  return difference <= tolerance;
}

}  // namespace scanbench::testing
