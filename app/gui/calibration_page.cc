#include "app/gui/calibration_page.h"

#include <QBrush>
#include <QCheckBox>
#include <QColor>
#include <QDir>
#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QLineEdit>
#include <QListWidget>
#include <QProgressBar>
#include <QPushButton>
#include <QScrollArea>
#include <QSettings>
#include <QSpinBox>
#include <QSplitter>
#include <QStackedWidget>
#include <QTreeWidget>
#include <QVBoxLayout>

#include <algorithm>
#include <map>
#include <numeric>

#include "app/controllers/calibration_controllers.h"
#include "app/controllers/simulate_targets_controller.h"
#include "app/gui/bench.h"
#include "app/gui/calibration_quality.h"
#include "app/gui/controller_runner.h"
#include "app/gui/devices_page.h"
#include "app/session/calibration_set.h"
#include "app/session/calibration_target.h"
#include "app/session/session.h"

namespace scanbench {
namespace fs = std::filesystem;
using Mark = QualityFigure::Mark;

namespace {

enum FigureColumn { kFigureName, kFigureValue, kFigureLimit, kFigureMark, kFigureColumns };
constexpr int kValueRole = Qt::UserRole;     // the figure's number (column kFigureValue)
constexpr int kMarkRole = Qt::UserRole + 1;  // its QualityFigure::Mark (column kFigureMark)

const char* const kStepPrefix[] = {"camera", "white", "lights"};
const char* const kStepTitle[] = {"Camera", "White balance", "Lights"};

CalibrationTargetDescription::Kind StepKind(int step) {
  if (step == CalibrationPage::kCameraStep) return CalibrationTargetDescription::Kind::kCheckerboard;
  if (step == CalibrationPage::kWhiteStep) return CalibrationTargetDescription::Kind::kGrayChart;
  return CalibrationTargetDescription::Kind::kWhiteSheet;
}

CalibrationStep QualityStep(int step) {
  if (step == CalibrationPage::kCameraStep) return CalibrationStep::kCamera;
  if (step == CalibrationPage::kWhiteStep) return CalibrationStep::kWhiteBalance;
  return CalibrationStep::kLights;
}

QColor MarkBackground(Mark mark) {
  switch (mark) {
    case Mark::kPass: return QColor("#d5f5e3");
    case Mark::kWarn: return QColor("#fcf3cf");
    case Mark::kFail: return QColor("#fadbd8");
    case Mark::kInfo: break;
  }
  return QColor();
}

QColor MarkForeground(Mark mark) {
  switch (mark) {
    case Mark::kPass: return QColor("#1e8449");
    case Mark::kWarn: return QColor("#9a7d0a");
    case Mark::kFail: return QColor("#c0392b");
    case Mark::kInfo: break;
  }
  return QColor();
}

void SetMark(QTreeWidgetItem* item, Mark mark) {
  item->setText(kFigureMark, QString::fromLatin1(QualityMarkName(mark)));
  item->setData(kFigureMark, kMarkRole, int(mark));
  if (mark != Mark::kInfo) {
    item->setBackground(kFigureMark, MarkBackground(mark));
    item->setForeground(kFigureMark, MarkForeground(mark));
  }
}

// The target sessions in `folder` (itself, or its sub-folders) of each kind,
// sorted by folder name. Unreadable target.json files are skipped here: the
// calibration names what is wrong with them if they are chosen anyway.
std::map<CalibrationTargetDescription::Kind, QStringList> TargetSessionsIn(const fs::path& folder) {
  std::map<CalibrationTargetDescription::Kind, QStringList> found;
  std::vector<fs::path> dirs;
  std::error_code error;
  if (fs::exists(folder / kCalibrationTargetFileName, error)) dirs.push_back(folder);
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    if (entry.is_directory() && fs::exists(entry.path() / kCalibrationTargetFileName)) dirs.push_back(entry.path());
  }
  std::sort(dirs.begin(), dirs.end());
  for (const fs::path& dir : dirs) {
    try {
      found[LoadCalibrationTarget(dir).kind].push_back(QString::fromStdString(dir.string()));
    } catch (const std::exception&) {
    }
  }
  return found;
}

// The rig description a light calibration started from: the first white
// sheet session's (empty when it cannot be read any more).
std::vector<LedDescription> MeasuredLeds(const std::string& session_dir) {
  try {
    return LoadSession(session_dir, SessionLoadOptions{.verify_checksums = false}).rig.leds;
  } catch (const std::exception&) {
    return {};
  }
}

}  // namespace

