// A full scan on the simulated bench through the real widgets: connect the
// simulated LED board and camera, light an LED, capture a small session
// (cancelled part-way and resumed), solve it, view every map, relight it,
// and re-solve it from the Sessions page. Asserts on the maps produced.
#include <QCheckBox>
#include <QComboBox>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QRegularExpression>
#include <QScopeGuard>
#include <QSemaphore>
#include <QSettings>
#include <QSpinBox>
#include <QTemporaryDir>
#include <QTest>
#include <QTreeWidget>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "app/gui/capture_page.h"
#include "app/gui/controller_runner.h"
#include "app/gui/devices_page.h"
#include "app/gui/image_view.h"
#include "app/gui/main_window.h"
#include "app/gui/results_page.h"
#include "app/gui/sessions_page.h"
#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/io/result_maps.h"
#include "app/session/session.h"

namespace scanbench {
namespace fs = std::filesystem;

class GuiScanTest : public QObject {
  Q_OBJECT

 private:
  template <typename T>
  T* Find(const char* name) {
    T* widget = window_->findChild<T*>(QString::fromLatin1(name));
    if (!widget) qFatal("no widget %s", name);
    return widget;
  }

  // Clicks through the real button and waits for the job it starts.
  ControllerRunner::Outcome ClickAndWait(const char* button, int timeout_ms = 120000) {
    ControllerRunner::Outcome outcome = ControllerRunner::Outcome::kFailed;
    auto connection = connect(window_->runner(), &ControllerRunner::Finished, this,
                              [&outcome, this](ControllerRunner::Outcome result, const QString& message) {
                                outcome = result;
                                last_message_ = message;
                              });
    QPushButton* widget = Find<QPushButton>(button);
    if (!widget->isEnabled()) qWarning("%s is disabled", button);
    QTest::mouseClick(widget, Qt::LeftButton);
    if (!window_->runner()->Wait(timeout_ms)) qWarning("%s: job still running", button);
    disconnect(connection);
    return outcome;
  }

  std::unique_ptr<MainWindow> window_;
  QTemporaryDir work_;
  QString last_message_;

 private slots:
  void initTestCase() {
    QVERIFY(work_.isValid());
    QCoreApplication::setOrganizationName("scanbench");
    QCoreApplication::setApplicationName("scanbench-gui-test");
    QSettings().clear();  // what an earlier run saved must not steer this one
    window_ = std::make_unique<MainWindow>();
    window_->resize(1200, 800);
    window_->show();
  }

  void cleanupTestCase() { window_.reset(); }

  void ConnectsTheSimulatedBench() {
    window_->ShowPage(MainWindow::kDevicesPage);
    QCOMPARE(Find<QComboBox>("lightsChoice")->currentData().toString(), QStringLiteral("simulated"));
    QCOMPARE(Find<QComboBox>("cameraChoice")->currentData().toString(), QStringLiteral("simulated"));
    Find<QSpinBox>("simWidth")->setValue(320);
    Find<QSpinBox>("simHeight")->setValue(212);
    QCOMPARE(ClickAndWait("connectButton", 60000), ControllerRunner::Outcome::kSucceeded);
    QVERIFY(window_->devices()->bench() != nullptr);
    const QString lights_info = Find<QLabel>("lightsInfo")->text();
    QVERIFY2(lights_info.contains("scanbench-leds"), qPrintable(lights_info));
    QVERIFY(Find<QLabel>("cameraInfo")->text().contains("simulated camera"));

    QCOMPARE(ClickAndWait("led3", 10000), ControllerRunner::Outcome::kSucceeded);
    QCOMPARE(window_->devices()->bench()->lights().Status().lit_led, std::optional<int>(3));
    QCOMPARE(ClickAndWait("allOff", 10000), ControllerRunner::Outcome::kSucceeded);
    QCOMPARE(window_->devices()->bench()->lights().Status().lit_led, std::nullopt);

    // Live view: the simulated camera's preview, shown on a timer.
    Find<QCheckBox>("liveView")->setChecked(true);
    QTRY_VERIFY_WITH_TIMEOUT(!Find<QLabel>("liveImage")->pixmap().isNull(), 5000);
    Find<QCheckBox>("liveView")->setChecked(false);
  }

