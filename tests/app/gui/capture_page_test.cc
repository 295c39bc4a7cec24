// The Capture page's state (issue #36 items 3, 6 and 8): why Start capture is
// off (no bench, a folder that is not empty, a complete session); a new
// folder clears the previous session's thumbnails and summary; one bar per
// job that never moves back (solve while capturing: the capture's stages,
// then the solve's) and an end that says finished, on the page and in the
// status bar; the Devices page's LED buttons after the capture turned them off.
#include <QCheckBox>
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
    window_->ShowPage(MainWindow::kDevicesPage);
    Find<QSpinBox>("simWidth")->setValue(160);
    Find<QSpinBox>("simHeight")->setValue(106);
    QCOMPARE(ClickAndWait("connectButton", 60000), ControllerRunner::Outcome::kSucceeded);
    window_->ShowPage(MainWindow::kCapturePage);
    QVERIFY(Find<QPushButton>("startCapture")->isEnabled());
    QVERIFY2(Blocked().isEmpty(), qPrintable(Blocked()));
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
};

}  // namespace scanbench

QTEST_MAIN(scanbench::CapturePageTest)
#include "capture_page_test.moc"