CalibrationPage::CalibrationPage(ControllerRunner* runner, DevicesPage* devices, QWidget* parent)
    : QWidget(parent), runner_(runner), devices_(devices) {
  // The set: created by step 1, completed by steps 2 and 3.
  auto* set_box = new QGroupBox(tr("Calibration set"), this);
  set_box_ = set_box;
  auto* set_layout = new QVBoxLayout(set_box);
  set_folder_ = new QLineEdit(set_box);
  set_folder_->setObjectName("calibrationSet");
  set_folder_->setPlaceholderText(tr("a new folder for a new set, or an existing set to complete or review"));
  auto* browse_set = new QPushButton(tr("Browse…"), set_box);
  replace_ = new QCheckBox(tr("Replace an existing set (step 1 starts it anew)"), set_box);
  replace_->setObjectName("replaceSet");
  auto* set_row = new QHBoxLayout;
  set_row->addWidget(new QLabel(tr("Folder"), set_box));
  set_row->addWidget(set_folder_, 1);
  set_row->addWidget(browse_set);
  set_row->addWidget(replace_);
  set_state_ = new QLabel(set_box);
  set_state_->setObjectName("calibrationSetState");
  set_state_->setWordWrap(true);
  use_set_ = new QPushButton(tr("Use this set for solves"), set_box);
  use_set_->setObjectName("useCalibrationSet");
  use_set_->setToolTip(tr("Puts the set into the Sessions page's calibration field"));
  auto* state_row = new QHBoxLayout;
  state_row->addWidget(set_state_, 1);
  state_row->addWidget(use_set_);
  set_layout->addLayout(set_row);
  set_layout->addLayout(state_row);

  // Where the target sessions are.
  auto* targets_box = new QGroupBox(tr("Target sessions"), this);
  targets_box_ = targets_box;
  auto* targets_layout = new QVBoxLayout(targets_box);
  targets_folder_ = new QLineEdit(targets_box);
  targets_folder_->setObjectName("targetsFolder");
  targets_folder_->setPlaceholderText(tr("the folder holding the target sessions (one sub-folder each)"));
  auto* browse_targets = new QPushButton(tr("Browse…"), targets_box);
  find_ = new QPushButton(tr("Find target sessions"), targets_box);
  find_->setObjectName("findTargets");
  auto* targets_row = new QHBoxLayout;
  targets_row->addWidget(new QLabel(tr("Folder"), targets_box));
  targets_row->addWidget(targets_folder_, 1);
  targets_row->addWidget(browse_targets);
  targets_row->addWidget(find_);
  render_ = new QPushButton(tr("Render simulated targets"), targets_box);
  render_->setObjectName("renderTargets");
  render_->setToolTip(tr("Simulated bench: writes every target session (checkerboard poses, gray chart, white "
                         "sheets) into the folder, as scanbench calibrate simulate-targets does"));
  sim_width_ = new QSpinBox(targets_box);
  sim_width_->setObjectName("targetsWidth");
  sim_width_->setRange(64, 8192);
  sim_width_->setValue(1232);
  sim_height_ = new QSpinBox(targets_box);
  sim_height_->setObjectName("targetsHeight");
  sim_height_->setRange(64, 8192);
  sim_height_->setValue(816);
  auto* render_row = new QHBoxLayout;
  render_row->addWidget(render_);
  render_row->addWidget(sim_width_);
  render_row->addWidget(new QLabel(tr("×"), targets_box));
  render_row->addWidget(sim_height_);
  auto* how = new QLabel(
      tr("Simulated bench: <b>Render simulated targets</b> writes all of them. Real bench: capture each target as "
         "a session on the Capture page, then <b>Find target sessions</b> in their folder or <b>Add…</b> them to "
         "a step; a capture without a target.json becomes a target with <b>Describe selected as …</b>."),
      targets_box);
  how->setWordWrap(true);
  render_row->addWidget(how, 1);
  targets_status_ = new QLabel(targets_box);
  targets_status_->setObjectName("targetsStatus");
  targets_status_->setWordWrap(true);
  targets_layout->addLayout(targets_row);
  targets_layout->addLayout(render_row);
  targets_layout->addWidget(targets_status_);

  // The steps.
  step_list_ = new QListWidget(this);
  step_list_->setObjectName("calibrationSteps");
  step_list_->setMaximumWidth(200);
  stack_ = new QStackedWidget(this);
  stack_->addWidget(MakeStep(
      kCameraStep, "camera",
      tr("<b>Target:</b> the checkerboard (9 × 6 inner corners, 9 mm squares), flat: mounted on glass or stiff "
         "card. <b>Capture</b> one session per pose, all LEDs as for a scan: first the board <b>lying flat on the "
         "table</b>, its rows along the image's x (this view places the table); then 5 to 8 more with the board "
         "<b>tilted 20–35°</b> in different directions, at different places in the view. The whole board must be "
         "visible and sharp in every pose. This step starts the calibration set."),
      tr("Run camera calibration")));
  stack_->addWidget(MakeStep(
      kWhiteStep, "white",
      tr("<b>Target:</b> the matte <b>gray chart</b> (Munsell neutral value scale, N2 to N9.5) lying flat at the "
         "centre of the table, where its target.json puts the patches. <b>Capture</b> one session, all LEDs, at "
         "the exposure of a scan. Keep the chart clean, without glare or shadow. Needs step 1 in this set."),
      tr("Run white balance")));
  stack_->addWidget(MakeStep(
      kLightsStep, "lights",
      tr("<b>Target:</b> a <b>99 % white sheet</b> (matte, no optical brighteners), flat and clean, filling the "
         "view. <b>Capture</b> two sessions, all LEDs: the sheet <b>on the table</b>, then on the <b>spacer</b> "
         "(40 mm, the height its target.json states). Nothing may clip at the scan's exposure. Needs step 1."),
      tr("Run light calibration")));
  for (int step = 0; step < kStepCount; ++step) step_list_->addItem(QString());
  auto* splitter = new QSplitter(Qt::Horizontal, this);
  splitter->addWidget(step_list_);
  splitter->addWidget(stack_);
  splitter->setStretchFactor(1, 1);

  progress_ = new QProgressBar(this);
  progress_->setObjectName("calibrationProgress");
  progress_->setRange(0, 1000);
  progress_->setTextVisible(false);
  stage_ = new QLabel(this);
  cancel_ = new QPushButton(tr("Cancel"), this);
  cancel_->setObjectName("cancelCalibration");
  auto* progress_row = new QHBoxLayout;
  progress_row->addWidget(progress_, 1);
  progress_row->addWidget(stage_);
  progress_row->addWidget(cancel_);

  auto* layout = new QVBoxLayout(this);
  layout->addWidget(set_box);
  layout->addWidget(targets_box);
  layout->addWidget(splitter, 1);
  layout->addLayout(progress_row);

  connect(browse_set, &QPushButton::clicked, this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(this, tr("Calibration set folder"), set_folder_->text());
    if (!dir.isEmpty()) SetCalibrationFolder(dir);
  });
  connect(set_folder_, &QLineEdit::editingFinished, this, [this] {
    if (set_folder_->text() != loaded_folder_) SetCalibrationFolder(set_folder_->text());
  });
  connect(use_set_, &QPushButton::clicked, this, [this] { emit UseCalibrationSet(calibration_folder()); });
  connect(browse_targets, &QPushButton::clicked, this, [this] {
    const QString dir =
        QFileDialog::getExistingDirectory(this, tr("Folder of target sessions"), targets_folder_->text());
    if (!dir.isEmpty()) SetTargetsFolder(dir);
  });
  connect(find_, &QPushButton::clicked, this, &CalibrationPage::FindTargets);
  connect(render_, &QPushButton::clicked, this, &CalibrationPage::RenderSimulatedTargets);
  connect(step_list_, &QListWidget::currentRowChanged, stack_, &QStackedWidget::setCurrentIndex);
  connect(cancel_, &QPushButton::clicked, this, [this] {
    if (running_ != kNoJob) runner_->Cancel();
  });
  connect(runner_, &ControllerRunner::Progress, this,
          [this](const QString& stage, double fraction, const QString& detail) {
    if (running_ == kNoJob) return;
    progress_->setValue(int(fraction * 1000));
    stage_->setText(ProgressText(stage, detail, fraction));
  });
  connect(runner_, &ControllerRunner::Started, this, &CalibrationPage::UpdateButtons);
  connect(runner_, &ControllerRunner::Finished, this, &CalibrationPage::UpdateButtons);
  // Simulated targets are rendered at the simulated camera's size, so that
  // the set fits the sessions captured on this bench.
  connect(devices_, &DevicesPage::BenchChanged, this, [this] {
    Bench* bench = devices_->bench();
    if (bench && bench->options().simulated_camera) {
      sim_width_->setValue(bench->options().sim_width);
      sim_height_->setValue(bench->options().sim_height);
    }
  });
  step_list_->setCurrentRow(0);
  UpdateStepList();
  ReloadSet();
}

