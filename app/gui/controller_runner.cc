#include "app/gui/controller_runner.h"

#include <QCoreApplication>
#include <QDeadlineTimer>
#include <QThread>

#include <algorithm>
#include <cmath>
#include <exception>
#include <mutex>

#include "core/job_progress.h"

namespace scanbench {

QString ProgressText(const QString& stage, const QString& detail, double fraction) {
  QString text = stage;
  if (fraction >= 0) text += QStringLiteral(": %1 %").arg(int(std::clamp(fraction, 0.0, 1.0) * 100));
  if (!detail.isEmpty()) text += QStringLiteral(" — ") + detail;
  return text;
}

ControllerRunner::ControllerRunner(QObject* parent) : QObject(parent) {}

ControllerRunner::~ControllerRunner() {
  if (thread_ == nullptr) return;
  controller_->RequestStop();
  thread_->wait();
  delete thread_;
}

bool ControllerRunner::Start(std::shared_ptr<BaseController> controller, const QString& job_name,
                             DoneCallback done, std::vector<ProgressStagePlan> plan) {
  if (busy() || !controller) return false;
  controller_ = std::move(controller);
  job_name_ = job_name;
  done_ = std::move(done);
  outcome_ = Outcome::kSucceeded;
  message_.clear();

  // Progress comes from the worker thread, often thousands of times per
  // stage: only a new stage or detail or a visible step (half a percent) is
  // sent, so the UI thread's queue never floods (a detail changes per item
  // done, as the batch's "3/20 done", not per pixel).
  // Reports may come from more than one of the job's threads: the job's
  // bar and the throttle's state are shared under one mutex.
  struct Shared {
    std::mutex mutex;
    ProgressReport last{{}, {}, -1};
    JobProgress job;
  };
  auto shared = std::make_shared<Shared>();
  shared->job = JobProgress(std::move(plan));
  job_start_ = std::chrono::steady_clock::now();
  job_end_ = {};
  controller_->SetProgressCallback([this, shared, hook = worker_hook_](const ProgressReport& report) {
    const QString stage = QString::fromStdString(report.stage);
    {
      // Sent under the lock, so that the UI gets them in the order the job's bar moved.
      const std::lock_guard lock(shared->mutex);
      shared->job.Update(report);
      const ProgressReport& last = shared->last;
      if (report.stage == last.stage && report.detail == last.detail &&
          std::abs(report.fraction - last.fraction) < 0.005 && report.fraction < 1) {
        return;
      }
      shared->last = report;
      // Emitted on the worker: Qt queues them to the runner's (UI) thread.
      emit Progress(stage, report.fraction, QString::fromStdString(report.detail));
      emit JobProgressChanged(shared->job.fraction(), QString::fromStdString(shared->job.Text()));
    }
    if (hook) hook(stage, report.fraction);
  });

  BaseController* job = controller_.get();
  thread_ = QThread::create([this, job, devices = device_mutex_] {
    const std::lock_guard lock(*devices);
    try {
      job->Run();
      outcome_ = Outcome::kSucceeded;
    } catch (const Cancelled& cancelled) {
      outcome_ = Outcome::kCancelled;
      message_ = QString::fromStdString(cancelled.what());
    } catch (const std::exception& error) {
      outcome_ = Outcome::kFailed;
      message_ = QString::fromStdString(error.what());
    } catch (...) {
      outcome_ = Outcome::kFailed;
      message_ = QStringLiteral("unknown error");
    }
  });
  connect(thread_, &QThread::finished, this, &ControllerRunner::OnThreadFinished, Qt::QueuedConnection);
  emit Started(job_name_);
  thread_->start();
  return true;
}

void ControllerRunner::Cancel() {
  if (controller_) controller_->RequestStop();
}

void ControllerRunner::OnThreadFinished() {
  if (thread_ == nullptr) return;
  thread_->wait();
  thread_->deleteLater();
  thread_ = nullptr;
  job_end_ = std::chrono::steady_clock::now();
  // Drop the callback before the controller: it captures `this`.
  controller_->SetProgressCallback({});
  controller_.reset();
  const Outcome outcome = outcome_;
  const QString message = message_;
  DoneCallback done = std::move(done_);
  done_ = {};
  if (done) done(outcome, message);
  emit Finished(outcome, message);
}

double ControllerRunner::job_seconds() const {
  if (job_start_ == std::chrono::steady_clock::time_point{}) return 0;
  const auto end = busy() || job_end_ == std::chrono::steady_clock::time_point{} ? std::chrono::steady_clock::now()
                                                                                 : job_end_;
  return std::chrono::duration<double>(end - job_start_).count();
}

bool ControllerRunner::Wait(int timeout_ms) {
  QDeadlineTimer deadline(timeout_ms);
  while (busy() && !deadline.hasExpired()) {
    QCoreApplication::processEvents(QEventLoop::AllEvents, 20);
    QThread::msleep(2);
  }
  return !busy();
}

}  // namespace scanbench
