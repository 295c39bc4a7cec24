#include "app/gui/controller_runner.h"

#include <QCoreApplication>
#include <QDeadlineTimer>
#include <QThread>

#include <algorithm>
#include <cmath>
#include <exception>

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
                             DoneCallback done) {
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
  auto last = std::make_shared<ProgressReport>(ProgressReport{{}, {}, -1});
  controller_->SetProgressCallback([this, last, hook = worker_hook_](const ProgressReport& report) {
    if (report.stage == last->stage && report.detail == last->detail &&
        std::abs(report.fraction - last->fraction) < 0.005 && report.fraction < 1) {
      return;
    }
    *last = report;
    // Emitted on the worker: Qt queues it to the runner's (UI) thread.
    const QString stage = QString::fromStdString(report.stage);
    emit Progress(stage, report.fraction, QString::fromStdString(report.detail));
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

bool ControllerRunner::Wait(int timeout_ms) {
  QDeadlineTimer deadline(timeout_ms);
  while (busy() && !deadline.hasExpired()) {
    QCoreApplication::processEvents(QEventLoop::AllEvents, 20);
    QThread::msleep(2);
  }
  return !busy();
}

}  // namespace scanbench