QWidget* CalibrationPage::MakeStep(Step step, const QString& prefix, const QString& instructions,
                                   const QString& run_text) {
  auto* page = new QWidget(this);
  StepWidgets& w = steps_[step];
  auto* text = new QLabel(instructions, page);
  text->setWordWrap(true);
  text->setTextFormat(Qt::RichText);

  w.sessions = new QListWidget(page);
  w.sessions->setObjectName(prefix + "Sessions");
  w.sessions->setSelectionMode(QAbstractItemView::ExtendedSelection);
  w.sessions->setMaximumHeight(step == kWhiteStep ? 30 : step == kLightsStep ? 48 : 84);
  auto* add = new QPushButton(tr("Add…"), page);
  add->setObjectName(prefix + "Add");
  auto* remove = new QPushButton(tr("Remove"), page);
  remove->setObjectName(prefix + "Remove");
  auto* list_buttons = new QVBoxLayout;
  list_buttons->addWidget(add);
  list_buttons->addWidget(remove);
  list_buttons->addStretch();
  auto* list_row = new QHBoxLayout;
  list_row->addWidget(w.sessions, 1);
  list_row->addLayout(list_buttons);

  // Real bench: a capture of the target becomes a target session.
  auto* describe = new QPushButton(tr("Describe selected as %1").arg(step == kCameraStep ? tr("board poses")
                                                                     : step == kWhiteStep ? tr("the gray chart")
                                                                                          : tr("white sheets")),
                                   page);
  describe->setObjectName(prefix + "Describe");
  describe->setToolTip(
      step == kCameraStep
          ? tr("Writes target.json (9 × 6 inner corners, 9 mm squares) into each selected session without one; the "
               "first becomes the board lying on the table unless a listed session already is")
      : step == kWhiteStep
          ? tr("Writes target.json (the Munsell neutral scale, centred on the table) into the selected session")
          : tr("Writes target.json (99 % sheet) into each selected session without one: the first on the table "
               "unless a listed session already is, the others on the spacer"));
  auto* describe_row = new QHBoxLayout;
  describe_row->addWidget(new QLabel(tr("Captured on the real bench, without a target.json?"), page));
  describe_row->addWidget(describe);
  if (step == kLightsStep) {
    w.spacer_mm = new QDoubleSpinBox(page);
    w.spacer_mm->setObjectName("spacerMm");
    w.spacer_mm->setRange(1, 200);
    w.spacer_mm->setValue(SimulateTargetsOptions().spacer_mm);
    w.spacer_mm->setSuffix(tr(" mm"));
    describe_row->addWidget(new QLabel(tr("spacer"), page));
    describe_row->addWidget(w.spacer_mm);
  }
  describe_row->addStretch();

  w.run = new QPushButton(run_text, page);
  w.run->setObjectName(prefix + "Run");
  auto* next = new QPushButton(step == kLightsStep ? tr("Use this set for solves") : tr("Next step →"), page);
  next->setObjectName(prefix + "Next");
  auto* run_row = new QHBoxLayout;
  run_row->addWidget(w.run);
  run_row->addStretch();
  run_row->addWidget(next);
  w.status = new QLabel(page);
  w.status->setObjectName(prefix + "Status");
  w.status->setWordWrap(true);
  w.status->setTextInteractionFlags(Qt::TextSelectableByMouse);

  w.figures = new QTreeWidget(page);
  w.figures->setObjectName(prefix + "Figures");
  w.figures->setColumnCount(kFigureColumns);
  w.figures->setHeaderLabels({tr("Figure"), tr("Value"), tr("Limit"), tr("Mark")});
  w.figures->header()->setSectionResizeMode(kFigureName, QHeaderView::ResizeToContents);
  w.figures->header()->setSectionResizeMode(kFigureValue, QHeaderView::Interactive);
  w.figures->header()->resizeSection(kFigureValue, 340);
  w.figures->header()->setSectionResizeMode(kFigureLimit, QHeaderView::Interactive);
  w.figures->header()->resizeSection(kFigureLimit, 230);
  w.figures->setAlternatingRowColors(true);
  w.hints = new QLabel(page);
  w.hints->setObjectName(prefix + "Hints");
  w.hints->setWordWrap(true);
  w.hints->setTextInteractionFlags(Qt::TextSelectableByMouse);
  w.hints->setAlignment(Qt::AlignTop | Qt::AlignLeft);
  w.hints_area = new QScrollArea(page);
  w.hints_area->setWidget(w.hints);
  w.hints_area->setWidgetResizable(true);
  w.hints_area->setFrameShape(QFrame::NoFrame);

  auto* layout = new QVBoxLayout(page);
  layout->addWidget(text);
  layout->addWidget(new QLabel(step == kWhiteStep ? tr("Target session") : tr("Target sessions"), page));
  layout->addLayout(list_row);
  layout->addLayout(describe_row);
  layout->addLayout(run_row);
  layout->addWidget(w.status);
  layout->addWidget(w.figures, 1);
  layout->addWidget(w.hints_area);

  connect(add, &QPushButton::clicked, this, [this, step] { AddFromFolder(step); });
  connect(describe, &QPushButton::clicked, this, [this, step] { DescribeSelected(step); });
  connect(remove, &QPushButton::clicked, this, [this, step] { qDeleteAll(steps_[step].sessions->selectedItems()); });
  connect(w.run, &QPushButton::clicked, this, [this, step] { RunStep(step); });
  connect(next, &QPushButton::clicked, this, [this, step] {
    if (step == kLightsStep) {
      if (use_set_->isEnabled()) emit UseCalibrationSet(calibration_folder());
    } else {
      ShowStep(Step(step + 1));
    }
  });
  return page;
}

