// Runs one BaseController at a time on a worker thread, so that the UI never
// waits for a long job. Progress and the outcome arrive as signals on the
// thread that owns the runner (the UI thread); Cancel() asks the controller
// to stop at its next check (it then ends with JobCancelled).
#pragma once

#include <QObject>
#include <QString>

#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "app/controllers/base_controller.h"

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

class ControllerRunner : public QObject {
  Q_OBJECT

 public:
  enum class Outcome { kSucceeded, kCancelled, kFailed };
  // Called on the UI thread once the job has ended, before Finished.
  using DoneCallback = std::function<void(Outcome outcome, const QString& message)>;

  explicit ControllerRunner(QObject* parent = nullptr);
  ~ControllerRunner() override;  // cancels a running job and waits for it

  // Starts `controller` under `job_name` ("Capture", "Solve"); false (and
  // nothing started) while another job runs.
  bool Start(std::shared_ptr<BaseController> controller, const QString& job_name, DoneCallback done = {});
  bool busy() const { return thread_ != nullptr; }
  const QString& job_name() const { return job_name_; }
  void Cancel();
  // Blocks until the running job has ended and its callbacks ran (tests,
  // shutdown); true if nothing runs any more.
  bool Wait(int timeout_ms);

 signals:
  void Started(const QString& job_name);
  // fraction of `stage` done, [0, 1].
  void Progress(const QString& stage, double fraction);
  void Finished(scanbench::ControllerRunner::Outcome outcome, const QString& message);

 private:
  void OnThreadFinished();

  QThread* thread_ = nullptr;
  std::shared_ptr<BaseController> controller_;
  QString job_name_;
  DoneCallback done_;
  // Written by the worker before its thread ends, read after.
  Outcome outcome_ = Outcome::kSucceeded;
  QString message_;
};

}  // namespace scanbench
