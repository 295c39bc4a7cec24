// The Capture page's state (issue #36 items 3, 6 and 8): why Start capture is
// off (no bench, a folder that is not empty, a complete session); a new
// folder clears the previous session's thumbnails and summary; one bar per
// job that never moves back (solve while capturing: the capture's stages,
// then the solve's) and an end that says finished, on the page and in the
// status bar; the Devices page's LED buttons after the capture turned them off;
// the exposure (issue #36 item 13): the simulated camera's own values, off
// with the reason without a camera, and the values chosen reach the camera
// and session.json.
#include <QCheckBox>
#include <QComboBox>
#include <QLabel>
#include <QLineEdit>
#include <QProgressBar>
#include <QPushButton>
#include <QRegularExpression>
#include <QSettings>
#include <QSpinBox>
#include <QTemporaryDir>
#include <QTest>

#include <filesystem>
#include <fstream>

#include "app/devices/camera/simulated_camera.h"
#include "app/gui/bench.h"
#include "app/gui/controller_runner.h"
#include "app/gui/devices_page.h"
#include "app/gui/main_window.h"
#include "tests/app/gui/widget_test_util.h"
#include "app/session/session.h"

namespace scanbench {
namespace fs = std::filesystem;

class CapturePageTest : public QObject {
  Q_OBJECT

 private:
  template <typename T>
  T* Find(const char* name) {
    return testing::FindWidget<T>(*window_, name);
  }
  ControllerRunner::Outcome ClickAndWait(const char* button, int timeout_ms = 120000) {
    return testing::ClickAndWait(*window_, button, timeout_ms);
  }
  void TypeFolder(const QString& folder) {
    auto* field = Find<QLineEdit>("sessionFolder");
    field->clear();
    QTest::keyClicks(field, folder);
  }
  int Thumbnails() { return window_->findChildren<QLabel*>(QRegularExpression("^thumbnail_")).size(); }
  QString Blocked() {
    auto* label = Find<QLabel>("captureBlocked");
    return label->isHidden() ? QString() : label->text();
  }

  std::unique_ptr<MainWindow> window_;
  QTemporaryDir work_;

 private slots:
  void initTestCase() {
    QCoreApplication::setOrganizationName("scanbench");
    QCoreApplication::setApplicationName("scanbench-capture-page-test");
    QSettings().clear();
    window_ = std::make_unique<MainWindow>();
    window_->resize(1200, 800);
    window_->show();
  }
  void cleanupTestCase() { window_.reset(); }

  // Start capture greyed out without a word while the bench was disconnected.
  void SaysWhyStartIsOffWithoutABench() {
    window_->ShowPage(MainWindow::kCapturePage);
    TypeFolder(work_.filePath("first"));
    QVERIFY(!Find<QPushButton>("startCapture")->isEnabled());
    QVERIFY2(Blocked().contains("No bench connected"), qPrintable(Blocked()));
    // No camera, no exposure to choose: the boxes are off and say why.
    for (const char* name : {"isoChoice", "shutterChoice", "apertureChoice"}) {
      QVERIFY(!Find<QComboBox>(name)->isEnabled());
      QCOMPARE(Find<QComboBox>(name)->count(), 1);
    }
    const QString no_camera = Find<QLabel>("exposureNote")->text();
    QVERIFY2(!Find<QLabel>("exposureNote")->isHidden() && no_camera.contains("No camera connected"),
             qPrintable(no_camera));
    window_->ShowPage(MainWindow::kDevicesPage);
    Find<QSpinBox>("simWidth")->setValue(160);
    Find<QSpinBox>("simHeight")->setValue(106);
    QCOMPARE(ClickAndWait("connectButton", 60000), ControllerRunner::Outcome::kSucceeded);
    window_->ShowPage(MainWindow::kCapturePage);
    QVERIFY(Find<QPushButton>("startCapture")->isEnabled());
    QVERIFY2(Blocked().isEmpty(), qPrintable(Blocked()));
    // Connected: the simulated camera's own values, "leave the camera's" first and chosen.
    const std::pair<const char*, CameraSetting> boxes[] = {{"isoChoice", CameraSetting::kIso},
                                                           {"shutterChoice", CameraSetting::kShutter},
                                                           {"apertureChoice", CameraSetting::kAperture}};
    for (const auto& [name, setting] : boxes) {
      auto* box = Find<QComboBox>(name);
      QVERIFY(box->isEnabled());
      QCOMPARE(box->currentIndex(), 0);
      QCOMPARE(box->currentData().toString(), QString());
      const std::vector<std::string>& values = SimulatedCameraChoices(setting);
      QCOMPARE(box->count(), int(values.size()) + 1);
      for (size_t k = 0; k < values.size(); ++k) QCOMPARE(box->itemText(int(k) + 1).toStdString(), values[k]);
    }
    QVERIFY(Find<QLabel>("exposureNote")->isHidden());
  }