fs::path CalibrationPage::SetDir() const { return fs::path(set_folder_->text().trimmed().toStdString()); }
QString CalibrationPage::calibration_folder() const { return set_folder_->text().trimmed(); }

void CalibrationPage::ShowStep(Step step) { step_list_->setCurrentRow(int(step)); }

void CalibrationPage::FitHints(Step step) {
  StepWidgets& w = steps_[step];
  const int width = std::max(w.hints_area->viewport()->width(), 400);
  const int text_height = w.hints->text().isEmpty() ? 0 : w.hints->heightForWidth(width);
  w.hints_area->setFixedHeight(std::clamp(text_height + 4, 4, 120));
}

void CalibrationPage::SetStepStatus(Step step, const QString& text, bool error) {
  steps_[step].status->setText(text);
  steps_[step].status->setStyleSheet(error ? QStringLiteral("color: #c0392b") : QString());
}

void CalibrationPage::SetTargetsStatus(const QString& text, bool error) {
  targets_status_->setText(text);
  targets_status_->setStyleSheet(error ? QStringLiteral("color: #c0392b") : QString());
}

// ---------------------------------------------------------------------------
// Target sessions

void CalibrationPage::AddSessions(Step step, const QStringList& folders) {
  QListWidget* list = steps_[step].sessions;
  if (step == kWhiteStep && !folders.isEmpty()) list->clear();  // one gray chart session
  for (const QString& folder : folders) {
    if (list->findItems(folder, Qt::MatchExactly).isEmpty()) list->addItem(folder);
    if (step == kWhiteStep) break;
  }
}

