// scanbench-gui: the operator's window. With --screenshot-dir it drives
// itself through a simulated capture and solve and saves a picture of every
// page (scripts/gui-screenshots.sh, for docs/gui.md), then exits.
#include <QApplication>
#include <QBuffer>
#include <QCheckBox>
#include <QCommandLineParser>
#include <QDeadlineTimer>
#include <QDir>
#include <QLineEdit>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QSettings>
#include <QSpinBox>
#include <QTemporaryDir>
#include <QThread>
#include <QThreadPool>
#include <QTimer>
#include <QTreeWidget>

#include <cstdio>
#include <tuple>

#include "app/controllers/simulate_controller.h"
#include "app/gui/calibration_page.h"
#include "app/gui/capture_page.h"
#include "app/gui/controller_runner.h"
#include "app/gui/devices_page.h"
#include "app/gui/export_dialog.h"
#include "app/gui/image_view.h"
#include "app/gui/main_window.h"
#include "app/gui/results_page.h"
#include "app/gui/sessions_page.h"
#include "core/memory.h"

namespace scanbench {
namespace {

void Pause(int ms) {
  QDeadlineTimer deadline(ms);
  while (!deadline.hasExpired()) {
    QCoreApplication::processEvents(QEventLoop::AllEvents, 10);
    QThread::msleep(5);
  }
}

template <typename T>
T* Find(QWidget& window, const char* name) {
  T* widget = window.findChild<T*>(QString::fromLatin1(name));
  if (!widget) throw std::runtime_error(std::string("screenshot tour: no widget ") + name);
  return widget;
}

// Clicks `button` and waits for the job it starts; false if it failed or
// took longer than `timeout_ms`.
bool ClickAndWait(MainWindow& window, const char* button, int timeout_ms) {
  bool ok = true;
  auto connection = QObject::connect(window.runner(), &ControllerRunner::Finished,
                                     [&ok](ControllerRunner::Outcome outcome, const QString& message) {
                                       if (outcome != ControllerRunner::Outcome::kSucceeded) {
                                         std::fprintf(stderr, "scanbench-gui: %s\n", qPrintable(message));
                                         ok = false;
                                       }
                                     });
  Find<QPushButton>(window, button)->click();
  ok = window.runner()->Wait(timeout_ms) && ok;
  QObject::disconnect(connection);
  Pause(100);
  return ok;
}

// scale: two thirds for the window; a dialog, much smaller, stays at full size.
bool Save(QWidget& window, const QDir& dir, const QString& name, double scale = 2.0 / 3) {
  Pause(150);
  const QImage image = window.grab().toImage();
  const QString path = dir.filePath("gui-" + name + ".png");
  // True colour when that stays under 300 KB, else a 256-colour palette:
  // readable in the docs, small in the repository.
  const QImage scaled = image.scaledToWidth(int(image.width() * scale), Qt::SmoothTransformation)
                            .convertToFormat(QImage::Format_RGB888);
  QByteArray png;
  QBuffer buffer(&png);
  buffer.open(QIODevice::WriteOnly);
  scaled.save(&buffer, "PNG", 9);
  const bool saved = png.size() < 300 * 1024
                         ? scaled.save(path, "PNG", 9)
                         : scaled.convertToFormat(QImage::Format_Indexed8, Qt::DiffuseDither).save(path, "PNG", 9);
  std::printf("%s %s\n", saved ? "saved" : "FAILED to save", qPrintable(path));
  return saved;
}

// The screenshot tour, one step per page or group of shots. A step returns
// false when a job it starts fails (the tour stops there); a picture that
// cannot be saved only marks the tour failed.
class ScreenshotTourSteps {
 public:
  ScreenshotTourSteps(MainWindow& window, const QDir& dir, QSize sim_size)
      : window_(window), dir_(dir), sim_size_(sim_size) {}

  bool all_saved() const { return saved_; }

  // The simulated bench connected, one LED on, the live view with RAW clipping.
  bool Devices() {
    window_.ShowPage(MainWindow::kDevicesPage);
    Find<QSpinBox>(window_, "simWidth")->setValue(sim_size_.width());
    Find<QSpinBox>(window_, "simHeight")->setValue(sim_size_.height());
    if (!ClickAndWait(window_, "connectButton", 60000)) return false;
    if (!ClickAndWait(window_, "led3", 10000)) return false;
    // Four times the reference exposure, so that the live view shows RAW
    // clipping (the simulated camera's default exposure clips nothing).
    Camera& camera = window_.devices()->bench()->camera();
    const double exposure_s = camera.CurrentExposure().exposure_time_s;
    camera.SetExposureTime(1.0 / 15);
    Find<QCheckBox>(window_, "liveView")->setChecked(true);
    Pause(1500);
    Shot(window_, "devices");
    Find<QCheckBox>(window_, "liveView")->setChecked(false);
    window_.devices()->WaitForLiveFetch();
    camera.SetExposureTime(exposure_s);
    return ClickAndWait(window_, "allOff", 10000);
  }

