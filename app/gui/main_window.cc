#include "app/gui/main_window.h"

#include <QCloseEvent>
#include <QLabel>
#include <QMessageBox>
#include <QProgressBar>
#include <QSettings>
#include <QStatusBar>
#include <QTabWidget>

#include <filesystem>

#include "app/gui/calibration_page.h"
#include "app/gui/capture_page.h"
#include "app/gui/controller_runner.h"
#include "app/gui/devices_page.h"
#include "app/gui/results_page.h"
#include "app/gui/sessions_page.h"

namespace scanbench {

MainWindow::MainWindow(QWidget* parent) : QMainWindow(parent) {
  setWindowTitle(tr("scanbench — operator"));
  runner_ = new ControllerRunner(this);
  tabs_ = new QTabWidget(this);
  tabs_->setObjectName("pages");
  devices_ = new DevicesPage(runner_, tabs_);
  capture_ = new CapturePage(runner_, devices_, tabs_);
  results_ = new ResultsPage(runner_, tabs_);
  sessions_ = new SessionsPage(runner_, tabs_);
  tabs_->addTab(devices_, tr("Devices"));
  tabs_->addTab(capture_, tr("Capture"));
  tabs_->addTab(results_, tr("Results"));
  tabs_->addTab(sessions_, tr("Sessions"));
  calibration_ = new CalibrationPage(runner_, devices_, tabs_);
  tabs_->addTab(calibration_, tr("Calibration"));
  setCentralWidget(tabs_);

  job_label_ = new QLabel(tr("Idle"), this);
  job_label_->setObjectName("jobStatus");
  job_progress_ = new QProgressBar(this);
  job_progress_->setObjectName("jobProgress");
  job_progress_->setRange(0, 1000);
  job_progress_->setMaximumWidth(220);
  job_progress_->setTextVisible(false);
  statusBar()->addWidget(job_label_, 1);
  statusBar()->addPermanentWidget(job_progress_);
  // One bar for the whole job (its stages named in the text), and an end
  // that says how it ended.
  connect(runner_, &ControllerRunner::Started, this, [this](const QString& name) {
    job_label_->setText(tr("%1…").arg(name));
    job_progress_->setValue(0);
  });
  connect(runner_, &ControllerRunner::JobProgressChanged, this, [this](double fraction, const QString& text) {
    job_label_->setText(tr("%1: %2").arg(runner_->job_name(), text));
    job_progress_->setValue(int(fraction * 1000));
  });
  connect(runner_, &ControllerRunner::Finished, this,
          [this](ControllerRunner::Outcome outcome, const QString& message) {
            const QString seconds = QString::number(runner_->job_seconds(), 'f', 1);
            job_progress_->setValue(outcome == ControllerRunner::Outcome::kSucceeded ? 1000 : 0);
            job_label_->setText(outcome == ControllerRunner::Outcome::kSucceeded
                                    ? tr("%1 finished in %2 s").arg(runner_->job_name(), seconds)
                                : outcome == ControllerRunner::Outcome::kCancelled
                                    ? tr("%1 cancelled after %2 s").arg(runner_->job_name(), seconds)
                                    : tr("%1 failed: %2").arg(runner_->job_name(), message));
          });

  auto open_result = [this](const QString& result_dir) {
    results_->OpenResult(result_dir);
    ShowPage(kResultsPage);
  };
  connect(capture_, &CapturePage::ResultReady, this, [this, open_result](const QString& result_dir) {
    // The session's parent becomes the browsed folder, so the new session is listed.
    const std::filesystem::path session = std::filesystem::path(result_dir.toStdString()).parent_path().parent_path();
    sessions_->SetRoot(QString::fromStdString(session.parent_path().string()));
    sessions_->SelectSession(QString::fromStdString(session.string()));
    open_result(result_dir);
  });
  connect(sessions_, &SessionsPage::OpenResult, this, open_result);
  connect(sessions_, &SessionsPage::ResumeCapture, this, [this](const QString& session_dir) {
    capture_->SetSessionFolder(session_dir);
    ShowPage(kCapturePage);
  });
  // A finished calibration set becomes the solve's (the Sessions page's field).
  connect(calibration_, &CalibrationPage::UseCalibrationSet, this, [this](const QString& calibration_dir) {
    sessions_->SetCalibrationSet(calibration_dir);
    ShowPage(kSessionsPage);
  });
  LoadSettings();
}

MainWindow::~MainWindow() = default;

void MainWindow::ShowPage(Page page) { tabs_->setCurrentIndex(int(page)); }

void MainWindow::LoadSettings() {
  QSettings settings;
  if (!restoreGeometry(settings.value("window/geometry").toByteArray())) resize(1280, 820);
  tabs_->setCurrentIndex(settings.value("window/page", 0).toInt());
  devices_->LoadSettings();
  capture_->LoadSettings();
  sessions_->LoadSettings();
  calibration_->LoadSettings();
}

void MainWindow::SaveSettings() const {
  QSettings settings;
  settings.setValue("window/geometry", saveGeometry());
  settings.setValue("window/page", tabs_->currentIndex());
  devices_->SaveSettings();
  capture_->SaveSettings();
  sessions_->SaveSettings();
  calibration_->SaveSettings();
}

void MainWindow::closeEvent(QCloseEvent* event) {
  if (runner_->busy()) {
    // Closing mid-capture would leave the journal as it is (resumable), but
    // the operator should decide that, not a stray click.
    const auto answer = QMessageBox::question(
        this, tr("Job running"), tr("%1 is running. Cancel it and quit?").arg(runner_->job_name()));
    if (answer != QMessageBox::Yes) {
      event->ignore();
      return;
    }
    runner_->Cancel();
    runner_->Wait(30000);
  }
  SaveSettings();
  event->accept();
}

}  // namespace scanbench
