// One small Levenberg-Marquardt loop for the per-pixel fits (after Ceres'
// tiny_solver.h): the lobe (FitDiffuseLobe), the sheen (FitDiffuseSheen) and
// the normal under a shared lobe (RefineCoherentLobe). The functor owns the
// parameters and the model; robust reweighting and variable projection (the
// linear amplitudes re-solved at every trial) live inside it, so the loop only
// damps, solves, tries and keeps steps. Header-only: each fit's functor is
// inlined into its per-pixel kernel.
//
// A Functor provides
//   using Hessian = ...;  // square Eigen matrix (fixed, or dynamic with a fixed maximum)
//   using Vector = ...;   // column of the same size
//   // At the current parameters: J^T W J, J^T W r and the cost sum w r^2 (the
//   // weights refreshed here, if robust). False ends the fit (kLinearizationFailed).
//   bool Linearize(Hessian* jtj, Vector* jtr, double* cost);
//   // The cost at the current parameters plus `step`, into *cost; infinity when
//   // the model cannot take that point (e.g. a negative amplitude). False when
//   // the point is not finite: then treated as a non-finite step.
//   bool Trial(const Vector& step, double* cost);
//   // Called when the last trial lowered the cost: takes it or not, and says
//   // whether the fit has converged (the parameter tests are the functor's).
//   StepVerdict Take(double cost, double trial_cost);
#pragma once

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace scanbench {

struct LevenbergMarquardtOptions {
  enum class Damping {
    // Marquardt's: a rejected step is solved again with more damping.
    kAdaptive,
    // Fixed damping, one solve per linearization; a rejected step is halved
    // (a backtracking line search) and a non-finite step ends the fit.
    kFixedWithBacktracking,
  };
  Damping damping = Damping::kAdaptive;
  int max_iterations = 30;        // linearizations, in [1, 1000]
  int max_step_attempts = 6;      // trial steps per linearization, in [1, 100]
  // The damped system is J^T W J + lambda diag(max(J^T W J_ii, min_diagonal)).
  double initial_lambda = 1e-3;   // > 0
  double min_diagonal = 1e-12;    // > 0
  // kAdaptive's updates: lambda = max(lambda / lambda_decrease, min_lambda)
  // after a step that lowered the cost, lambda *= lambda_increase after one
  // that did not, lambda *= non_finite_increase after a non-finite one.
  double lambda_decrease = 3;      // > 1
  double min_lambda = 1e-9;        // > 0
  double lambda_increase = 4;      // > 1
  double non_finite_increase = 10; // > 1
  // A trial of equal cost counts as lowering it (the sheen's line search).
  bool accept_equal_cost = false;

  // Throws std::invalid_argument naming the field, its value and the rule.
  void Check() const;
};

// The functor's answer to a trial that lowered the cost.
enum class StepVerdict {
  kTaken,           // taken; go on
  kTakenConverged,  // taken; the fit has converged
  kConverged,       // not taken (the change is below the tolerances); the fit has converged
};

// No strings: the loop runs once per pixel.
struct LevenbergMarquardtSummary {
  enum class Termination {
    kConverged,            // the functor's tolerances (StepVerdict)
    kMaxIterations,        // max_iterations linearizations
    kNoDescent,            // max_step_attempts trials without a lower cost
    kNonFiniteStep,        // kFixedWithBacktracking: the damped system gave no finite step
    kLinearizationFailed,  // Linearize returned false
  };
  Termination termination = Termination::kMaxIterations;
  int iterations = 0;    // linearizations
  int steps_taken = 0;   // trials the functor took
  double cost = 0;       // at the last linearization
  double lambda = 0;     // the damping at the end
};

// The step of the damped normal equations (J^T W J + lambda D) step = -J^T W r.
template <typename Hessian, typename Vector>
Vector DampedStep(const Hessian& jtj, const Vector& jtr, double lambda, double min_diagonal) {
  Hessian damped = jtj;
  for (int i = 0; i < damped.rows(); ++i) damped(i, i) += lambda * std::max(jtj(i, i), min_diagonal);
  return damped.ldlt().solve(-jtr);
}

// Minimizes the functor's cost from its current parameters (which it holds
// and updates in Take). Every floating-point step is the fits' own: the
// damping, one LDLT solve of the damped system, the comparison of costs.
template <typename Functor>
LevenbergMarquardtSummary SolveLevenbergMarquardt(const LevenbergMarquardtOptions& options, Functor* functor) {
  using Summary = LevenbergMarquardtSummary;
  using Hessian = typename Functor::Hessian;
  using Vector = typename Functor::Vector;
  options.Check();
  const bool backtrack = options.damping == LevenbergMarquardtOptions::Damping::kFixedWithBacktracking;
  Summary summary;
  double lambda = options.initial_lambda;
  Hessian jtj;
  Vector jtr;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    double cost = 0;
    if (!functor->Linearize(&jtj, &jtr, &cost)) {
      summary.termination = Summary::Termination::kLinearizationFailed;
      break;
    }
    ++summary.iterations;
    summary.cost = cost;
    bool lowered = false;
    StepVerdict verdict = StepVerdict::kTaken;
    Vector step = DampedStep(jtj, jtr, lambda, options.min_diagonal);
    for (int attempt = 0; attempt < options.max_step_attempts && !lowered; ++attempt) {
      if (attempt > 0) {
        if (backtrack) {
          step *= 0.5;
        } else {
          step = DampedStep(jtj, jtr, lambda, options.min_diagonal);
        }
      }
      double trial_cost = 0;
      if (!step.allFinite() || !functor->Trial(step, &trial_cost)) {
        if (backtrack) {
          summary.termination = Summary::Termination::kNonFiniteStep;
          summary.lambda = lambda;
          return summary;
        }
        lambda *= options.non_finite_increase;
        continue;
      }
      lowered = std::isfinite(trial_cost) &&
                (trial_cost < cost || (options.accept_equal_cost && trial_cost == cost));
      if (lowered) {
        verdict = functor->Take(cost, trial_cost);
        summary.steps_taken += verdict != StepVerdict::kConverged;
        if (!backtrack) lambda = std::max(lambda / options.lambda_decrease, options.min_lambda);
      } else if (!backtrack) {
        lambda *= options.lambda_increase;
      }
    }
    if (!lowered || verdict != StepVerdict::kTaken) {
      summary.termination = lowered ? Summary::Termination::kConverged : Summary::Termination::kNoDescent;
      break;
    }
  }
  summary.lambda = lambda;
  return summary;
}

}  // namespace scanbench
