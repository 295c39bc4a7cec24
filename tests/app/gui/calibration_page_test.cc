// The Calibration page on the simulated bench through the real widgets:
// render the target sessions (308 x 204), cancel a camera calibration (no set
// is left), calibrate camera, white balance and lights into one set, compare
// the figures shown with the set's, calibrate the colour on the ColorChecker
// session (its patch table and swatches against the set's colour section),
// offer the set to the Sessions page, show
// the fix hint of a run on a session that is no target, describe that capture
// as the gray chart and run on it, and reload the set in a new window from the
// saved settings. The limits and hints of bad figures are checked on made-up
// summaries.
#include <QCheckBox>
#include <QLabel>
#include <QLineEdit>
#include <QListWidget>
#include <QProgressBar>
#include <QPushButton>
#include <QSettings>
#include <QSpinBox>
#include <QTabWidget>
#include <QTableWidget>
#include <QTemporaryDir>
#include <QTest>
#include <QTreeWidget>

#include <filesystem>

#include "app/gui/calibration_page.h"
#include "app/gui/calibration_quality.h"
#include "app/gui/controller_runner.h"
#include "app/gui/main_window.h"
#include "app/session/calibration_set.h"
#include "app/session/calibration_target.h"
#include "app/session/session.h"

namespace scanbench {
namespace fs = std::filesystem;

class CalibrationPageTest : public QObject {
  Q_OBJECT

 private:
  template <typename T>
  T* Find(const char* name, QWidget* in = nullptr) {
    T* widget = (in ? in : window_.get())->findChild<T*>(QString::fromLatin1(name));
    if (!widget) qFatal("no widget %s", name);
    return widget;
  }

  // Clicks through the real button and waits for the job it starts.
  ControllerRunner::Outcome ClickAndWait(const char* button, bool cancel_at_once = false) {
    ControllerRunner::Outcome outcome = ControllerRunner::Outcome::kFailed;
    auto connection = connect(window_->runner(), &ControllerRunner::Finished, this,
                              [&outcome](ControllerRunner::Outcome result, const QString&) { outcome = result; });
    QPushButton* widget = Find<QPushButton>(button);
    if (!widget->isEnabled()) qWarning("%s is disabled", button);
    QTest::mouseClick(widget, Qt::LeftButton);
    if (cancel_at_once) {
      // The job checks for a stop while it reads the first session: it
      // cannot have written anything yet.
      QPushButton* cancel = Find<QPushButton>("cancelCalibration");
      if (!cancel->isEnabled()) qWarning("cancelCalibration is disabled");
      QTest::mouseClick(cancel, Qt::LeftButton);
    }
    if (!window_->runner()->Wait(60000)) qWarning("%s: job still running", button);
    disconnect(connection);
    return outcome;
  }

  // The figure `name` of `tree`, at the top level (group "") or under the
  // group item whose text starts with `group`.
  QTreeWidgetItem* FigureItem(const char* tree_name, const QString& group, const QString& name) {
    QTreeWidget* tree = Find<QTreeWidget>(tree_name);
    for (int i = 0; i < tree->topLevelItemCount(); ++i) {
      QTreeWidgetItem* top = tree->topLevelItem(i);
      if (group.isEmpty()) {
        if (top->text(0) == name) return top;
      } else if (top->text(0).startsWith(group)) {
        for (int j = 0; j < top->childCount(); ++j) {
          if (top->child(j)->text(0) == name) return top->child(j);
        }
      }
    }
    qWarning("%s: no figure %s / %s", tree_name, qPrintable(group), qPrintable(name));
    return nullptr;
  }

  double FigureValue(const char* tree, const QString& group, const QString& name) {
    QTreeWidgetItem* item = FigureItem(tree, group, name);
    return item ? item->data(1, Qt::UserRole).toDouble() : -1;
  }

  QString CalibrationDir() const { return work_.filePath("calibration"); }
  QString TargetsDir() const { return work_.filePath("targets"); }

  std::unique_ptr<MainWindow> window_;
  QTemporaryDir work_;