  // A capture of a new session, then its solve (which opens the Results page).
  bool Capture() {
    window_.ShowPage(MainWindow::kCapturePage);
    Find<QLineEdit>(window_, "sessionFolder")->setText(work_.filePath("twill-01"));
    Find<QLineEdit>(window_, "sampleName")->setText("twill, navy");
    Find<QPlainTextEdit>(window_, "notes")->setPlainText("screenshot tour on the simulated bench");
    if (!ClickAndWait(window_, "startCapture", 300000)) return false;
    QThreadPool::globalInstance()->waitForDone();  // the thumbnails decode there
    // A capture that solved while capturing has opened its result: the shot is of the Capture page.
    window_.ShowPage(MainWindow::kCapturePage);
    Shot(window_, "capture");
    return ClickAndWait(window_, "solveCaptured", 300000);
  }

  // The solved maps the result has, then the relight, Lambertian and with the GGX lobe.
  void ResultLayers() {
    ResultsPage* results = window_.results();
    for (auto [layer, name] : {std::pair{ResultLayer::kAlbedo, "results-albedo"},
                               std::pair{ResultLayer::kNormal, "results-normal"},
                               std::pair{ResultLayer::kResidual, "results-confidence"},
                               std::pair{ResultLayer::kAngularError, "results-error"}}) {
      if (results->ShowLayer(layer)) Shot(window_, name);
    }
    if (!results->ShowLayer(ResultLayer::kRelight)) return;
    results->light_pad()->SetDirectionXY(QPointF(-0.6, 0.45));
    results->WaitForRelight(60000);
    results->view()->ZoomBy(2.0, QPointF(results->view()->width() / 2.0, results->view()->height() / 2.0));
    Shot(window_, "results-relight");
    RelightShading glossy;
    glossy.specular = true;
    glossy.roughness = 0.35;
    results->SetRelightShading(glossy);
    results->WaitForRelight(60000);
    Shot(window_, "results-relight-ggx");
    results->SetRelightShading(RelightShading());
  }

  // A session with ground truth (as `scanbench simulate` writes it), re-solved
  // from the Sessions page, for the angular error map.
  bool ResolveSimulated() {
    SimulateOptions simulate;
    simulate.rig.width = sim_size_.width();
    simulate.rig.height = sim_size_.height();
    const QString simulated = work_.filePath("simulated-twill");
    window_.runner()->Start(std::make_shared<SimulateController>(simulated.toStdString(), simulate), "Simulate");
    if (!window_.runner()->Wait(300000)) return false;
    window_.ShowPage(MainWindow::kSessionsPage);
    window_.sessions()->Refresh();
    if (!window_.sessions()->SelectSession(simulated)) return false;
    if (!ClickAndWait(window_, "resolveSession", 300000)) return false;
    ResultsPage* results = window_.results();
    if (results->ShowLayer(ResultLayer::kAngularError)) {
      results->view()->FitToWidget();  // the whole sample, not the relight's zoom
      Shot(window_, "results-error");
    }
    return true;
  }

  // Export of that result (ground truth: the height error is reported).
  bool Export() {
    ExportDialog* dialog = window_.results()->OpenExportDialog();
    if (!dialog) return true;
    Find<QCheckBox>(*dialog, "tileable")->setChecked(true);
    if (!ClickAndWait(window_, "startExport", 300000)) return false;
    Shot(*dialog, "export", 1.0);
    dialog->close();
    return true;
  }

  // The Sessions page with both sessions and the re-solve's result folder.
  void Sessions() {
    window_.ShowPage(MainWindow::kSessionsPage);
    Shot(window_, "sessions");
  }

