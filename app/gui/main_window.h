// The operator's window: Devices, Capture, Results, Sessions and Calibration pages over
// one ControllerRunner, so that one long job runs at a time (the bench has
// one camera and one LED board) while the window stays responsive.
#pragma once

#include <QMainWindow>

class QLabel;
class QProgressBar;
class QTabWidget;

namespace scanbench {

class CalibrationPage;
class CapturePage;
class ControllerRunner;
class DevicesPage;
class ResultsPage;
class SessionsPage;

class MainWindow : public QMainWindow {
  Q_OBJECT

 public:
  enum Page { kDevicesPage, kCapturePage, kResultsPage, kSessionsPage, kCalibrationPage };

  explicit MainWindow(QWidget* parent = nullptr);
  ~MainWindow() override;

  ControllerRunner* runner() const { return runner_; }
  DevicesPage* devices() const { return devices_; }
  CapturePage* capture() const { return capture_; }
  ResultsPage* results() const { return results_; }
  SessionsPage* sessions() const { return sessions_; }
  CalibrationPage* calibration() const { return calibration_; }
  void ShowPage(Page page);

  void SaveSettings() const;

 protected:
  void closeEvent(QCloseEvent* event) override;

 private:
  void LoadSettings();

  ControllerRunner* runner_;
  QTabWidget* tabs_;
  DevicesPage* devices_;
  CapturePage* capture_;
  ResultsPage* results_;
  SessionsPage* sessions_;
  CalibrationPage* calibration_;
  QLabel* job_label_;
  QProgressBar* job_progress_;
};

}  // namespace scanbench