 private slots:
  void initTestCase() {
    QVERIFY(work_.isValid());
    QCoreApplication::setOrganizationName("scanbench");
    QCoreApplication::setApplicationName("scanbench-gui-calibration-test");
    QSettings().clear();  // what an earlier run saved must not steer this one
    window_ = std::make_unique<MainWindow>();
    window_->resize(1280, 820);
    window_->show();
  }

  void cleanupTestCase() { window_.reset(); }

  void RendersTheSimulatedTargets() {
    window_->ShowPage(MainWindow::kCalibrationPage);
    QCOMPARE(window_->findChild<QTabWidget*>("pages")->currentWidget(), window_->calibration());
    Find<QSpinBox>("targetsWidth")->setValue(308);
    Find<QSpinBox>("targetsHeight")->setValue(204);
    QTest::keyClicks(Find<QLineEdit>("targetsFolder"), TargetsDir());
    QLineEdit* set_folder = Find<QLineEdit>("calibrationSet");
    QTest::keyClicks(set_folder, CalibrationDir());
    QTest::keyClick(set_folder, Qt::Key_Return);  // editingFinished: the page looks for a set there
    QVERIFY2(Find<QLabel>("calibrationSetState")->text().contains("step 1 (camera) creates it"),
             qPrintable(Find<QLabel>("calibrationSetState")->text()));
    QVERIFY(!Find<QPushButton>("useCalibrationSet")->isEnabled());

    QCOMPARE(ClickAndWait("renderTargets"), ControllerRunner::Outcome::kSucceeded);
    QCOMPARE(Find<QListWidget>("cameraSessions")->count(), 9);
    QCOMPARE(Find<QListWidget>("whiteSessions")->count(), 1);
    QCOMPARE(Find<QListWidget>("lightsSessions")->count(), 2);
    QCOMPARE(Find<QListWidget>("colorSessions")->count(), 1);
    QVERIFY(Find<QListWidget>("whiteSessions")->item(0)->text().endsWith("gray_chart"));
    QVERIFY(Find<QListWidget>("colorSessions")->item(0)->text().endsWith("color_chart"));
    // 9 boards, the gray chart, 2 white sheets and the colour chart (issue #12).
    QVERIFY2(Find<QLabel>("targetsStatus")->text().contains("13 target session(s) rendered"),
             qPrintable(Find<QLabel>("targetsStatus")->text()));
    // The sessions fit the simulated camera at that size.
    const Session board = LoadSession(Find<QListWidget>("cameraSessions")->item(0)->text().toStdString());
    QCOMPARE(board.camera.width, 308);
    QCOMPARE(board.camera.height, 204);
  }

  void CancelLeavesNoSet() {
    QCOMPARE(ClickAndWait("cameraRun", /*cancel_at_once=*/true), ControllerRunner::Outcome::kCancelled);
    QVERIFY(!fs::exists(fs::path(CalibrationDir().toStdString()) / kCalibrationManifestName));
    QVERIFY2(Find<QLabel>("cameraStatus")->text().startsWith("Cancelled"),
             qPrintable(Find<QLabel>("cameraStatus")->text()));
    QCOMPARE(Find<QTreeWidget>("cameraFigures")->topLevelItemCount(), 0);
  }

