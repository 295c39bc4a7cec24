#include "solver/levenberg_marquardt.h"

#include <cmath>

#include "core/field_error.h"

namespace scanbench {
namespace {
constexpr const char* kOptions = "LevenbergMarquardtOptions";
}  // namespace

void LevenbergMarquardtOptions::Check() const {
  if (max_iterations < 1 || max_iterations > 1000) {
    throw FieldError(kOptions, "max_iterations", max_iterations, "must lie in [1, 1000]");
  }
  if (max_step_attempts < 1 || max_step_attempts > 100) {
    throw FieldError(kOptions, "max_step_attempts", max_step_attempts, "must lie in [1, 100]");
  }
  if (!(initial_lambda > 0) || !std::isfinite(initial_lambda)) {
    throw FieldError(kOptions, "initial_lambda", initial_lambda, "must be finite and > 0");
  }
  if (!(min_diagonal > 0) || !std::isfinite(min_diagonal)) {
    throw FieldError(kOptions, "min_diagonal", min_diagonal, "must be finite and > 0");
  }
  if (!(lambda_decrease > 1) || !std::isfinite(lambda_decrease)) {
    throw FieldError(kOptions, "lambda_decrease", lambda_decrease, "must be finite and > 1");
  }
  if (!(min_lambda > 0) || !std::isfinite(min_lambda)) {
    throw FieldError(kOptions, "min_lambda", min_lambda, "must be finite and > 0");
  }
  if (!(lambda_increase > 1) || !std::isfinite(lambda_increase)) {
    throw FieldError(kOptions, "lambda_increase", lambda_increase, "must be finite and > 1");
  }
  if (!(non_finite_increase > 1) || !std::isfinite(non_finite_increase)) {
    throw FieldError(kOptions, "non_finite_increase", non_finite_increase, "must be finite and > 1");
  }
}

}  // namespace scanbench