QStringList CalibrationPage::Sessions(Step step) const {
  QStringList folders;
  for (int i = 0; i < steps_[step].sessions->count(); ++i) folders << steps_[step].sessions->item(i)->text();
  return folders;
}

void CalibrationPage::AddFromFolder(Step step) {
  const QString dir = QFileDialog::getExistingDirectory(this, tr("Target session, or a folder of them"),
                                                        targets_folder_->text());
  if (dir.isEmpty()) return;
  const auto found = TargetSessionsIn(dir.toStdString());
  const auto it = found.find(StepKind(step));
  // A folder that is no target of this kind is added all the same: the run
  // then says what is wrong with it (a scan session has no target.json).
  AddSessions(step, it != found.end() ? it->second : QStringList{dir});
}

void CalibrationPage::DescribeSelected(Step step) {
  QListWidget* list = steps_[step].sessions;
  QList<QListWidgetItem*> selected = list->selectedItems();
  std::sort(selected.begin(), selected.end(),
            [list](QListWidgetItem* a, QListWidgetItem* b) { return list->row(a) < list->row(b); });
  if (selected.isEmpty()) {
    SetStepStatus(step, tr("Select the captured session(s) to describe in the list first."), true);
    return;
  }
  // Is one of the listed sessions already the target on the table?
  bool have_table_view = false;
  for (const QString& folder : Sessions(step)) {
    try {
      const CalibrationTargetDescription target = LoadCalibrationTarget(folder.toStdString());
      have_table_view |= target.kind == StepKind(step) &&
                         (step == kCameraStep ? target.on_table : target.white_sheet.height_mm == 0);
    } catch (const std::exception&) {
    }
  }
  QStringList written, kept;
  try {
    for (QListWidgetItem* item : selected) {
      const fs::path dir(item->text().toStdString());
      if (fs::exists(dir / kCalibrationTargetFileName)) {
        kept << item->text();  // never replaced: it may describe another target
        continue;
      }
      if (!fs::exists(dir / "session.json")) {
        throw std::runtime_error(item->text().toStdString() + " holds no session.json: capture it first");
      }
      CalibrationTargetDescription target;
      target.kind = StepKind(step);
      QString what;
      if (step == kCameraStep) {
        target.on_table = !have_table_view;
        have_table_view = true;
        what = target.on_table ? tr("the board lying on the table") : tr("a tilted board pose");
      } else if (step == kWhiteStep) {
        target.gray_chart = GrayChartTarget::MunsellNeutralScale();
        what = tr("the gray chart");
      } else {
        target.white_sheet.height_mm = have_table_view ? steps_[step].spacer_mm->value() : 0;
        have_table_view = true;
        what = target.white_sheet.height_mm == 0
                   ? tr("the sheet on the table")
                   : tr("the sheet on the %1 mm spacer").arg(target.white_sheet.height_mm);
      }
      WriteCalibrationTarget(dir, target);
      written << tr("%1 (%2)").arg(QString::fromStdString(dir.filename().string()), what);
    }
  } catch (const std::exception& error) {
    SetStepStatus(step, tr("Describe: %1").arg(error.what()), true);
    return;
  }
  QString text = written.isEmpty() ? tr("Nothing written.") : tr("target.json written: %1.").arg(written.join(", "));
  if (!kept.isEmpty()) {
    text += tr(" Kept the target.json of %1 (delete it by hand to describe again).").arg(kept.join(", "));
  }
  SetStepStatus(step, text);
}

void CalibrationPage::SetTargetsFolder(const QString& folder) {
  targets_folder_->setText(folder);
  FindTargets();
}

void CalibrationPage::FindTargets() {
  const fs::path folder(targets_folder_->text().trimmed().toStdString());
  std::error_code error;
  if (folder.empty() || !fs::is_directory(folder, error)) {
    SetTargetsStatus(tr("%1 is not a folder: choose the folder the target sessions are in, or render the "
                        "simulated ones into a new folder.")
                         .arg(targets_folder_->text()),
                     true);
    return;
  }
  const auto found = TargetSessionsIn(folder);
  QStringList counts;
  int total = 0;
  for (int step = 0; step < kStepCount; ++step) {
    const auto it = found.find(StepKind(step));
    const QStringList sessions = it == found.end() ? QStringList() : it->second;
    steps_[step].sessions->clear();
    AddSessions(Step(step), sessions);
    counts << tr("%1 %2").arg(sessions.size()).arg(QString::fromLatin1(CalibrationTargetKindName(StepKind(step))));
    total += int(sessions.size());
  }
  if (total == 0) {
    SetTargetsStatus(tr("No target sessions (folders with a target.json) in %1.").arg(targets_folder_->text()), true);
  } else {
    SetTargetsStatus(tr("%1 target session(s) in %2: %3.").arg(total).arg(targets_folder_->text(), counts.join(", ")));
  }
}

