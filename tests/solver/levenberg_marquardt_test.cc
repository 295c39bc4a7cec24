// The Levenberg-Marquardt loop (solver/levenberg_marquardt.h) on small
// problems with known minima: a curve fit, a robust line fit with an outlier,
// and functors made to end the loop for each of its reasons.
#include "solver/levenberg_marquardt.h"

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

namespace scanbench {
namespace {

using Termination = LevenbergMarquardtSummary::Termination;

// What the two-parameter fits below share: the trial p + step, and
// convergence when a taken step moves p by less than `tolerance`.
// Derived::Cost(p) is the cost of p.
template <typename Derived>
class TwoParameterFit {
 public:
  using Hessian = Eigen::Matrix2d;
  using Vector = Eigen::Vector2d;

  TwoParameterFit(Vector start, double tolerance) : p_(start), tolerance_(tolerance) {}
  bool Trial(const Vector& step, double* cost) {
    trial_ = p_ + step;
    *cost = static_cast<const Derived&>(*this).Cost(trial_);
    return true;
  }
  StepVerdict Take(double, double) {
    const double moved = (trial_ - p_).norm();
    p_ = trial_;
    return moved < tolerance_ ? StepVerdict::kTakenConverged : StepVerdict::kTaken;
  }
  const Vector& parameters() const { return p_; }

 protected:
  Vector p_, trial_ = Vector::Zero();
  double tolerance_;
};

// Least squares of y = a exp(b x) with the Jacobian by hand.
class ExponentialFit : public TwoParameterFit<ExponentialFit> {
 public:
  ExponentialFit(std::vector<double> x, std::vector<double> y, Vector start)
      : TwoParameterFit(start, 1e-12), x_(std::move(x)), y_(std::move(y)) {}

  bool Linearize(Hessian* jtj, Vector* jtr, double* cost) {
    jtj->setZero(), jtr->setZero();
    *cost = Cost(p_);
    for (size_t i = 0; i < x_.size(); ++i) {
      const double e = std::exp(p_[1] * x_[i]);
      const Vector j(e, p_[0] * x_[i] * e);
      *jtj += j * j.transpose();
      *jtr += (p_[0] * e - y_[i]) * j;
    }
    return true;
  }
  double Cost(const Vector& p) const {
    double sum = 0;
    for (size_t i = 0; i < x_.size(); ++i) sum += std::pow(p[0] * std::exp(p[1] * x_[i]) - y_[i], 2);
    return sum;
  }

 private:
  std::vector<double> x_, y_;
};

TEST(LevenbergMarquardtTest, FitsAnExponentialToItsKnownMinimum) {
  std::vector<double> x, y;
  for (int i = 0; i < 20; ++i) x.push_back(0.2 * i), y.push_back(2.0 * std::exp(-0.5 * x.back()));
  ExponentialFit fit(x, y, Eigen::Vector2d(1.0, 0.0));
  LevenbergMarquardtOptions options;
  options.max_iterations = 100;
  const LevenbergMarquardtSummary summary = SolveLevenbergMarquardt(options, &fit);
  EXPECT_EQ(summary.termination, Termination::kConverged);
  EXPECT_NEAR(fit.parameters()[0], 2.0, 1e-9);
  EXPECT_NEAR(fit.parameters()[1], -0.5, 1e-9);
  EXPECT_GT(summary.steps_taken, 2);
  EXPECT_LE(summary.iterations, options.max_iterations);
  EXPECT_LT(summary.cost, 1e-12);
}

TEST(LevenbergMarquardtTest, BacktrackingFindsTheSameMinimum) {
  std::vector<double> x, y;
  for (int i = 0; i < 20; ++i) x.push_back(0.2 * i), y.push_back(2.0 * std::exp(-0.5 * x.back()));
  ExponentialFit fit(x, y, Eigen::Vector2d(1.5, -0.3));
  LevenbergMarquardtOptions options;
  options.damping = LevenbergMarquardtOptions::Damping::kFixedWithBacktracking;
  options.max_iterations = 100;
  const LevenbergMarquardtSummary summary = SolveLevenbergMarquardt(options, &fit);
  EXPECT_EQ(summary.termination, Termination::kConverged);
  EXPECT_NEAR(fit.parameters()[0], 2.0, 1e-9);
  EXPECT_NEAR(fit.parameters()[1], -0.5, 1e-9);
  EXPECT_EQ(summary.lambda, options.initial_lambda);  // fixed damping
}

// A line y = a + b x with Tukey weights refreshed inside the functor at each
// linearization (scale: 1.4826 MAD of the residuals, floored), the way the
// per-pixel fits reweight.
class RobustLineFit : public TwoParameterFit<RobustLineFit> {
 public:
  RobustLineFit(std::vector<double> x, std::vector<double> y, bool robust)
      : TwoParameterFit(Vector::Zero(), 1e-9),
        x_(std::move(x)),
        y_(std::move(y)),
        robust_(robust),
        weights_(x_.size(), 1.0) {}