  // A folder that holds other files is refused, naming them (the CLI's rule).
  void RefusesAFolderThatIsNotEmpty() {
    const fs::path other = work_.filePath("other").toStdString();
    fs::create_directories(other);
    std::ofstream(other / "notes.txt") << "x";
    TypeFolder(QString::fromStdString(other.string()));
    QVERIFY(!Find<QPushButton>("startCapture")->isEnabled());
    QVERIFY(!Find<QPushButton>("resumeCapture")->isEnabled());
    QVERIFY2(Blocked().contains("is not empty") && Blocked().contains("notes.txt"), qPrintable(Blocked()));
  }

  // Solve while capturing (the default): one bar that only moves forward
  // through the capture's and the solve's stages, and a finished end.
  void OneBarPerJobAndAFinishedEnd() {
    QCOMPARE(ClickAndWait("led3", 10000), ControllerRunner::Outcome::kSucceeded);
    window_->ShowPage(MainWindow::kCapturePage);
    TypeFolder(work_.filePath("first"));
    QTest::keyClicks(Find<QLineEdit>("sampleName"), "twill");
    Find<QCheckBox>("checkExposure")->setChecked(false);
    QVERIFY(Find<QCheckBox>("solveWhileCapturing")->isChecked());
    std::vector<double> fractions;
    QStringList texts;
    auto watch = connect(window_->runner(), &ControllerRunner::JobProgressChanged, this,
                         [&](double fraction, const QString& text) {
                           fractions.push_back(fraction);
                           texts << text;
                         });
    int page_bar_backwards = 0, last_page_value = 0;
    auto page = connect(window_->runner(), &ControllerRunner::JobProgressChanged, this, [&] {
      const int value = Find<QProgressBar>("captureProgress")->value();
      page_bar_backwards += value < last_page_value;
      last_page_value = value;
    });
    QCOMPARE(ClickAndWait("startCapture"), ControllerRunner::Outcome::kSucceeded);
    disconnect(watch);
    disconnect(page);
    QVERIFY(fractions.size() > 10);
    for (size_t i = 1; i < fractions.size(); ++i) {
      QVERIFY2(fractions[i] >= fractions[i - 1], qPrintable(texts[int(i - 1)] + " -> " + texts[int(i)]));
    }
    QCOMPARE(page_bar_backwards, 0);
    QVERIFY2(texts.filter(QRegularExpression("^capture \\(stage 1 of \\d\\)")).size() > 0, qPrintable(texts.join("\n")));
    QVERIFY2(texts.filter(QRegularExpression("^solve \\(stage \\d of \\d\\)")).size() > 0, qPrintable(texts.join("\n")));
    const QString stage = Find<QLabel>("captureStage")->text();
    QVERIFY2(stage.startsWith("Capture finished in"), qPrintable(stage));
    QCOMPARE(Find<QProgressBar>("captureProgress")->value(), 1000);
    const QString job = Find<QLabel>("jobStatus")->text();
    QVERIFY2(job.startsWith("Capture finished in"), qPrintable(job));
    QCOMPARE(Find<QProgressBar>("jobProgress")->value(), 1000);
    QTRY_COMPARE_WITH_TIMEOUT(Thumbnails(), 11, 5000);
    QVERIFY(!Find<QLabel>("captureStatus")->text().isEmpty());

    // The capture turned every LED off: the Devices page says so.
    QVERIFY(!window_->findChild<QPushButton*>("led3")->isChecked());
    const QString devices = window_->findChild<QLabel*>("devicesStatus")->text();
    QVERIFY2(devices.contains("All LEDs off (Capture turned them off)"), qPrintable(devices));
  }