void CalibrationPage::RenderSimulatedTargets() {
  const QString folder = targets_folder_->text().trimmed();
  if (folder.isEmpty()) {
    SetTargetsStatus(tr("Choose a folder for the simulated target sessions first."), true);
    return;
  }
  SimulateTargetsOptions options;
  options.rig.width = sim_width_->value();
  options.rig.height = sim_height_->value();
  try {
    options.Check();
  } catch (const std::exception& error) {
    SetTargetsStatus(tr("Simulated targets: %1").arg(error.what()), true);
    return;
  }
  auto controller = std::make_shared<SimulateTargetsController>(folder.toStdString(), options);
  SetTargetsStatus(tr("Rendering the target sessions into %1…").arg(folder));
  StartJob(kTargetsJob, controller, tr("Simulate targets"),
           [this, controller, folder](bool ok, bool cancelled, const QString& message) {
             if (!ok) {
               SetTargetsStatus(cancelled ? tr("Rendering cancelled; render again to complete the sessions.")
                                          : tr("Simulated targets: %1").arg(message),
                                true);
               return;
             }
             FindTargets();
             const SimulateTargetsSummary& s = controller->summary();
             SetTargetsStatus(tr("%1 target session(s) rendered into %2 (%3 already there); each step has its "
                                 "sessions.")
                                  .arg(s.sessions_written)
                                  .arg(folder)
                                  .arg(s.sessions_skipped));
           });
}

// ---------------------------------------------------------------------------
// Runs

bool CalibrationPage::StartJob(int job, std::shared_ptr<BaseController> controller, const QString& name,
                               std::function<void(bool, bool, const QString&)> done) {
  running_ = job;
  progress_->setValue(0);
  stage_->clear();
  const bool started = runner_->Start(
      std::move(controller), name,
      [this, done = std::move(done)](ControllerRunner::Outcome outcome, const QString& message) {
        running_ = kNoJob;
        done(outcome == ControllerRunner::Outcome::kSucceeded, outcome == ControllerRunner::Outcome::kCancelled,
             message);
        UpdateButtons();
      });
  if (!started) {
    running_ = kNoJob;
    const QString busy = tr("%1 is running; start this when it has finished.").arg(runner_->job_name());
    if (job >= 0) {
      SetStepStatus(Step(job), busy, true);
    } else {
      SetTargetsStatus(busy, true);
    }
  }
  UpdateButtons();
  return started;
}

void CalibrationPage::RunStep(int step_index) {
  const Step step = Step(step_index);
  const fs::path set_dir = SetDir();
  const QStringList sessions = Sessions(step);
  if (set_dir.empty()) {
    SetStepStatus(step, tr("Choose the calibration set folder first (a new folder for step 1)."), true);
    return;
  }
  if (sessions.isEmpty()) {
    SetStepStatus(step, tr("No target session chosen: render the simulated targets, find them in their folder, or "
                           "Add… them."),
                  true);
    return;
  }
  std::vector<fs::path> paths;
  for (const QString& session : sessions) paths.push_back(session.toStdString());
  const QString set_name = calibration_folder();
  ClearFigures(step);
  SetStepStatus(step, tr("Running…"));

  // What every step does with the outcome; `figures` is called on success only.
  auto finish = [this, step, set_name](std::function<std::vector<QualityFigure>()> figures, QString done_text) {
    return [this, step, set_name, figures, done_text](bool ok, bool cancelled, const QString& message) {
      if (ok) {
        ShowFigures(step, figures());
        if (step == kCameraStep) {
          // A new set: the other steps' figures belonged to the old one.
          for (Step other : {kWhiteStep, kLightsStep}) {
            worst_[other] = -1;
            ClearFigures(other);
            SetStepStatus(other, QString());
          }
        }
      } else {
        // Cancelled: the set on disk (if any) is shown as it still is.
        worst_[step] = cancelled ? -1 : int(Mark::kFail);
      }
      ReloadSet();
      if (ok) {
        SetStepStatus(step, done_text);
      } else if (cancelled) {
        SetStepStatus(step, tr("Cancelled: nothing was written; the set in %1 is as it was.").arg(set_name), true);
      } else {
        SetStepStatus(step, tr("Failed: %1").arg(message), true);
        const std::string hint = FixHintForError(QualityStep(step), message.toStdString());
        QLabel* hints = steps_[step].hints;
        hints->setTextFormat(Qt::PlainText);
        hints->setText(hint.empty() ? QString() : tr("What to fix: %1").arg(QString::fromStdString(hint)));
        hints->setStyleSheet(QStringLiteral("color: #c0392b"));
        FitHints(step);
      }
    };
  };

  if (step == kCameraStep) {
    CameraCalibrationJobOptions options;
    options.replace = replace_->isChecked();
    auto controller = std::make_shared<CameraCalibrationController>(paths, set_dir, options);
    StartJob(step, controller, tr("Camera calibration"),
             finish([controller] { return CameraQuality(controller->summary()); },
                    tr("Camera calibrated: a new set in %1.").arg(set_name)));
  } else if (step == kWhiteStep) {
    auto controller = std::make_shared<WhiteBalanceController>(paths.front(), set_dir, WhiteBalanceJobOptions());
    StartJob(step, controller, tr("White balance"),
             finish([controller] { return WhiteBalanceQuality(controller->summary()); },
                    tr("White balance and linearity measured into %1.").arg(set_name)));
  } else {
    auto controller = std::make_shared<LightCalibrationController>(paths, set_dir, LightCalibrationJobOptions());
    const std::string first = paths.front().string();
    StartJob(step, controller, tr("Light calibration"),
             finish([controller, first] { return LightsQuality(controller->summary(), MeasuredLeds(first)); },
                    tr("Lights calibrated into %1.").arg(set_name)));
  }
}

