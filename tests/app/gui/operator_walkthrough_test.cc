// The operator's flow on the simulated bench, through the real MainWindow
// (issue #36's done-when): connect the bench on the Devices page, capture a
// session into a new folder on the Capture page (solved while capturing),
// the result opened on the Results page, every map shown, and the result
// exported through the export dialog. After each step no page shows an error,
// the status bar and the page's own progress say that step finished (not
// "Idle" beside a full bar, not a running stage's "…: 100 %", not an earlier
// step's text), and the step's files are there.
#include <QCheckBox>
#include <QComboBox>
#include <QFile>
#include <QJsonDocument>
#include <QJsonObject>
#include <QLabel>
#include <QLineEdit>
#include <QPlainTextEdit>
#include <QProgressBar>
#include <QPushButton>
#include <QRegularExpression>
#include <QSettings>
#include <QSpinBox>
#include <QTabWidget>
#include <QTemporaryDir>
#include <QTest>
#include <QTextBrowser>
#include <QTreeWidget>

#include <filesystem>

#include "app/gui/controller_runner.h"
#include "app/gui/devices_page.h"
#include "app/gui/export_dialog.h"
#include "app/gui/image_view.h"
#include "app/gui/main_window.h"
#include "app/gui/result_images.h"
#include "app/gui/results_page.h"
#include "app/session/session.h"
#include "tests/app/gui/widget_test_util.h"

namespace scanbench {
namespace fs = std::filesystem;

// The checks after a step; the step's slot ends at the first that fails.
#define CHECK_NO_ERROR_OR_STALE_STATE(step, job) \
  do {                                           \
    CheckNoErrorOrStaleState(step, job);         \
    if (QTest::currentTestFailed()) return;      \
  } while (false)

class OperatorWalkthroughTest : public QObject {
  Q_OBJECT

 private:
  template <typename T>
  T* Find(const char* name) {
    return testing::FindWidget<T>(*window_, name);
  }
  ControllerRunner::Outcome ClickAndWait(const char* button, int timeout_ms = 120000) {
    return testing::ClickAndWait(*window_, button, timeout_ms);
  }
  QString Text(const char* label) { return Find<QLabel>(label)->text(); }

  // What every page shows after a step: no status line marked as an error
  // (ShowStatusText's "error" property) and none that reads as a failure; no
  // line still showing a running stage ("write maps: 100 %") once no job
  // runs; the status bar at the step's end, never "Idle" beside a filled bar.
  // Every label of the window counts, on the pages not shown and in the
  // export dialog too: the operator sees them when they go there.
  void CheckNoErrorOrStaleState(const QString& step, const QString& job) {
    static const QRegularExpression failure(
        "failed|[Cc]annot |unreadable|holds no maps|stopped:|unknown \\(|is running");
    static const QRegularExpression running_stage(": \\d+ %( —|$)");
    QVERIFY2(!window_->runner()->busy(), qPrintable(step + ": a job still runs"));
    for (const QLabel* label : window_->findChildren<QLabel*>()) {
      const QString where = step + ": " + label->objectName() + " says \"" + label->text() + "\"";
      QVERIFY2(!label->property("error").toBool(), qPrintable(where));
      if (!label->objectName().isEmpty()) {
        QVERIFY2(!failure.match(label->text()).hasMatch(), qPrintable(where));
      }
      QVERIFY2(!running_stage.match(label->text()).hasMatch(), qPrintable(where));
    }
    const QString job_status = Text("jobStatus");
    const int job_bar = Find<QProgressBar>("jobProgress")->value();
    QVERIFY2(job_status != "Idle" || job_bar <= 0, qPrintable(step + ": Idle beside a bar at " +
                                                               QString::number(job_bar)));
    if (job.isEmpty()) return;
    QVERIFY2(job_status.startsWith(job + " finished in "), qPrintable(step + ": status bar says " + job_status));
    QCOMPARE(job_bar, 1000);
  }

  std::unique_ptr<MainWindow> window_;
  QTemporaryDir work_;
  fs::path session_;
  fs::path result_;

 private slots:
  void initTestCase() {
    QVERIFY(work_.isValid());
    QCoreApplication::setOrganizationName("scanbench");
    QCoreApplication::setApplicationName("scanbench-operator-walkthrough-test");
    QSettings().clear();
    window_ = std::make_unique<MainWindow>();
    window_->resize(1280, 820);
    window_->show();
    session_ = fs::path(work_.filePath("walk-01").toStdString());
  }
  void cleanupTestCase() { window_.reset(); }

  void StartsIdleWithoutErrors() {
    CHECK_NO_ERROR_OR_STALE_STATE("start", QString());
    QCOMPARE(Text("jobStatus"), QStringLiteral("Idle"));
  }

