// Capture: a new session (folder, sample name, notes) or the resume of an
// interrupted one, run by CaptureController on the bench the Devices page
// connected; a thumbnail per light appears as its frame is journalled, and
// a finished session can be solved from here, or is solved while it is
// captured ("Solve while capturing", LiveSolveController). Whether the folder
// takes a new capture or a resume is app/session/capture_folder.h's rule, the
// CLI's; the page says why a button is off.
#pragma once

#include <QWidget>

#include <filesystem>
#include <set>
#include <string>

class QCheckBox;
class QGridLayout;
class QLabel;
class QLineEdit;
class QPlainTextEdit;
class QProgressBar;
class QPushButton;
class QTimer;

namespace scanbench {

class ControllerRunner;
class DevicesPage;
struct CaptureSummary;

class CapturePage : public QWidget {
  Q_OBJECT

 public:
  CapturePage(ControllerRunner* runner, DevicesPage* devices, QWidget* parent = nullptr);

  void SetSessionFolder(const QString& folder);
  void LoadSettings();
  void SaveSettings() const;

 signals:
  // A solve of the captured session finished into `result_dir`.
  void ResultReady(const QString& result_dir);

 public slots:
  void StartNew();
  void Resume();
  void Solve();

 private:
  void StartCapture(bool resume);
  void ReportCaptured(const CaptureSummary& summary);
  void PollFrames();
  void ResetThumbnails();
  void UpdateButtons();
  // A new folder typed or chosen: the previous session's thumbnails, summary
  // and progress go; the frames the new one already has are shown.
  void FolderChanged();
  // The end of a job in the stage line: "Capture finished in 3.2 s".
  void ShowJobEnd(const QString& job, int outcome);
  void SetStatus(const QString& text, bool error = false);
  std::filesystem::path SessionDir() const;

  ControllerRunner* runner_;
  DevicesPage* devices_;
  QLineEdit* folder_;
  QLineEdit* sample_name_;
  QPlainTextEdit* notes_;
  QCheckBox* check_exposure_;
  QCheckBox* solve_while_capturing_;
  QPushButton* start_;
  QPushButton* resume_;
  QPushButton* cancel_;
  QPushButton* solve_;
  QProgressBar* progress_;
  QLabel* stage_;
  QLabel* blocked_;  // why Start capture / Resume cannot run now; hidden when both can
  QLabel* status_;
  QGridLayout* thumbnails_;
  QTimer* poll_;
  bool capturing_ = false;
  bool solving_ = false;
  std::set<std::string> shown_frames_;  // files already thumbnailed
};

}  // namespace scanbench