// ---------------------------------------------------------------------------
// Figures

void CalibrationPage::ClearFigures(Step step) {
  steps_[step].figures->clear();
  steps_[step].hints->clear();
  steps_[step].hints->setStyleSheet(QString());
  FitHints(step);
}

void CalibrationPage::ShowFigures(Step step, const std::vector<QualityFigure>& figures) {
  ClearFigures(step);
  QTreeWidget* tree = steps_[step].figures;
  std::map<std::string, std::vector<QualityFigure>> grouped;
  for (const QualityFigure& figure : figures) grouped[figure.group].push_back(figure);
  std::map<std::string, QTreeWidgetItem*> groups;
  for (const QualityFigure& figure : figures) {
    QTreeWidgetItem* parent = nullptr;
    if (!figure.group.empty()) {
      auto [it, added] = groups.emplace(figure.group, nullptr);
      if (added) {
        it->second = new QTreeWidgetItem(tree);
        it->second->setText(kFigureName, QString::fromStdString(figure.group));
        const std::vector<QualityFigure>& members = grouped[figure.group];
        const Mark worst = WorstMark(members);
        SetMark(it->second, worst);
        // Folded, the group says which of its figures are bad.
        QStringList bad;
        for (const QualityFigure& member : members) {
          if (member.mark == Mark::kWarn || member.mark == Mark::kFail) {
            bad << QStringLiteral("%1: %2").arg(QString::fromLatin1(QualityMarkName(member.mark)),
                                                QString::fromStdString(member.name));
          }
        }
        it->second->setText(kFigureValue, bad.isEmpty() ? tr("%n figure(s), all pass", "", int(members.size()))
                                                        : bad.join(QStringLiteral("; ")));
        it->second->setExpanded(worst != Mark::kPass);  // problems open, what passes stays folded
      }
      parent = it->second;
    }
    auto* item = parent ? new QTreeWidgetItem(parent) : new QTreeWidgetItem(tree);
    item->setText(kFigureName, QString::fromStdString(figure.name));
    item->setText(kFigureValue, QString::fromStdString(figure.text));
    item->setToolTip(kFigureValue, QString::fromStdString(figure.text));
    item->setData(kFigureValue, kValueRole, figure.value);
    item->setText(kFigureLimit, QString::fromStdString(figure.limit));
    item->setToolTip(kFigureLimit, QString::fromStdString(figure.limit));
    SetMark(item, figure.mark);
    if (!figure.hint.empty()) item->setToolTip(kFigureName, QString::fromStdString(figure.hint));
  }

  const Mark worst = WorstMark(figures);
  worst_[step] = int(worst);
  QStringList hints;
  for (const QualityFigure& figure : figures) {
    if (figure.hint.empty()) continue;
    hints << QStringLiteral("<li><b>%1</b>: %2</li>")
                 .arg(QString::fromLatin1(QualityMarkName(figure.mark)),
                      QString::fromStdString(figure.hint).toHtmlEscaped());
  }
  hints.removeDuplicates();
  QLabel* label = steps_[step].hints;
  label->setTextFormat(Qt::RichText);
  if (hints.isEmpty()) {
    label->setText(tr("Every figure passes: nothing to fix."));
    label->setStyleSheet(QStringLiteral("color: #1e8449"));
  } else {
    label->setText(tr("<b>What to fix</b><ul>%1</ul>").arg(hints.join(QString())));
    label->setStyleSheet(worst == Mark::kFail ? QStringLiteral("color: #c0392b") : QString());
  }
  FitHints(step);
  UpdateStepList();
}

// ---------------------------------------------------------------------------
// The set

