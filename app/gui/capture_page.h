// Capture: a new session (folder, sample name, notes) or the resume of an
// interrupted one, run by CaptureController on the bench the Devices page
// connected; a thumbnail per light appears as its frame is journalled, and
// a finished session can be solved from here, or is solved while it is
// captured ("Solve while capturing", LiveSolveController). Whether the folder
// takes a new capture or a resume is app/session/capture_folder.h's rule, the
// CLI's; the page says why a button is off. The exposure (ISO, shutter
// speed, aperture) is chosen from the values the connected camera allows
// (ExposureChoicesOf, as `camera info` lists them), each "leave the camera's"
// by default, and carried into CaptureOptions.exposure as the CLI's
// `capture --iso / --exposure-time / --f-number` are.
#pragma once

#include <QWidget>

#include <array>
#include <filesystem>
#include <set>
#include <string>

class QCheckBox;
class QComboBox;
class QGridLayout;
class QLabel;
class QLineEdit;
class QPlainTextEdit;
class QProgressBar;
class QPushButton;
class QTimer;

namespace scanbench {

class Bench;
class ControllerRunner;
class DevicesPage;
struct CaptureSummary;
struct ExposureSettings;

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
  // The exposure box after a connect or disconnect: the camera's values,
  // the operator's choice kept where the camera allows it, or why not.
  void ShowExposureChoices();
  // The chosen values as CaptureOptions.exposure's numbers; false (and the
  // reason on the page) if one is not the camera's.
  bool ExposureFromWidgets(const Bench& bench, ExposureSettings* exposure);

  ControllerRunner* runner_;
  DevicesPage* devices_;
  QLineEdit* folder_;
  QLineEdit* sample_name_;
  QPlainTextEdit* notes_;
  QCheckBox* check_exposure_;
  QCheckBox* solve_while_capturing_;
  std::array<QComboBox*, 3> exposure_{};  // ISO, shutter speed, aperture; data "" = leave the camera's
  std::array<QString, 3> chosen_;         // the operator's last choice, kept over a reconnect
  bool filling_exposure_ = false;         // ShowExposureChoices is refilling the boxes
  QLabel* exposure_note_;                 // why a setting cannot be chosen; hidden when all can
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