  void CalibratesTheCamera() {
    QCOMPARE(ClickAndWait("cameraRun"), ControllerRunner::Outcome::kSucceeded);
    const CalibrationSet set = LoadCalibrationSet(CalibrationDir().toStdString());
    QVERIFY(set.camera_calibration.has_value());
    QVERIFY(!set.white_balance && !set.lights);
    const CameraCalibrationSummary& s = set.camera_calibration->summary;

    // The figures shown are the set's, each marked.
    QTreeWidgetItem* rms = FigureItem("cameraFigures", "", "reprojection RMS, all views");
    QVERIFY(rms != nullptr);
    QCOMPARE(rms->data(1, Qt::UserRole).toDouble(), s.reprojection_rms_px);
    QVERIFY2(rms->text(1).startsWith(QString::number(s.reprojection_rms_px, 'f', 3) + " px"), qPrintable(rms->text(1)));
    QCOMPARE(rms->text(3), QStringLiteral("pass"));  // 0.075 px on the simulated rig
    QCOMPARE(FigureValue("cameraFigures", "", "reprojection RMS, table view"), s.table_view_rms_px);
    QCOMPARE(FigureValue("cameraFigures", "", "views used"), double(s.num_used_views));
    QCOMPARE(s.num_used_views, 9);
    QCOMPARE(FigureValue("cameraFigures", "", "focal length uncertainty"),
             std::max(s.intrinsics_std[0] / s.camera.intrinsics.fx, s.intrinsics_std[1] / s.camera.intrinsics.fy));
    for (const CalibrationViewReport& view : s.views) {
      const QString group = "view " + QString::fromStdString(fs::path(view.name).filename().string());
      QCOMPARE(FigureValue("cameraFigures", group, "reprojection RMS"), view.rms_px);
      QCOMPARE(FigureValue("cameraFigures", group, "edge width"), view.edge_width_px);
    }
    QVERIFY(FigureItem("cameraFigures", "view checkerboard_0 (on the table)", "reprojection RMS") != nullptr);
    QVERIFY2(Find<QLabel>("cameraHints")->text().contains("nothing to fix"),
             qPrintable(Find<QLabel>("cameraHints")->text()));
    QVERIFY(Find<QListWidget>("calibrationSteps")->item(0)->text().contains("done"));
    QVERIFY(!Find<QPushButton>("useCalibrationSet")->isEnabled());  // white balance and lights to come
  }

  void MeasuresTheWhiteBalance() {
    QTest::mouseClick(Find<QPushButton>("cameraNext"), Qt::LeftButton);
    QCOMPARE(Find<QListWidget>("calibrationSteps")->currentRow(), int(CalibrationPage::kWhiteStep));
    QCOMPARE(ClickAndWait("whiteRun"), ControllerRunner::Outcome::kSucceeded);
    const CalibrationSet set = LoadCalibrationSet(CalibrationDir().toStdString());
    QVERIFY(set.white_balance.has_value());
    const WhiteBalanceSummary& s = set.white_balance->summary;
    QCOMPARE(s.leds.size(), size_t(10));
    for (const LedWhiteBalance& led : s.leds) {
      const QString group = QStringLiteral("LED %1").arg(led.led_index);
      QCOMPARE(FigureValue("whiteFigures", group, "linearity residual"), led.linearity_rms.maxCoeff());
      QCOMPARE(FigureValue("whiteFigures", group, "patches used"), double(led.used_patches));
      QCOMPARE(FigureValue("whiteFigures", group, "response exponent"),
               (led.response_exponent.array() - 1).abs().maxCoeff());
    }
    // The simulated sensor is linear: every LED passes that.
    QTreeWidgetItem* exponent = FigureItem("whiteFigures", "LED 0", "response exponent");
    QVERIFY(exponent != nullptr);
    QCOMPARE(exponent->text(3), QStringLiteral("pass"));
  }