  // A new folder typed: the previous session's thumbnails and summary go;
  // the complete session typed again shows its frames, and Start capture
  // says why it is off.
  void ANewFolderClearsThePreviousSession() {
    TypeFolder(work_.filePath("second"));
    QCOMPARE(Thumbnails(), 0);
    QVERIFY(Find<QLabel>("captureStatus")->text().isEmpty());
    QVERIFY(Find<QLabel>("captureStage")->text().isEmpty());
    QCOMPARE(Find<QProgressBar>("captureProgress")->value(), 0);
    QVERIFY(Find<QPushButton>("startCapture")->isEnabled());

    TypeFolder(work_.filePath("first"));
    QTRY_COMPARE_WITH_TIMEOUT(Thumbnails(), 11, 5000);
    QVERIFY(!Find<QPushButton>("startCapture")->isEnabled());
    QVERIFY(!Find<QPushButton>("resumeCapture")->isEnabled());
    QVERIFY(Find<QPushButton>("solveCaptured")->isEnabled());
    QVERIFY2(Blocked().contains("holds a complete session of 'twill'"), qPrintable(Blocked()));
  }

  // The exposure chosen is the one the camera takes the frames with, as
  // `capture --iso 200 --exposure-time 0.004 --f-number 5.6` would; the
  // capture before it left the camera's own (ISO 100, 1/60 s, f/8).
  void CarriesTheChosenExposure() {
    const Session before = LoadSession(work_.filePath("first").toStdString());
    QCOMPARE(before.camera.iso, 100.0);
    QCOMPARE(before.camera.exposure_time_s, 1.0 / 60);
    QCOMPARE(before.camera.f_number, 8.0);

    TypeFolder(work_.filePath("exposed"));
    Find<QCheckBox>("solveWhileCapturing")->setChecked(false);
    for (auto [name, value] : {std::pair{"isoChoice", "200"}, std::pair{"shutterChoice", "1/250"},
                               std::pair{"apertureChoice", "f/5.6"}}) {
      auto* box = Find<QComboBox>(name);
      const int index = box->findData(QString::fromLatin1(value));
      QVERIFY2(index > 0, value);
      box->setCurrentIndex(index);
    }
    QCOMPARE(ClickAndWait("startCapture"), ControllerRunner::Outcome::kSucceeded);
    Find<QCheckBox>("solveWhileCapturing")->setChecked(true);
    const Session session = LoadSession(work_.filePath("exposed").toStdString());
    QCOMPARE(session.camera.iso, 200.0);
    QCOMPARE(session.camera.exposure_time_s, 1.0 / 250);
    QCOMPARE(session.camera.f_number, 5.6);
    QCOMPARE(session.frames.size(), size_t(11));
    for (const FrameRecord& frame : session.frames) QCOMPARE(frame.exposure_time_s, 1.0 / 250);
    Camera& camera = window_->devices()->bench()->camera();
    QCOMPARE(camera.GetSetting(CameraSetting::kIso).current, std::string("200"));
    QCOMPARE(camera.GetSetting(CameraSetting::kShutter).current, std::string("1/250"));
    QCOMPARE(camera.GetSetting(CameraSetting::kAperture).current, std::string("f/5.6"));
    // The choice stays for the next capture, and over a reconnect.
    QCOMPARE(Find<QComboBox>("isoChoice")->currentData().toString(), QStringLiteral("200"));
    window_->ShowPage(MainWindow::kDevicesPage);
    QCOMPARE(ClickAndWait("connectButton", 60000), ControllerRunner::Outcome::kSucceeded);
    QCOMPARE(Find<QComboBox>("shutterChoice")->currentData().toString(), QStringLiteral("1/250"));
    QVERIFY(Find<QComboBox>("shutterChoice")->isEnabled());
  }
};

}  // namespace scanbench

QTEST_MAIN(scanbench::CapturePageTest)
#include "capture_page_test.moc"
