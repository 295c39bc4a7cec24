// Runs one BaseController at a time on a worker thread, so that the UI never
// waits for a long job. Progress and the outcome arrive as signals on the
// thread that owns the runner (the UI thread); Cancel() asks the controller
// to stop at its next check (it then ends with Cancelled).
#pragma once

#include <QObject>
#include <QString>

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "app/controllers/base_controller.h"
#include "core/job_progress.h"

class QThread;

namespace scanbench {

// A short device job (connect, light an LED) run through the same runner, so
// that a slow serial reply never freezes the window either.
class FunctionController : public BaseController {
 public:
  explicit FunctionController(std::function<void()> work) : work_(std::move(work)) {}
  void Run() override { work_(); }

 private:
  std::function<void()> work_;
};

// For a label: "solve sessions: 15 % — 3/20 done, ETA 01:12"; the percentage
// is left out for a negative fraction, the dash and detail for an empty one.
QString ProgressText(const QString& stage, const QString& detail, double fraction = -1);

class ControllerRunner : public QObject {
  Q_OBJECT

 public:
  enum class Outcome { kSucceeded, kCancelled, kFailed };
  // Called on the UI thread once the job has ended, before Finished.
  using DoneCallback = std::function<void(Outcome outcome, const QString& message)>;

  explicit ControllerRunner(QObject* parent = nullptr);
  ~ControllerRunner() override;  // cancels a running job and waits for it

  // Starts `controller` under `job_name` ("Capture", "Solve"); false (and
  // nothing started) while another job runs. `plan`: the stages it reports
  // (app/controllers/progress_plans.h), for the job's one bar; empty = each
  // stage takes half of what is left.
  bool Start(std::shared_ptr<BaseController> controller, const QString& job_name, DoneCallback done = {},
             std::vector<ProgressStagePlan> plan = {});
  bool busy() const { return thread_ != nullptr; }
  const QString& job_name() const { return job_name_; }
  // The wall time of the running job, or of the last one once it has ended.
  double job_seconds() const;
  void Cancel();
  // Held by every job for its whole run, on its worker thread. Work that must
  // not overlap a job (the live view's preview fetch: the camera has one
  // owner at a time) try-locks it and skips its turn when a job holds it; a
  // job starting meanwhile waits for that work to end.
  // Shared, so that such work may outlive the runner at shutdown.
  std::shared_ptr<std::mutex> device_mutex() const { return device_mutex_; }
  // Called on the worker thread right after each Progress signal was sent
  // (same thread as the controller's progress report), with the signal's
  // stage and fraction: a test can hold the job at an exact point until the
  // UI has acted on that signal.
  using WorkerProgressHook = std::function<void(const QString& stage, double fraction)>;
  void SetWorkerProgressHook(WorkerProgressHook hook) { worker_hook_ = std::move(hook); }
  // Blocks until the running job has ended and its callbacks ran (tests,
  // shutdown); true if nothing runs any more.
  bool Wait(int timeout_ms);

 signals:
  void Started(const QString& job_name);
  // fraction of `stage` done, [0, 1]; the controller's stage text split by
  // SplitStageText (a slot may take the first two arguments only). Sent for
  // a new stage or detail and for each visible step (half a percent).
  void Progress(const QString& stage, double fraction, const QString& detail);
  // The same report as one bar for the whole job (JobProgress over the
  // plan given to Start): `fraction` of the job, never decreasing, and
  // its text ("solve (stage 4 of 7): 12 %"). Sent with each Progress.
  void JobProgressChanged(double fraction, const QString& text);
  void Finished(scanbench::ControllerRunner::Outcome outcome, const QString& message);

 private:
  void OnThreadFinished();

  QThread* thread_ = nullptr;
  std::shared_ptr<BaseController> controller_;
  QString job_name_;
  std::chrono::steady_clock::time_point job_start_{};
  std::chrono::steady_clock::time_point job_end_{};
  DoneCallback done_;
  std::shared_ptr<std::mutex> device_mutex_ = std::make_shared<std::mutex>();
  WorkerProgressHook worker_hook_;  // copied into each job at Start
  // Written by the worker before its thread ends, read after.
  Outcome outcome_ = Outcome::kSucceeded;
  QString message_;
};

}  // namespace scanbench