  void CapturesCancelsAndResumes() {
    window_->ShowPage(MainWindow::kCapturePage);
    const QString session = work_.filePath("twill-01");
    QTest::keyClicks(Find<QLineEdit>("sessionFolder"), session);
    QTest::keyClicks(Find<QLineEdit>("sampleName"), "twill, navy");
    Find<QCheckBox>("checkExposure")->setChecked(false);  // keeps the test short; the CLI tests cover it
    QVERIFY(Find<QPushButton>("startCapture")->isEnabled());

    // Cancel through the button once three frames are in. The capture
    // reports "capture" i/11 before taking frame i; the worker is held right
    // after that report until the button was clicked, so the stop lands
    // before frame 3 however loaded the machine is.
    constexpr int kFramesBeforeCancel = 3;
    const double cancel_at = double(kFramesBeforeCancel) / 11;
    QSemaphore clicked;
    bool held = false;
    window_->runner()->SetWorkerProgressHook([&](const QString& stage, double fraction) {
      if (held || stage != "capture" || fraction < cancel_at - 1e-9) return;
      held = true;
      clicked.tryAcquire(1, 60000);
    });
    bool cancel_clicked = false;
    auto cancel_early = connect(window_->runner(), &ControllerRunner::Progress, this,
                                [&](const QString& stage, double fraction) {
                                  if (cancel_clicked || stage != "capture" || fraction < cancel_at - 1e-9) return;
                                  cancel_clicked = true;
                                  QPushButton* cancel = Find<QPushButton>("cancelCapture");
                                  if (!cancel->isEnabled()) qWarning("cancelCapture is disabled mid-capture");
                                  QTest::mouseClick(cancel, Qt::LeftButton);
                                  clicked.release();
                                });
    {
      // Dropped however this ends: both capture locals by reference.
      const auto drop_hooks = qScopeGuard([&] {
        disconnect(cancel_early);
        window_->runner()->SetWorkerProgressHook({});
      });
      QCOMPARE(ClickAndWait("startCapture"), ControllerRunner::Outcome::kCancelled);
    }
    QVERIFY(cancel_clicked);
    QVERIFY(Find<QLabel>("captureStatus")->text().contains("cancelled"));
    Session partial = LoadSession(session.toStdString(), SessionLoadOptions{.verify_checksums = false});
    QVERIFY(!partial.capture_complete);
    QCOMPARE(partial.frames.size(), size_t(kFramesBeforeCancel));  // the dark frame and LEDs 0, 1
    QVERIFY(Find<QPushButton>("resumeCapture")->isEnabled());

    // The UI thread stays free during the run: thumbnails appear while it goes on.
    int thumbnails_while_running = 0;
    auto watch = connect(window_->runner(), &ControllerRunner::Progress, this, [&] {
      if (window_->runner()->busy()) {
        thumbnails_while_running = std::max<int>(
            thumbnails_while_running,
            window_->findChildren<QLabel*>(QRegularExpression("^thumbnail_")).size());
      }
    });
    {
      const auto drop_watch = qScopeGuard([&] { disconnect(watch); });
      QCOMPARE(ClickAndWait("resumeCapture"), ControllerRunner::Outcome::kSucceeded);
    }
    QVERIFY2(thumbnails_while_running > int(partial.frames.size()),
             qPrintable(QString::number(thumbnails_while_running)));
    const Session complete = LoadSession(session.toStdString());
    QVERIFY(complete.capture_complete);
    QCOMPARE(complete.frames.size(), size_t(11));
    QCOMPARE(complete.sample_name, std::string("twill, navy"));
    // A thumbnail per frame, each a picture.
    for (int slot = -1; slot < 10; ++slot) {
      auto* thumbnail = window_->findChild<QLabel*>(QStringLiteral("thumbnail_%1").arg(slot));
      QVERIFY2(thumbnail != nullptr, qPrintable(QStringLiteral("no thumbnail %1").arg(slot)));
      QTRY_VERIFY_WITH_TIMEOUT(!thumbnail->pixmap().isNull(), 5000);  // decoded off the UI thread
    }
    // "Solve while capturing" is on by default: the resume ended with a
    // result, which the Results page shows.
    QVERIFY(Find<QCheckBox>("solveWhileCapturing")->isChecked());
    const fs::path live_result = window_->results()->result_dir();
    QVERIFY2(fs::exists(live_result / "normal.exr"), live_result.c_str());
    QCOMPARE(live_result.parent_path().parent_path(), fs::path(session.toStdString()));
    QVERIFY(Find<QLabel>("captureStatus")->text().contains("after the last frame"));
  }