  // Devices: the simulated LED board and camera, small frames; an LED lit by hand.
  void ConnectsTheBench() {
    window_->ShowPage(MainWindow::kDevicesPage);
    QCOMPARE(Find<QComboBox>("lightsChoice")->currentData().toString(), QStringLiteral("simulated"));
    QCOMPARE(Find<QComboBox>("cameraChoice")->currentData().toString(), QStringLiteral("simulated"));
    Find<QSpinBox>("simWidth")->setValue(192);
    Find<QSpinBox>("simHeight")->setValue(128);
    QCOMPARE(ClickAndWait("connectButton", 60000), ControllerRunner::Outcome::kSucceeded);
    QVERIFY(window_->devices()->bench() != nullptr);
    QCOMPARE(Text("devicesStatus"), QStringLiteral("Connected."));
    QVERIFY2(Text("cameraInfo").contains("simulated camera"), qPrintable(Text("cameraInfo")));
    CHECK_NO_ERROR_OR_STALE_STATE("connect", "Connect");

    QCOMPARE(ClickAndWait("led3", 10000), ControllerRunner::Outcome::kSucceeded);
    QCOMPARE(Text("devicesStatus"), QStringLiteral("LED 3 lit, the others off."));
    QVERIFY(Find<QPushButton>("led3")->isChecked());
    CHECK_NO_ERROR_OR_STALE_STATE("LED 3", "LED 3 on");
  }

  // Capture: a new folder, the defaults (exposure check, solve while
  // capturing, the camera's own exposure); the result follows the last frame.
  void CapturesAndSolvesANewSession() {
    window_->ShowPage(MainWindow::kCapturePage);
    QVERIFY(!fs::exists(session_));
    QTest::keyClicks(Find<QLineEdit>("sessionFolder"), QString::fromStdString(session_.string()));
    QTest::keyClicks(Find<QLineEdit>("sampleName"), "walkthrough twill");
    QVERIFY(Find<QCheckBox>("checkExposure")->isChecked());
    QVERIFY(Find<QCheckBox>("solveWhileCapturing")->isChecked());
    QVERIFY(Find<QComboBox>("isoChoice")->isEnabled());
    QVERIFY(Find<QLabel>("captureBlocked")->isHidden());
    QVERIFY(Find<QPushButton>("startCapture")->isEnabled());
    QCOMPARE(Find<QProgressBar>("captureProgress")->value(), 0);
    CHECK_NO_ERROR_OR_STALE_STATE("before capture", "LED 3 on");

    QCOMPARE(ClickAndWait("startCapture"), ControllerRunner::Outcome::kSucceeded);
    QVERIFY2(Text("captureStage").startsWith("Capture finished in "), qPrintable(Text("captureStage")));
    QCOMPARE(Find<QProgressBar>("captureProgress")->value(), 1000);
    const QString status = Text("captureStatus");
    QVERIFY2(status.startsWith("Captured 11 frames (0 already there") && status.contains("Exposure check:") &&
                 status.contains(" Solved into "),
             qPrintable(status));
    // The capture turned the LEDs off: the Devices page no longer says LED 3.
    QCOMPARE(Text("devicesStatus"), QStringLiteral("All LEDs off (Capture turned them off)."));
    QVERIFY(!Find<QPushButton>("led3")->isChecked());
    // The finished session: Start capture says why it is off now.
    QVERIFY(!Find<QPushButton>("startCapture")->isEnabled());
    QVERIFY2(Text("captureBlocked").contains("holds a complete session"), qPrintable(Text("captureBlocked")));
    // A thumbnail per frame, each decoded.
    for (int slot = -1; slot < 10; ++slot) {
      auto* thumbnail = window_->findChild<QLabel*>(QStringLiteral("thumbnail_%1").arg(slot));
      QVERIFY2(thumbnail != nullptr, qPrintable(QStringLiteral("no thumbnail %1").arg(slot)));
      QTRY_VERIFY_WITH_TIMEOUT(!thumbnail->pixmap().isNull(), 10000);
    }
    QVERIFY(fs::exists(session_ / "session.json"));
    const Session session = LoadSession(session_);  // checksums verified
    QVERIFY(session.capture_complete);
    QCOMPARE(session.frames.size(), size_t(11));
    QCOMPARE(session.sample_name, std::string("walkthrough twill"));
    CHECK_NO_ERROR_OR_STALE_STATE("capture", "Capture");
  }

