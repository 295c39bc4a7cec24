// The runner keeps jobs off the UI thread: progress arrives there as
// signals (stage and detail apart), Cancel ends a job through RequestStop,
// failures carry the message.
#include "app/gui/controller_runner.h"

#include <QCoreApplication>
#include <QElapsedTimer>
#include <QStringList>
#include <QTest>
#include <QThread>

#include <stdexcept>

namespace scanbench {

namespace {

// Reports `steps` progress points, pausing between them, checking the stop flag.
class SteppingController : public BaseController {
 public:
  SteppingController(int steps, int pause_ms) : steps_(steps), pause_ms_(pause_ms) {}
  void Run() override {
    worker_thread = QThread::currentThread();
    for (int i = 0; i <= steps_; ++i) {
      ThrowIfStopRequested("stepping");
      ReportProgress("stepping", double(i) / steps_);
      QThread::msleep(pause_ms_);
    }
  }
  QThread* worker_thread = nullptr;

 private:
  int steps_;
  int pause_ms_;
};

// Reports the batch controller's way: a stage with a detail that changes per
// item while the fraction barely moves.
class DetailedController : public BaseController {
 public:
  void Run() override {
    ReportProgress("check results", 0.001, "1/3");
    ReportProgress("check results", 0.002, "2/3");
    ReportProgress("solve sessions", 0.15, "3/20 done, ETA 01:12");
    ReportProgress("write summary", 1.0);
  }
};

}  // namespace

class ControllerRunnerTest : public QObject {
  Q_OBJECT

 private slots:
  void ProgressArrivesOnTheUiThread() {
    ControllerRunner runner;
    auto job = std::make_shared<SteppingController>(20, 5);
    int calls = 0;
    bool all_on_ui_thread = true;
    double last = -1;
    connect(&runner, &ControllerRunner::Progress, this, [&](const QString& stage, double fraction) {
      ++calls;
      all_on_ui_thread = all_on_ui_thread && QThread::currentThread() == QCoreApplication::instance()->thread();
      QCOMPARE(stage, QStringLiteral("stepping"));
      last = fraction;
    });
    ControllerRunner::Outcome outcome = ControllerRunner::Outcome::kFailed;
    int finished = 0;
    connect(&runner, &ControllerRunner::Finished, this, [&](ControllerRunner::Outcome result, const QString&) {
      outcome = result;
      ++finished;
      QVERIFY(!runner.busy());  // a new job may start from the Finished slot
    });
    QVERIFY(runner.Start(job, "Stepping"));
    QVERIFY(runner.busy());
    QVERIFY(runner.Wait(10000));
    QCOMPARE(finished, 1);
    QCOMPARE(outcome, ControllerRunner::Outcome::kSucceeded);
    QVERIFY(job->worker_thread != nullptr);
    QVERIFY(job->worker_thread != QCoreApplication::instance()->thread());
    QVERIFY(all_on_ui_thread);
    QVERIFY(calls >= 10);
    QCOMPARE(last, 1.0);
  }

  void StageDetailArrivesApartAndIsShownAfterTheStage() {
    ControllerRunner runner;
    QStringList shown;
    QStringList hooked;
    runner.SetWorkerProgressHook([&](const QString& stage, double) { hooked << stage; });
    connect(&runner, &ControllerRunner::Progress, this,
            [&](const QString& stage, double fraction, const QString& detail) {
              shown << ProgressText(stage, detail, fraction);
            });
    QVERIFY(runner.Start(std::make_shared<DetailedController>(), "Batch"));
    QVERIFY(runner.Wait(5000));
    // A new detail is sent even when the fraction moved less than the step.
    const QStringList expected = {"check results: 0 % — 1/3", "check results: 0 % — 2/3",
                                  "solve sessions: 15 % — 3/20 done, ETA 01:12", "write summary: 100 %"};
    QCOMPARE(shown, expected);
    QCOMPARE(hooked, QStringList({"check results", "check results", "solve sessions", "write summary"}));
  }

  void ProgressTextJoinsStageFractionAndDetail() {
    QCOMPARE(ProgressText("solve", "3/20 done", -1), QStringLiteral("solve — 3/20 done"));
    QCOMPARE(ProgressText("solve", "", 0.5), QStringLiteral("solve: 50 %"));
    QCOMPARE(ProgressText("solve", "", 1.7), QStringLiteral("solve: 100 %"));
  }

  void CancelEndsTheJobWithJobCancelled() {
    ControllerRunner runner;
    // 100 s if never cancelled.
    auto job = std::make_shared<SteppingController>(10000, 10);
    ControllerRunner::Outcome outcome = ControllerRunner::Outcome::kSucceeded;
    QString message;
    QVERIFY(runner.Start(job, "Long", [&](ControllerRunner::Outcome result, const QString& text) {
      outcome = result;
      message = text;
    }));
    QTest::qWait(100);
    QElapsedTimer timer;
    timer.start();
    runner.Cancel();
    QVERIFY(runner.Wait(5000));
    QVERIFY(timer.elapsed() < 2000);
    QCOMPARE(outcome, ControllerRunner::Outcome::kCancelled);
    QVERIFY2(message.contains("stepping"), qPrintable(message));
  }

  void FailureCarriesTheMessage() {
    ControllerRunner runner;
    ControllerRunner::Outcome outcome = ControllerRunner::Outcome::kSucceeded;
    QString message;
    connect(&runner, &ControllerRunner::Finished, this, [&](ControllerRunner::Outcome result, const QString& text) {
      outcome = result;
      message = text;
    });
    QVERIFY(runner.Start(std::make_shared<FunctionController>(
                             [] { throw std::runtime_error("frames/led_03.dng: truncated; capture it again"); }),
                         "Broken"));
    QVERIFY(runner.Wait(5000));
    QCOMPARE(outcome, ControllerRunner::Outcome::kFailed);
    QCOMPARE(message, QStringLiteral("frames/led_03.dng: truncated; capture it again"));
  }

  void OneJobAtATime() {
    ControllerRunner runner;
    QVERIFY(runner.Start(std::make_shared<SteppingController>(10, 10), "First"));
    QVERIFY(!runner.Start(std::make_shared<SteppingController>(1, 1), "Second"));
    QCOMPARE(runner.job_name(), QStringLiteral("First"));
    QVERIFY(runner.Wait(5000));
    QVERIFY(runner.Start(std::make_shared<SteppingController>(1, 1), "Second"));
    QVERIFY(runner.Wait(5000));
  }

  void DestructionCancelsARunningJob() {
    auto job = std::make_shared<SteppingController>(10000, 10);
    QElapsedTimer timer;
    timer.start();
    {
      ControllerRunner runner;
      QVERIFY(runner.Start(job, "Long"));
      QTest::qWait(50);
    }
    QVERIFY(timer.elapsed() < 3000);
    QVERIFY(job->IsStopRequested());
  }
};

}  // namespace scanbench

QTEST_MAIN(scanbench::ControllerRunnerTest)
#include "controller_runner_test.moc"