  void CalibratesTheLightsAndOffersTheSet() {
    QTest::mouseClick(Find<QPushButton>("whiteNext"), Qt::LeftButton);
    QCOMPARE(ClickAndWait("lightsRun"), ControllerRunner::Outcome::kSucceeded);
    const CalibrationSet set = LoadCalibrationSet(CalibrationDir().toStdString());
    QVERIFY(set.camera_calibration && set.white_balance && set.lights);
    const LightCalibrationSummary& s = set.lights->summary;
    QCOMPARE(s.selected, LightCalibrationSummary::Choice::kModel);
    const Session table_sheet = LoadSession(Find<QListWidget>("lightsSessions")->item(0)->text().toStdString(),
                                            SessionLoadOptions{.verify_checksums = false});
    for (size_t k = 0; k < s.model.size(); ++k) {
      const QString group = QStringLiteral("LED %1").arg(s.model[k].led.id);
      QCOMPARE(FigureValue("lightsFigures", group, "model residual / noise (chi)"), s.model[k].chi);
      const double change =
          (s.model[k].led.position_in_table_mm - table_sheet.rig.leds[k].position_in_table_mm).norm();
      QCOMPARE(FigureValue("lightsFigures", group, "position change from the rig description"), change);
      QVERIFY(change > 0.5 && change < 20);  // the measured rig is a few mm off (docs/calibration.md)
    }
    // Complete without the optional colour step.
    QVERIFY2(Find<QLabel>("calibrationSetState")->text().contains("Colour not done (optional)"),
             qPrintable(Find<QLabel>("calibrationSetState")->text()));
    QVERIFY(Find<QLabel>("calibrationSetState")->text().contains("complete, ready for solves"));
    QVERIFY(Find<QPushButton>("useCalibrationSet")->isEnabled());
    QTest::mouseClick(Find<QPushButton>("lightsNext"), Qt::LeftButton);
    QCOMPARE(Find<QListWidget>("calibrationSteps")->currentRow(), int(CalibrationPage::kColorStep));
  }