void CalibrationPage::ReloadSet() {
  const fs::path dir = SetDir();
  done_ = {};
  std::error_code error;
  if (dir.empty()) {
    set_state_->setText(tr("Choose a folder for the calibration set: a new one for a new set."));
  } else if (!fs::exists(dir / kCalibrationManifestName, error)) {
    set_state_->setText(tr("No calibration set in %1 yet: step 1 (camera) creates it.").arg(calibration_folder()));
  } else {
    try {
      const CalibrationSet set = LoadCalibrationSet(dir);
      done_ = {set.camera_calibration.has_value(), set.white_balance.has_value(), set.lights.has_value()};
      // A step shows the figures of the set on disk unless it has just run.
      if (set.camera_calibration && worst_[kCameraStep] < 0) {
        ShowFigures(kCameraStep, CameraQuality(set.camera_calibration->summary));
        SetStepStatus(kCameraStep,
                      tr("In the set since %1.").arg(QString::fromStdString(set.camera_calibration->date)));
      }
      if (set.white_balance && worst_[kWhiteStep] < 0) {
        ShowFigures(kWhiteStep, WhiteBalanceQuality(set.white_balance->summary));
        SetStepStatus(kWhiteStep, tr("In the set since %1.").arg(QString::fromStdString(set.white_balance->date)));
      }
      if (set.lights && worst_[kLightsStep] < 0) {
        const std::vector<LedDescription> measured =
            set.lights->targets.empty() ? std::vector<LedDescription>() : MeasuredLeds(set.lights->targets[0].session);
        ShowFigures(kLightsStep, LightsQuality(set.lights->summary, measured));
        SetStepStatus(kLightsStep, tr("In the set since %1.").arg(QString::fromStdString(set.lights->date)));
      }
      QStringList parts;
      for (int step = 0; step < kStepCount; ++step) {
        parts << tr("%1 %2").arg(tr(kStepTitle[step]), done_[step] ? tr("done") : tr("missing"));
      }
      const bool complete = done_[kCameraStep] && done_[kWhiteStep] && done_[kLightsStep];
      set_state_->setText(tr("%1: %2; %3 (%4, %5 × %6 px, created %7)")
                              .arg(calibration_folder(), parts.join(", "),
                                   complete ? tr("complete, ready for solves") : tr("incomplete"),
                                   QString::fromStdString(set.camera.make + " " + set.camera.model))
                              .arg(set.camera.width)
                              .arg(set.camera.height)
                              .arg(QString::fromStdString(set.created)));
    } catch (const std::exception& load_error) {
      set_state_->setText(tr("%1 cannot be read: %2").arg(calibration_folder(), load_error.what()));
    }
  }
  UpdateStepList();
  UpdateButtons();
}

void CalibrationPage::UpdateStepList() {
  for (int step = 0; step < kStepCount; ++step) {
    QString state = done_[step] ? tr("done") : tr("not done");
    Mark mark = Mark::kInfo;
    if (worst_[step] >= 0) {
      mark = Mark(worst_[step]);
      state = !done_[step] && mark == Mark::kFail ? tr("failed")
              : mark == Mark::kPass               ? tr("done: all figures pass")
              : mark == Mark::kWarn               ? tr("done: see the warnings")
                                                  : tr("done: figures fail");
    }
    QListWidgetItem* item = step_list_->item(step);
    item->setText(tr("%1. %2\n      %3").arg(step + 1).arg(tr(kStepTitle[step]), state));
    item->setForeground(mark == Mark::kInfo ? QBrush() : QBrush(MarkForeground(mark)));
  }
}

void CalibrationPage::UpdateButtons() {
  const bool busy = runner_->busy();
  for (StepWidgets& w : steps_) w.run->setEnabled(!busy);
  render_->setEnabled(!busy);
  cancel_->setEnabled(busy && running_ != kNoJob);
  // The folders stay as they are while this page's job writes into them.
  set_box_->setEnabled(running_ == kNoJob);
  targets_box_->setEnabled(running_ == kNoJob);
  use_set_->setEnabled(done_[kCameraStep] && done_[kWhiteStep] && done_[kLightsStep]);
}

// ---------------------------------------------------------------------------
// Settings

void CalibrationPage::LoadSettings() {
  QSettings settings;
  sim_width_->setValue(settings.value("calibration/targets_width", sim_width_->value()).toInt());
  sim_height_->setValue(settings.value("calibration/targets_height", sim_height_->value()).toInt());
  targets_folder_->setText(settings.value("calibration/targets").toString());
  for (int step = 0; step < kStepCount; ++step) {
    steps_[step].sessions->clear();
    AddSessions(Step(step),
                settings.value(QStringLiteral("calibration/%1_sessions").arg(kStepPrefix[step])).toStringList());
  }
  SetCalibrationFolder(settings.value("calibration/set").toString());
  ShowStep(Step(std::clamp(settings.value("calibration/step", 0).toInt(), 0, kStepCount - 1)));
}

void CalibrationPage::SaveSettings() const {
  QSettings settings;
  settings.setValue("calibration/set", set_folder_->text());
  settings.setValue("calibration/targets", targets_folder_->text());
  settings.setValue("calibration/targets_width", sim_width_->value());
  settings.setValue("calibration/targets_height", sim_height_->value());
  for (int step = 0; step < kStepCount; ++step) {
    settings.setValue(QStringLiteral("calibration/%1_sessions").arg(kStepPrefix[step]), Sessions(Step(step)));
  }
  settings.setValue("calibration/step", step_list_->currentRow());
}

void CalibrationPage::SetCalibrationFolder(const QString& folder) {
  set_folder_->setText(folder);
  loaded_folder_ = folder;
  worst_ = {-1, -1, -1};  // another set: show what it holds
  for (int step = 0; step < kStepCount; ++step) {
    ClearFigures(Step(step));
    SetStepStatus(Step(step), QString());
  }
  ReloadSet();
}

}  // namespace scanbench
