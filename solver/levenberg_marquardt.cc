#include "solver/levenberg_marquardt.h"

#include "core/field_error.h"

namespace scanbench {
namespace {
constexpr const char* kOptions = "LevenbergMarquardtOptions";
}  // namespace

void LevenbergMarquardtOptions::Check() const {
  SCANBENCH_REQUIRE_GE_LE(kOptions, "max_iterations", max_iterations, 1, 1000);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "max_step_attempts", max_step_attempts, 1, 100);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "initial_lambda", initial_lambda, 0);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "min_diagonal", min_diagonal, 0);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "lambda_decrease", lambda_decrease, 1);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "min_lambda", min_lambda, 0);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "lambda_increase", lambda_increase, 1);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "non_finite_increase", non_finite_increase, 1);
}

}  // namespace scanbench
