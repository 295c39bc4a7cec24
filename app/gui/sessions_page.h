// Sessions: the sessions in a folder (sample, frames, complete, results),
// their result folders, open one in Results, re-solve into a new result
// folder, resume an interrupted capture, or import a folder of RAW files
// (ImportController) as a new session of the listed folder.
#pragma once

#include <QWidget>
#include <filesystem>

#include "app/controllers/solve_controller.h"

class QComboBox;
class QDoubleSpinBox;
class QLabel;
class QLayout;
class QLineEdit;
class QListWidget;
class QProgressBar;
class QPushButton;
class QTreeWidget;

namespace scanbench {

class ControllerRunner;
class ExportDialog;

class SessionsPage : public QWidget {
  Q_OBJECT

 public:
  SessionsPage(ControllerRunner* runner, QWidget* parent = nullptr);

  void SetRoot(const QString& folder);
  // Selects the session in `session_dir` if listed.
  bool SelectSession(const QString& session_dir);
  void LoadSettings();
  void SaveSettings() const;
  // The solve's options as the form sets them (method, shadow level,
  // calibration set); not checked.
  SolveOptions SolveOptionsFromWidgets() const;
  // The calibration set the next re-solve uses ("" = the session's rig).
  void SetCalibrationSet(const QString& calibration_dir);
  // Opens the export dialog for the selected result folder (nullptr if none).
  ExportDialog* ExportSelectedResult();
  // Imports `raw_folder` (capture order, or `pattern` when not empty) with the
  // rig description `rig_file` into <listed folder>/<raw folder's name>, or
  // resumes that import; false (with the reason in the status line) when it
  // could not start. The "Import RAW folder…" button asks for the two paths.
  bool ImportRawFolder(const QString& raw_folder, const QString& rig_file, const QString& pattern = {});

 signals:
  void OpenResult(const QString& result_dir);
  void ResumeCapture(const QString& session_dir);

 public slots:
  void Refresh();
  void Resolve();

 private:
  // The constructor's steps, top to bottom; each builds one row or panel
  // and connects its own widgets.
  QLayout* MakeFolderRow();
  QWidget* MakeLists();
  QLayout* MakeSolveForm();
  QLayout* MakeMethodRow(const SolveOptions& defaults);
  QLayout* MakeShadowRow(const SolveOptions& defaults);
  QLayout* MakeButtonRow();
  QProgressBar* MakeProgressBar();

  std::filesystem::path SelectedSession() const;
  void ShowResults();
  void SetStatus(const QString& text, bool error = false);

  ControllerRunner* runner_;
  QLineEdit* root_;
  QTreeWidget* sessions_;
  QListWidget* results_;
  QLineEdit* calibration_;
  QComboBox* method_;
  QLabel* method_description_;
  QDoubleSpinBox* shadow_level_;
  QPushButton* export_;
  QPushButton* open_;
  QPushButton* resolve_;
  QPushButton* resume_;
  QPushButton* import_;
  QProgressBar* progress_;
  QLabel* status_;
  bool solving_ = false;  // a re-solve or an import of this page runs (its progress is shown)
};

}  // namespace scanbench