  // Calibration: the simulated target sessions, then each step's figures.
  bool Calibration() {
    window_.ShowPage(MainWindow::kCalibrationPage);
    Find<QSpinBox>(window_, "targetsWidth")->setValue(sim_size_.width());
    Find<QSpinBox>(window_, "targetsHeight")->setValue(sim_size_.height());
    Find<QLineEdit>(window_, "targetsFolder")->setText(work_.filePath("targets"));
    window_.calibration()->SetCalibrationFolder(work_.filePath("calibration"));
    if (!ClickAndWait(window_, "renderTargets", 300000)) return false;
    for (auto [step, button, table, name] :
         {std::tuple{CalibrationPage::kCameraStep, "cameraRun", "cameraFigures", "calibration-camera"},
          std::tuple{CalibrationPage::kWhiteStep, "whiteRun", "whiteFigures", "calibration-white"},
          std::tuple{CalibrationPage::kLightsStep, "lightsRun", "lightsFigures", "calibration-lights"},
          std::tuple{CalibrationPage::kColorStep, "colorRun", "colorFigures", "calibration-color"}}) {
      window_.calibration()->ShowStep(step);
      if (!ClickAndWait(window_, button, 300000)) return false;
      ExpandFirstWithChildren(Find<QTreeWidget>(window_, table));
      Shot(window_, name);
    }
    return true;
  }

 private:
  void Shot(QWidget& widget, const QString& name, double scale = 2.0 / 3) {
    saved_ = Save(widget, dir_, name, scale) && saved_;
  }

  // One view or LED unfolded, to show the figures kept per view and per LED.
  static void ExpandFirstWithChildren(QTreeWidget* figures) {
    for (int i = 0; i < figures->topLevelItemCount(); ++i) {
      if (figures->topLevelItem(i)->childCount() > 0) {
        figures->topLevelItem(i)->setExpanded(true);
        return;
      }
    }
  }

  MainWindow& window_;
  const QDir dir_;
  const QSize sim_size_;
  QTemporaryDir work_;  // the sessions and the calibration set the tour makes
  bool saved_ = true;
};

int ScreenshotTour(MainWindow& window, const QString& output_dir, QSize sim_size) {
  QDir dir(output_dir);
  if (!dir.mkpath(".")) {
    std::fprintf(stderr, "scanbench-gui: cannot create %s\n", qPrintable(output_dir));
    return 1;
  }
  ScreenshotTourSteps tour(window, dir, sim_size);
  window.resize(1280, 820);
  window.show();
  Pause(200);
  if (!tour.Devices() || !tour.Capture()) return 1;
  tour.ResultLayers();
  if (!tour.ResolveSimulated() || !tour.Export()) return 1;
  tour.Sessions();
  if (!tour.Calibration()) return 1;
  return tour.all_saved() ? 0 : 1;
}

}  // namespace
}  // namespace scanbench

int main(int argc, char** argv) {
  scanbench::ReturnFreedImagesToTheSystem();
  QApplication app(argc, argv);
  QApplication::setOrganizationName("scanbench");
  QApplication::setApplicationName("scanbench-gui");
  QApplication::setApplicationVersion(SCANBENCH_VERSION);

  QCommandLineParser parser;
  parser.setApplicationDescription("The scan bench operator's window (simulated bench by default).");
  parser.addHelpOption();
  parser.addVersionOption();
  QCommandLineOption screenshots("screenshot-dir",
                                 "Capture and solve on the simulated bench, save gui-*.png of every page "
                                 "into DIR and exit.",
                                 "DIR");
  QCommandLineOption sim_size("screenshot-size", "Simulated image size for --screenshot-dir.", "WxH", "640x424");
  parser.addOption(screenshots);
  parser.addOption(sim_size);
  parser.process(app);

  if (parser.isSet(screenshots)) {
    // Settings of the operator's own runs are neither used nor changed.
    QSettings::setDefaultFormat(QSettings::IniFormat);
    QTemporaryDir settings_dir;
    QSettings::setPath(QSettings::IniFormat, QSettings::UserScope, settings_dir.path());
    const QStringList size = parser.value(sim_size).split('x');
    if (size.size() != 2 || size[0].toInt() < 64 || size[1].toInt() < 64) {
      std::fprintf(stderr, "scanbench-gui: --screenshot-size must be WxH, each at least 64, not %s\n",
                   qPrintable(parser.value(sim_size)));
      return 1;
    }
    scanbench::MainWindow window;
    try {
      return scanbench::ScreenshotTour(window, parser.value(screenshots), QSize(size[0].toInt(), size[1].toInt()));
    } catch (const std::exception& error) {
      std::fprintf(stderr, "scanbench-gui: %s\n", error.what());
      return 1;
    }
  }

  scanbench::MainWindow window;
  window.show();
  return app.exec();
}