  // Results: the live solve's result, opened fitted, every map shown.
  void OpensTheResult() {
    QCOMPARE(Find<QTabWidget>("pages")->currentIndex(), int(MainWindow::kResultsPage));
    ResultsPage* results = window_->results();
    result_ = results->result_dir();
    QCOMPARE(result_.parent_path(), session_ / "results");
    QVERIFY2(Text("captureStatus").contains(QString::fromStdString(result_.string())), qPrintable(Text("captureStatus")));
    QCOMPARE(Find<QLineEdit>("resultFolder")->text().toStdString(), result_.string());
    for (const char* file : {"report.json", "summary.txt", "normal.exr", "normal.png", "albedo.exr",
                             "albedo_srgb.png", "status.png", "solved_mask.png", "confidence.exr", "specular.exr"}) {
      QVERIFY2(fs::is_regular_file(result_ / file) && fs::file_size(result_ / file) > 0, file);
    }
    QFile report(QString::fromStdString((result_ / "report.json").string()));
    QVERIFY(report.open(QIODevice::ReadOnly));
    QVERIFY(QJsonDocument::fromJson(report.readAll()).isObject());
    QVERIFY2(results->report()->toPlainText().contains("Photometric solve"),
             qPrintable(results->report()->toPlainText().left(200)));
    QVERIFY2(Text("resultAlbedoColor").startsWith("Albedo: linear_rec709"), qPrintable(Text("resultAlbedoColor")));
    QVERIFY(results->WaitForPixelProbe(30000));
    const QList<ResultLayer> layers = AvailableLayers(result_);
    QVERIFY(layers.size() >= 6);
    for (ResultLayer layer : layers) {
      const QString name = ResultLayerName(layer);
      QVERIFY2(results->ShowLayer(layer), qPrintable(name));
      QVERIFY(results->WaitForRelight(30000));
      QVERIFY2(Text("resultStatus").startsWith(name + " — "), qPrintable(name + ": " + Text("resultStatus")));
      QVERIFY2(!results->view()->image().isNull(), qPrintable(name));
      CHECK_NO_ERROR_OR_STALE_STATE("result, " + name, "Capture");
    }
    // The Sessions page lists the new session, complete, with its result.
    auto* list = Find<QTreeWidget>("sessionList");
    QCOMPARE(list->topLevelItemCount(), 1);
    QCOMPARE(list->topLevelItem(0)->text(3), QStringLiteral("complete"));
    QCOMPARE(list->topLevelItem(0)->text(4), QStringLiteral("1"));
  }

  // Export: through the dialog the Results page opens, its own Export button.
  void ExportsTheResult() {
    ExportDialog* dialog = window_->results()->OpenExportDialog();
    QVERIFY(dialog != nullptr);
    QCOMPARE(dialog->result_dir(), result_);
    const QString preset = dialog->preset()->currentText();
    QCOMPARE(ClickAndWait("startExport"), ControllerRunner::Outcome::kSucceeded);
    const QString status = dialog->findChild<QLabel*>("exportStatus")->text();
    QVERIFY2(status.startsWith("Exported ") && status.contains(" files into "), qPrintable(status));
    const QString stage = dialog->findChild<QLabel*>("exportStage")->text();
    QVERIFY2(stage.startsWith("Export finished in "), qPrintable(preset + ": " + stage));
    QCOMPARE(dialog->findChild<QProgressBar*>("exportProgress")->value(), 1000);
    QVERIFY(!dialog->findChild<QPlainTextEdit*>("exportSummary")->toPlainText().isEmpty());

    const fs::path export_dir = dialog->export_dir();
    QCOMPARE(export_dir.parent_path(), session_ / "exports");
    QVERIFY2(status.contains(QString::fromStdString(export_dir.string())), qPrintable(status));
    QFile manifest(QString::fromStdString((export_dir / "material.json").string()));
    QVERIFY(manifest.open(QIODevice::ReadOnly));
    const QJsonObject files = QJsonDocument::fromJson(manifest.readAll()).object()["files"].toObject();
    QVERIFY(files.size() >= 6);
    for (auto file = files.begin(); file != files.end(); ++file) {
      const QJsonObject entry = file.value().toObject();
      const fs::path path = export_dir / entry["path"].toString().toStdString();
      QVERIFY2(fs::is_regular_file(path), path.c_str());
      QCOMPARE(qint64(fs::file_size(path)), entry["bytes"].toInteger());
    }
    QVERIFY(files.contains("preview"));
    QVERIFY(!dialog->PreviewUrl().isEmpty());
    CHECK_NO_ERROR_OR_STALE_STATE("export", "Export");
  }
};

}  // namespace scanbench

QTEST_MAIN(scanbench::OperatorWalkthroughTest)
#include "operator_walkthrough_test.moc"