  bool Linearize(Hessian* jtj, Vector* jtr, double* cost) {
    if (robust_) Reweight();
    jtj->setZero(), jtr->setZero();
    for (size_t i = 0; i < x_.size(); ++i) {
      const Vector j(1.0, x_[i]);
      *jtj += weights_[i] * j * j.transpose();
      *jtr += weights_[i] * Residual(p_, i) * j;
    }
    *cost = Cost(p_);
    return true;
  }
  // Under the weights of the last linearization.
  double Cost(const Vector& p) const {
    double sum = 0;
    for (size_t i = 0; i < x_.size(); ++i) sum += weights_[i] * std::pow(Residual(p, i), 2);
    return sum;
  }
  double weight(size_t i) const { return weights_[i]; }

 private:
  double Residual(const Vector& p, size_t i) const { return p[0] + p[1] * x_[i] - y_[i]; }
  void Reweight() {
    std::vector<double> abs;
    for (size_t i = 0; i < x_.size(); ++i) abs.push_back(std::abs(Residual(p_, i)));
    std::nth_element(abs.begin(), abs.begin() + abs.size() / 2, abs.end());
    const double scale = std::max(1.4826 * abs[abs.size() / 2], 1e-6);
    for (size_t i = 0; i < x_.size(); ++i) {
      const double u = Residual(p_, i) / (4.685 * scale), t = 1 - u * u;
      weights_[i] = t > 0 ? t * t : 0.0;
    }
  }
  std::vector<double> x_, y_;
  bool robust_;
  std::vector<double> weights_;
};

TEST(LevenbergMarquardtTest, RobustReweightingInTheFunctorIgnoresAnOutlier) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 1e-3);
  std::vector<double> x, y;
  for (int i = 0; i < 15; ++i) x.push_back(i), y.push_back(0.5 + 0.25 * i + noise(rng));
  y[7] += 5.0;  // one outlier
  LevenbergMarquardtOptions options;
  options.max_iterations = 50;

  RobustLineFit plain(x, y, false);
  SolveLevenbergMarquardt(options, &plain);
  // Least squares spreads the outlier over the line: its offset moves by 1/3.
  EXPECT_GT(std::abs(plain.parameters()[0] - 0.5), 0.1);

  RobustLineFit robust(x, y, true);
  const LevenbergMarquardtSummary summary = SolveLevenbergMarquardt(options, &robust);
  EXPECT_EQ(summary.termination, Termination::kConverged);
  EXPECT_NEAR(robust.parameters()[0], 0.5, 3e-3);
  EXPECT_NEAR(robust.parameters()[1], 0.25, 3e-4);
  EXPECT_EQ(robust.weight(7), 0.0);
  EXPECT_GT(robust.weight(6), 0.9);
}

// A functor whose every answer is scripted, to end the loop on purpose.
class ScriptedFunctor {
 public:
  using Hessian = Eigen::Matrix<double, 1, 1>;
  using Vector = Eigen::Matrix<double, 1, 1>;

  bool linearizes = true;
  double gradient = 1.0;
  double cost = 1.0;
  double trial_cost = 2.0;  // worse than `cost`: never lowers it
  bool trial_finite = true;
  StepVerdict verdict = StepVerdict::kTaken;
  std::vector<double> steps;  // every step tried

  bool Linearize(Hessian* jtj, Vector* jtr, double* c) {
    (*jtj)(0, 0) = 1.0;
    (*jtr)(0, 0) = gradient;
    *c = cost;
    return linearizes;
  }
  bool Trial(const Vector& step, double* c) {
    steps.push_back(step(0, 0));
    *c = trial_cost;
    return trial_finite;
  }
  StepVerdict Take(double, double) { return verdict; }
};

