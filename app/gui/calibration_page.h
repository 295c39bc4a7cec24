// Calibration: the calibrations of docs/calibration.md as steps of one page —
// camera (checkerboard poses), white balance (gray chart), lights (white sheet
// on the table and on a spacer) and, optional, colour (a ColorChecker session
// or RAW photo; its patch table and before / after swatches) — into one
// calibration set folder. Each
// step says what target to place and how, takes its target sessions (rendered
// on the simulated bench with one button, or found in / added from folders of
// captured target sessions), runs its controller through ControllerRunner, and
// shows the summary's figures, each marked pass / warn / fail against
// calibration_quality.h's limits with what to fix when it is bad. A complete
// set (camera, white balance, lights) is offered to the solve
// (UseCalibrationSet).
#pragma once

#include <QString>
#include <QStringList>
#include <QWidget>

#include <array>
#include <filesystem>
#include <functional>
#include <memory>
#include <vector>

class QCheckBox;
class QDoubleSpinBox;
class QLabel;
class QLayout;
class QLineEdit;
class QListWidget;
class QProgressBar;
class QPushButton;
class QScrollArea;
class QSpinBox;
class QStackedWidget;
class QTableWidget;
class QTreeWidget;

namespace scanbench {

class BaseController;
class ControllerRunner;
class DevicesPage;
struct ColorCorrectionSummary;
struct QualityFigure;

class CalibrationPage : public QWidget {
  Q_OBJECT

 public:
  enum Step { kCameraStep, kWhiteStep, kLightsStep, kColorStep, kStepCount };

  CalibrationPage(ControllerRunner* runner, DevicesPage* devices, QWidget* parent = nullptr);

  // The calibration set folder; shows what an existing set there holds.
  void SetCalibrationFolder(const QString& folder);
  QString calibration_folder() const;
  // The folder of target sessions; fills every step with the sessions of its
  // kind found there (target.json).
  void SetTargetsFolder(const QString& folder);
  void ShowStep(Step step);
  void LoadSettings();
  void SaveSettings() const;

 signals:
  // The operator chose to solve with the set in `calibration_dir` (complete:
  // camera, white balance and lights).
  void UseCalibrationSet(const QString& calibration_dir);

 public slots:
  void RenderSimulatedTargets();
  void FindTargets();
  void RunStep(int step);
  void ReloadSet();

 private:
  struct StepWidgets {
    QListWidget* sessions = nullptr;
    QPushButton* run = nullptr;
    QLabel* status = nullptr;
    QTreeWidget* figures = nullptr;
    QLabel* hints = nullptr;
    QScrollArea* hints_area = nullptr;
    QDoubleSpinBox* spacer_mm = nullptr;  // lights only
    // Colour only: the per-patch table, its mean / max line, the swatches.
    QTableWidget* patches = nullptr;
    QLabel* patch_stats = nullptr;
    QLabel* swatches = nullptr;
  };

  // The page's parts; each step's differences are its entry in the step table
  // (calibration_page.cc).
  QWidget* MakeSetBox();
  QWidget* MakeTargetsBox();
  QSpinBox* MakeSizeBox(const char* name, int value, QWidget* parent);
  QWidget* MakeSteps();
  QLayout* MakeProgressRow();
  void ConnectRunner();
  QWidget* MakeStep(Step step);
  QLayout* MakeSessionList(Step step, QWidget* page);
  QLayout* MakeDescribeRow(Step step, QWidget* page);
  QLayout* MakeRunRow(Step step, QWidget* page);
  void MakeFigures(Step step, QWidget* page);
  QLayout* MakeColorPatches(Step step, QWidget* page);

  void AddSessions(Step step, const QStringList& folders);
  void AddFromFolder(Step step);
  // Colour: single RAW photos of a ColorChecker, beside (or instead of) sessions.
  void AddRawPhotos(Step step);
  // Writes the standard target's target.json into each selected session that
  // has none (a capture made on the real bench): DescribeTargetSessions.
  void DescribeSelected(Step step);
  // Figures and (colour) the patch table on success, status and hints of a
  // finished run.
  void FinishStep(Step step, const QString& set_name, const std::vector<QualityFigure>& figures,
                  const ColorCorrectionSummary* color, bool ok, bool cancelled, const QString& message);
  // Every required step's section (camera, white balance, lights) is in the set on disk.
  bool SetComplete() const;
  QStringList Sessions(Step step) const;
  void ShowFigures(Step step, const std::vector<QualityFigure>& figures);
  // The colour step's patch table, mean / max and swatches of `fit`.
  void ShowColorPatches(Step step, const ColorCorrectionSummary& fit);
  // Figures, hints and (colour) the patch table.
  void ClearFigures(Step step);
  // The hints' area as tall as its text, up to a few lines (then it scrolls).
  void FitHints(Step step);
  void SetStepStatus(Step step, const QString& text, bool error = false);
  void SetTargetsStatus(const QString& text, bool error = false);
  void UpdateStepList();
  void UpdateButtons();
  // `job`: a Step or kTargetsJob. False if another job runs (said on the page).
  bool StartJob(int job, std::shared_ptr<BaseController> controller, const QString& name,
                std::function<void(bool succeeded, bool cancelled, const QString& message)> done);
  std::filesystem::path SetDir() const;

  ControllerRunner* runner_;
  DevicesPage* devices_;
  QWidget* set_box_;
  QWidget* targets_box_;
  QLineEdit* set_folder_;
  QString loaded_folder_;  // the folder whose set the steps show
  QCheckBox* replace_;
  QLabel* set_state_;
  QPushButton* use_set_;
  QLineEdit* targets_folder_;
  QSpinBox* sim_width_;
  QSpinBox* sim_height_;
  QPushButton* render_;
  QPushButton* find_;
  QLabel* targets_status_;
  QListWidget* step_list_;
  QStackedWidget* stack_;
  std::array<StepWidgets, kStepCount> steps_;
  QProgressBar* progress_;
  QLabel* stage_;
  QPushButton* cancel_;
  // What the set on disk holds, and the worst mark of each step's figures
  // (-1: none shown).
  std::array<bool, kStepCount> done_{};
  std::array<int, kStepCount> worst_;
  // Why the set's colour section is stale (StaleColorReason); empty when it is not.
  QString color_stale_;
  // The step whose job runs, or kTargetsJob, or kNoJob (none of this page's).
  static constexpr int kTargetsJob = -1;
  static constexpr int kNoJob = -2;
  int running_ = kNoJob;
};

}  // namespace scanbench