  // The fourth step, after the lights: the ColorChecker session measured
  // through the set's light calibration.
  void CalibratesTheColour() {
    QListWidget* steps = Find<QListWidget>("calibrationSteps");
    QCOMPARE(steps->count(), int(CalibrationPage::kStepCount));
    QCOMPARE(int(CalibrationPage::kColorStep), int(CalibrationPage::kLightsStep) + 1);
    QVERIFY2(steps->item(CalibrationPage::kColorStep)->text().startsWith("4. Colour"),
             qPrintable(steps->item(CalibrationPage::kColorStep)->text()));
    QVERIFY(steps->item(CalibrationPage::kColorStep)->text().contains("not done (optional)"));
    QTableWidget* table = Find<QTableWidget>("colorPatches");
    QCOMPARE(table->rowCount(), 0);

    QCOMPARE(ClickAndWait("colorRun"), ControllerRunner::Outcome::kSucceeded);
    // Issue #36 item 8: the job's end, with a full bar, not its last stage's "100 %".
    QVERIFY2(Find<QLabel>("calibrationStage")->text().endsWith(" s") &&
                 Find<QLabel>("calibrationStage")->text().contains("finished in"),
             qPrintable(Find<QLabel>("calibrationStage")->text()));
    QCOMPARE(Find<QProgressBar>("calibrationProgress")->value(), 1000);
    const CalibrationSet set = LoadCalibrationSet(CalibrationDir().toStdString());
    QVERIFY(set.color.has_value());
    QCOMPARE(set.color->white_reference, std::string("light_field"));
    QCOMPARE(set.color->targets.at(0).session, Find<QListWidget>("colorSessions")->item(0)->text().toStdString());
    const ColorCorrectionSummary& fit = set.color->summary;
    QCOMPARE(fit.patches.size(), size_t(24));

    // The table is the set's: one row per patch in chart order.
    QCOMPARE(table->rowCount(), 24);
    QCOMPARE(table->columnCount(), 7);
    for (int row = 0; row < 24; ++row) {
      const ColorPatchResult& patch = fit.patches[row];
      QCOMPARE(table->item(row, 0)->text(), QString::fromStdString(patch.name));
      QCOMPARE(table->item(row, 1)->text(), QStringLiteral("%1 %2 %3")
                                                .arg(patch.measured_camera[0], 0, 'f', 3)
                                                .arg(patch.measured_camera[1], 0, 'f', 3)
                                                .arg(patch.measured_camera[2], 0, 'f', 3));
      QCOMPARE(table->item(row, 4)->data(Qt::UserRole).toDouble(), patch.delta_e_before);
      QCOMPARE(table->item(row, 5)->data(Qt::UserRole).toDouble(), patch.delta_e_after);
      QCOMPARE(table->item(row, 6)->text(), patch.used ? QStringLiteral("used")
                                                       : "no: " + QString::fromStdString(ColorPatchStatusText(patch)));
    }
    QCOMPARE(table->item(0, 0)->text(), QStringLiteral("dark skin"));
    QCOMPARE(table->item(23, 0)->text(), QStringLiteral("black 2 (1.5 D)"));
    const QString stats = Find<QLabel>("colorPatchStats")->text();
    for (double value : {fit.mean_delta_e_before, fit.mean_delta_e_after, fit.max_delta_e_before,
                         fit.max_delta_e_after}) {
      QVERIFY2(stats.contains(QString::number(value, 'f', 2)), qPrintable(stats));
    }
    QVERIFY2(stats.contains(QStringLiteral("over %1 of 24 patches").arg(UsedColorPatches(fit))), qPrintable(stats));
    // The simulated D5100 corrects to about 1 CIEDE2000 on average (docs/calibration.md).
    QVERIFY2(fit.mean_delta_e_after < 2 && fit.mean_delta_e_before > 4, qPrintable(stats));
    QCOMPARE(FigureValue("colorFigures", "", "CIEDE2000 mean, corrected"), fit.mean_delta_e_after);
    QCOMPARE(FigureValue("colorFigures", "", "CIEDE2000 max, corrected"), fit.max_delta_e_after);
    QCOMPARE(FigureValue("colorFigures", "", "patches used"), double(UsedColorPatches(fit)));
    QCOMPARE(UsedColorPatches(fit), 24);  // the simulated chart is evenly lit: nothing clips
    QCOMPARE(FigureItem("colorFigures", "", "CIEDE2000 mean, corrected")->text(3), QStringLiteral("pass"));

    // The swatches are the set's fit, drawn by ColorChartSwatches.
    const QPixmap swatches = Find<QLabel>("colorSwatches")->pixmap();
    QVERIFY(!swatches.isNull());
    const ImageU8 expected = ColorChartSwatches(fit, 36);
    QCOMPARE(swatches.size(), QSize(expected.width(), expected.height()));
    const QImage shown = swatches.toImage();
    const int g = SwatchGapPx(36);
    const int x = g + 2 * (36 + g) + 18, y = g + 3 * (36 + g) + 18;  // patch 20's reference stripe
    QCOMPARE(shown.pixelColor(x, y), QColor(expected(x, y, 0), expected(x, y, 1), expected(x, y, 2)));
    QVERIFY(steps->item(CalibrationPage::kColorStep)->text().contains("done"));
    QVERIFY2(Find<QLabel>("colorStatus")->text().startsWith("Colour calibrated"),
             qPrintable(Find<QLabel>("colorStatus")->text()));

    // The set (complete, now with colour) goes to the solve on the Sessions page.
    QVERIFY(Find<QLabel>("calibrationSetState")->text().contains("Colour done"));
    QTest::mouseClick(Find<QPushButton>("colorNext"), Qt::LeftButton);
    QCOMPARE(window_->findChild<QTabWidget*>("pages")->currentIndex(), int(MainWindow::kSessionsPage));
    QCOMPARE(Find<QLineEdit>("calibrationFolder")->text(), CalibrationDir());
    window_->ShowPage(MainWindow::kCalibrationPage);
  }

  void ASessionThatIsNoTargetShowsItsFix() {
    // A scan session as the white balance's target: the gray chart's frames
    // without its target.json.
    const fs::path chart(Find<QListWidget>("whiteSessions")->item(0)->text().toStdString());
    const fs::path scan = fs::path(work_.filePath("not-a-target").toStdString());
    fs::copy(chart, scan, fs::copy_options::recursive);
    fs::remove(scan / "target.json");
    const std::string date_before = LoadCalibrationSet(CalibrationDir().toStdString()).white_balance->date;

    QListWidget* sessions = Find<QListWidget>("whiteSessions");
    sessions->clear();
    sessions->addItem(QString::fromStdString(scan.string()));
    window_->calibration()->ShowStep(CalibrationPage::kWhiteStep);
    QCOMPARE(ClickAndWait("whiteRun"), ControllerRunner::Outcome::kFailed);
    const QString status = Find<QLabel>("whiteStatus")->text();
    QVERIFY2(status.contains("is no calibration target session"), qPrintable(status));
    const QString hint = Find<QLabel>("whiteHints")->text();
    QVERIFY2(hint.contains("not a target capture") && hint.contains("gray chart"), qPrintable(hint));
    QVERIFY(Find<QListWidget>("calibrationSteps")->item(1)->text().contains("done"));  // the set still has it
    // Nothing was written: the set's white balance is the earlier one.
    QCOMPARE(LoadCalibrationSet(CalibrationDir().toStdString()).white_balance->date, date_before);
  }