  void SolvesAndShowsTheMaps() {
    window_->ShowPage(MainWindow::kCapturePage);  // the live solve opened its result
    QCOMPARE(ClickAndWait("solveCaptured"), ControllerRunner::Outcome::kSucceeded);
    ResultsPage* results = window_->results();
    const fs::path dir = results->result_dir();
    QVERIFY2(fs::is_directory(dir), dir.c_str());
    QCOMPARE(dir.parent_path().parent_path(), fs::path(work_.filePath("twill-01").toStdString()));
    for (const char* file : {"normal.exr", "normal.png", "albedo.exr", "albedo_srgb.png", "status.png",
                             "solved_mask.png", "confidence.exr", "report.json", "summary.txt"}) {
      QVERIFY2(fs::exists(dir / file), file);
    }
    const ImageF normal = ReadImageFloat(dir / "normal.exr");
    QCOMPARE(normal.width(), 320);
    QCOMPARE(normal.height(), 212);
    double worst = 0;
    for (int y = 0; y < normal.height(); ++y)
      for (int x = 0; x < normal.width(); ++x)
        worst = std::max(worst, std::abs(std::hypot(normal(x, y, 0), normal(x, y, 1), normal(x, y, 2)) - 1.0));
    QVERIFY2(worst < 1e-3, qPrintable(QString::number(worst)));
    const ImageU8 mask = ReadImageU8(dir / "solved_mask.png");
    size_t solved = 0;
    for (size_t i = 0; i < mask.size(); ++i) solved += mask.data()[i] == 255;
    const double fraction = double(solved) / mask.num_pixels();
    QVERIFY2(fraction > 0.95, qPrintable(QString::number(fraction)));

    // The albedo's colour as report.json states it (issue #12): the simulated
    // DNGs carry the D5100's colour matrix, so without a colour calibration the
    // solve takes that matrix.
    const std::vector<uint8_t> report = ReadFileBytes(dir / "report.json");
    const ResultAlbedoColor color = AlbedoColorOfReport(std::string(report.begin(), report.end()));
    QCOMPARE(color.color_space, std::string("linear_rec709"));
    QLabel* albedo_line = window_->findChild<QLabel*>("resultAlbedoColor");
    QVERIFY(albedo_line != nullptr);
    QCOMPARE(albedo_line->text(), QStringLiteral("Albedo: %1, %2 — %3")
                                      .arg(QString::fromStdString(color.color_space),
                                           QString::fromStdString(color.scale),
                                           QString::fromStdString(color.description)));

    // Every map shows, at the result's size; zoom works on it.
    QCOMPARE(window_->findChild<QTabWidget*>("pages")->currentIndex(), int(MainWindow::kResultsPage));
    for (ResultLayer layer : {ResultLayer::kAlbedo, ResultLayer::kNormal, ResultLayer::kStatus,
                              ResultLayer::kResidual, ResultLayer::kRelight}) {
      QVERIFY2(results->ShowLayer(layer), qPrintable(ResultLayerName(layer)));
      QVERIFY(results->WaitForRelight(30000));  // the relight is rendered on a worker
      QCOMPARE(results->view()->image().size(), QSize(320, 212));
    }
    const double zoom = results->view()->zoom();
    results->view()->ZoomBy(2, QPointF(10, 10));
    QCOMPARE(results->view()->zoom(), zoom * 2);

    // Relight: a light from the left brightens left-facing slopes only; the
    // picture changes when the light moves.
    results->light_pad()->SetDirectionXY(QPointF(-0.7, 0));
    QVERIFY(results->WaitForRelight(30000));
    const QImage from_left = results->view()->image();
    results->light_pad()->SetDirectionXY(QPointF(0.7, 0));
    QVERIFY(results->WaitForRelight(30000));
    const QImage from_right = results->view()->image();
    QVERIFY(from_left != from_right);

    // The GGX lobe through its checkbox: only adds light, and somewhere a lot.
    auto* specular = Find<QCheckBox>("relightSpecular");
    QVERIFY(specular->isVisible());
    QVERIFY(!specular->isChecked());
    QTest::mouseClick(specular, Qt::LeftButton, {}, QPoint(8, specular->height() / 2));
    QVERIFY(specular->isChecked());
    QVERIFY(results->relight_shading().specular);
    QVERIFY(results->WaitForRelight(30000));
    const QImage glossy = results->view()->image();
    QCOMPARE(glossy.size(), from_right.size());
    int darker = 0, brightest_gain = 0;
    for (int y = 0; y < glossy.height(); ++y)
      for (int x = 0; x < glossy.width(); ++x) {
        const int gain = qGreen(glossy.pixel(x, y)) - qGreen(from_right.pixel(x, y));
        darker += gain < 0;
        brightest_gain = std::max(brightest_gain, gain);
      }
    QCOMPARE(darker, 0);
    QVERIFY2(brightest_gain > 20, qPrintable(QString::number(brightest_gain)));
    results->SetRelightShading(RelightShading());
  }

  void ResolvesFromTheSessionsPage() {
    window_->ShowPage(MainWindow::kSessionsPage);
    auto* list = Find<QTreeWidget>("sessionList");
    QCOMPARE(list->topLevelItemCount(), 1);
    QCOMPARE(list->topLevelItem(0)->text(3), QStringLiteral("complete"));
    const fs::path first = window_->results()->result_dir();
    QCOMPARE(ClickAndWait("resolveSession"), ControllerRunner::Outcome::kSucceeded);
    const fs::path second = window_->results()->result_dir();
    QVERIFY(second != first);
    QVERIFY(fs::exists(first / "normal.exr"));
    QVERIFY(fs::exists(second / "normal.exr"));
    QCOMPARE(list->topLevelItem(0)->text(4), QStringLiteral("3"));  // the live solve's, Solve's, this one
  }

  void SettingsPersist() {
    window_->SaveSettings();
    MainWindow again;
    QCOMPARE(again.findChild<QSpinBox*>("simWidth")->value(), 320);
    QCOMPARE(again.findChild<QSpinBox*>("simHeight")->value(), 212);
    QCOMPARE(again.findChild<QLineEdit*>("sessionsRoot")->text(), work_.path());
    QCOMPARE(again.findChild<QTreeWidget*>("sessionList")->topLevelItemCount(), 1);
    QVERIFY(again.findChild<QCheckBox*>("solveWhileCapturing")->isChecked());
  }
};

}  // namespace scanbench

QTEST_MAIN(scanbench::GuiScanTest)
#include "gui_scan_test.moc"