TEST(LevenbergMarquardtTest, EndsForEachOfItsReasons) {
  LevenbergMarquardtOptions options;
  options.max_iterations = 3;
  options.max_step_attempts = 4;
  {
    ScriptedFunctor f;
    f.linearizes = false;
    const LevenbergMarquardtSummary s = SolveLevenbergMarquardt(options, &f);
    EXPECT_EQ(s.termination, Termination::kLinearizationFailed);
    EXPECT_EQ(s.iterations, 0);
    EXPECT_TRUE(f.steps.empty());
  }
  {
    ScriptedFunctor f;  // every trial raises the cost
    const LevenbergMarquardtSummary s = SolveLevenbergMarquardt(options, &f);
    EXPECT_EQ(s.termination, Termination::kNoDescent);
    EXPECT_EQ(s.iterations, 1);
    EXPECT_EQ(s.steps_taken, 0);
    ASSERT_EQ(f.steps.size(), 4u);
    EXPECT_DOUBLE_EQ(s.lambda, 1e-3 * 4 * 4 * 4 * 4);  // lambda_increase per rejected trial
    // More damping, shorter steps: -g / (1 + lambda).
    EXPECT_DOUBLE_EQ(f.steps[0], -1.0 / (1 + 1e-3));
    EXPECT_LT(std::abs(f.steps[3]), std::abs(f.steps[0]));
  }
  {
    ScriptedFunctor f;  // every trial lowers it and is taken
    f.trial_cost = 0.5;
    const LevenbergMarquardtSummary s = SolveLevenbergMarquardt(options, &f);
    EXPECT_EQ(s.termination, Termination::kMaxIterations);
    EXPECT_EQ(s.iterations, 3);
    EXPECT_EQ(s.steps_taken, 3);
    EXPECT_DOUBLE_EQ(s.lambda, 1e-3 / 27);
  }
  {
    ScriptedFunctor f;  // lowered, but below the functor's tolerances: not taken
    f.trial_cost = 0.5;
    f.verdict = StepVerdict::kConverged;
    const LevenbergMarquardtSummary s = SolveLevenbergMarquardt(options, &f);
    EXPECT_EQ(s.termination, Termination::kConverged);
    EXPECT_EQ(s.steps_taken, 0);
    EXPECT_EQ(f.steps.size(), 1u);
  }
  {
    ScriptedFunctor f;  // a non-finite trial point: more damping, as a non-finite step
    f.trial_finite = false;
    const LevenbergMarquardtSummary s = SolveLevenbergMarquardt(options, &f);
    EXPECT_EQ(s.termination, Termination::kNoDescent);
    EXPECT_DOUBLE_EQ(s.lambda, 1e-3 * 10 * 10 * 10 * 10);
  }
  {
    ScriptedFunctor f;  // a NaN gradient: no finite step; backtracking stops at once
    f.gradient = std::numeric_limits<double>::quiet_NaN();
    LevenbergMarquardtOptions fixed = options;
    fixed.damping = LevenbergMarquardtOptions::Damping::kFixedWithBacktracking;
    const LevenbergMarquardtSummary s = SolveLevenbergMarquardt(fixed, &f);
    EXPECT_EQ(s.termination, Termination::kNonFiniteStep);
    EXPECT_TRUE(f.steps.empty());
  }
}

TEST(LevenbergMarquardtTest, BacktrackingHalvesTheStepAndMayAcceptAnEqualCost) {
  LevenbergMarquardtOptions options;
  options.damping = LevenbergMarquardtOptions::Damping::kFixedWithBacktracking;
  options.max_iterations = 2;
  options.max_step_attempts = 3;
  {
    ScriptedFunctor f;  // never lower: the one solved step, halved twice
    const LevenbergMarquardtSummary s = SolveLevenbergMarquardt(options, &f);
    EXPECT_EQ(s.termination, Termination::kNoDescent);
    ASSERT_EQ(f.steps.size(), 3u);
    EXPECT_EQ(f.steps[1], 0.5 * f.steps[0]);
    EXPECT_EQ(f.steps[2], 0.25 * f.steps[0]);
  }
  {
    ScriptedFunctor f;
    f.trial_cost = f.cost;  // equal: a rejection unless accept_equal_cost
    EXPECT_EQ(SolveLevenbergMarquardt(options, &f).steps_taken, 0);
    options.accept_equal_cost = true;
    ScriptedFunctor g;
    g.trial_cost = g.cost;
    EXPECT_EQ(SolveLevenbergMarquardt(options, &g).steps_taken, 2);
  }
  {
    ScriptedFunctor f;  // an infinite trial cost (a point the model cannot take) is never accepted
    f.cost = std::numeric_limits<double>::infinity();
    f.trial_cost = std::numeric_limits<double>::infinity();
    EXPECT_EQ(SolveLevenbergMarquardt(options, &f).steps_taken, 0);
  }
}

TEST(LevenbergMarquardtTest, CheckNamesTheFieldAndTheRule) {
  LevenbergMarquardtOptions options;
  EXPECT_NO_THROW(options.Check());
  options.max_step_attempts = 0;
  try {
    options.Check();
    FAIL() << "max_step_attempts = 0 passed";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("max_step_attempts = 0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("[1, 100]"), std::string::npos) << e.what();
  }
  options = LevenbergMarquardtOptions();
  options.lambda_increase = 1;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = LevenbergMarquardtOptions();
  options.initial_lambda = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