  // A capture without target.json (as the real bench's Capture page makes)
  // becomes the gray chart's target session, and the step runs on it.
  void DescribesACaptureAsTheTarget() {
    QListWidget* sessions = Find<QListWidget>("whiteSessions");
    QCOMPARE(sessions->count(), 1);
    const fs::path scan(sessions->item(0)->text().toStdString());
    QVERIFY(!fs::exists(scan / "target.json"));
    sessions->item(0)->setSelected(true);
    QTest::mouseClick(Find<QPushButton>("whiteDescribe"), Qt::LeftButton);
    QVERIFY2(Find<QLabel>("whiteStatus")->text().contains("target.json written"),
             qPrintable(Find<QLabel>("whiteStatus")->text()));
    const CalibrationTargetDescription target = LoadCalibrationTarget(scan);
    QCOMPARE(target.kind, CalibrationTargetDescription::Kind::kGrayChart);
    QCOMPARE(target.gray_chart.patches.size(), GrayChartTarget::MunsellNeutralScale().patches.size());
    QCOMPARE(ClickAndWait("whiteRun"), ControllerRunner::Outcome::kSucceeded);
    QCOMPARE(LoadCalibrationSet(CalibrationDir().toStdString()).white_balance->targets.at(0).session, scan.string());
    // Issue #36 item 14: the colour section was measured through the old
    // white balance: marked stale, with the command that refits it.
    const QString colour = Find<QListWidget>("calibrationSteps")->item(CalibrationPage::kColorStep)->text();
    QVERIFY2(colour.contains("stale"), qPrintable(colour));
    const QString colour_status = Find<QLabel>("colorStatus")->text();
    QVERIFY2(colour_status.contains("STALE") && colour_status.contains("scanbench calibrate color"),
             qPrintable(colour_status));
    QVERIFY2(Find<QLabel>("calibrationSetState")->text().contains("Colour stale"),
             qPrintable(Find<QLabel>("calibrationSetState")->text()));
    // Described once: a second click keeps it.
    QTest::mouseClick(Find<QPushButton>("whiteDescribe"), Qt::LeftButton);
    QVERIFY(Find<QLabel>("whiteStatus")->text().contains("Kept the target.json"));
  }

  void TheSetReloadsFromTheSettings() {
    window_->SaveSettings();
    MainWindow again;
    QCOMPARE(again.calibration()->calibration_folder(), CalibrationDir());
    // The figures of each step come from the set on disk.
    const CalibrationSet set = LoadCalibrationSet(CalibrationDir().toStdString());
    QTreeWidget* camera = again.findChild<QTreeWidget*>("cameraFigures");
    QVERIFY(camera != nullptr && camera->topLevelItemCount() > 0);
    QCOMPARE(camera->topLevelItem(0)->data(1, Qt::UserRole).toDouble(),
             set.camera_calibration->summary.reprojection_rms_px);
    QVERIFY(again.findChild<QTreeWidget*>("lightsFigures")->topLevelItemCount() > 0);
    QTableWidget* patches = again.findChild<QTableWidget*>("colorPatches");
    QVERIFY(patches != nullptr);
    QCOMPARE(patches->rowCount(), 24);
    QCOMPARE(patches->item(5, 5)->data(Qt::UserRole).toDouble(), set.color->summary.patches[5].delta_e_after);
    QVERIFY(again.findChild<QPushButton*>("useCalibrationSet")->isEnabled());
  }

  // The limits and their hints, on summaries made up to break them.
  void BadFiguresFailWithTheirFix() {
    CameraCalibrationSummary camera;
    camera.termination = Termination::kSuccess;
    camera.camera.intrinsics.fx = camera.camera.intrinsics.fy = 5000;
    camera.camera.intrinsics.width = 1232;
    camera.reprojection_rms_px = 1.8;
    camera.table_view_rms_px = 0.2;
    for (int v = 0; v < 9; ++v) {
      CalibrationViewReport view;
      view.name = "/bench/targets/checkerboard_" + std::to_string(v);
      view.used = true;
      view.rms_px = v == 3 ? 2.5 : v == 7 ? 2.1 : 0.3;
      view.edge_width_px = 1.5;
      camera.views.push_back(view);
    }
    camera.num_used_views = 9;
    const std::vector<QualityFigure> figures = CameraQuality(camera);
    QCOMPARE(figures[0].name, std::string("reprojection RMS, all views"));
    QCOMPARE(figures[0].mark, QualityFigure::Mark::kFail);
    QCOMPARE(figures[0].hint, std::string("reprojection RMS 1.80 px > 0.5 px: refocus on the board, hold it flatter "
                                          "(mounted on glass or card) and still, and retake checkerboard_3 and "
                                          "checkerboard_7 (the worst views)"));
    QCOMPARE(figures[1].mark, QualityFigure::Mark::kPass);
    QVERIFY(figures[1].hint.empty());
    QCOMPARE(WorstMark(figures), QualityFigure::Mark::kFail);

    WhiteBalanceSummary white;
    LedWhiteBalance led;
    led.led_index = 4;
    led.response_exponent = Eigen::Vector3d(1.0, 1.0, 0.55);  // a JPEG's gamma
    for (const char* name : {"N9.5", "N8", "N5"}) {
      PatchMeasurement patch;
      patch.name = name;
      patch.clipped = patch.name == "N9.5";
      patch.used = !patch.clipped;
      led.patches.push_back(patch);
    }
    led.used_patches = 2;
    white.leds.push_back(led);
    const std::vector<QualityFigure> white_figures = WhiteBalanceQuality(white);
    auto find = [](const std::vector<QualityFigure>& all, const std::string& name) {
      return *std::find_if(all.begin(), all.end(), [&](const QualityFigure& f) { return f.name == name; });
    };
    QCOMPARE(find(white_figures, "response exponent").mark, QualityFigure::Mark::kFail);
    QVERIFY(find(white_figures, "response exponent").hint.find("RAW") != std::string::npos);
    const QualityFigure patches = find(white_figures, "patches used");
    QCOMPARE(patches.mark, QualityFigure::Mark::kFail);  // fewer than 3 used
    QVERIFY2(patches.hint.find("N9.5 clipped under LED 4: shorten the exposure") != std::string::npos,
             patches.hint.c_str());

    LightCalibrationSummary lights;
    lights.termination = Termination::kSuccess;
    LedModelFit fit;
    fit.usable = true;
    fit.led.id = 2;
    fit.led.position_in_table_mm = Eigen::Vector3d(100, 0, 450);
    fit.chi = 1.2;
    lights.model.push_back(fit);
    LedDescription measured;
    measured.position_in_table_mm = Eigen::Vector3d(100, 60, 450);  // 60 mm off: another LED's place
    const QualityFigure moved = find(LightsQuality(lights, {measured}), "position change from the rig description");
    QCOMPARE(moved.value, 60.0);
    QCOMPARE(moved.mark, QualityFigure::Mark::kFail);
    QVERIFY2(moved.hint.find("LED 2 lies 60 mm from where the rig description puts it: re-measure it") !=
                 std::string::npos,
             moved.hint.c_str());

    QVERIFY(FixHintForError(CalibrationStep::kCamera, "cal/calibration.json: already exists; a camera calibration")
                .find("Replace an existing set") != std::string::npos);
  }
};

}  // namespace scanbench

QTEST_MAIN(scanbench::CalibrationPageTest)
#include "calibration_page_test.moc"
