#include "app/gui/calibration_page.h"

#include <QBrush>
#include <QCheckBox>
#include <QColor>
#include <QCoreApplication>
#include <QDir>
#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QFont>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QImage>
#include <QLabel>
#include <QLineEdit>
#include <QListWidget>
#include <QProgressBar>
#include <QPixmap>
#include <QPushButton>
#include <QScrollArea>
#include <QSettings>
#include <QSpinBox>
#include <QSplitter>
#include <QStackedWidget>
#include <QTabWidget>
#include <QTableWidget>
#include <QTreeWidget>
#include <QVBoxLayout>

#include <algorithm>
#include <map>
#include <numeric>
#include <optional>

#include "app/controllers/calibration_controllers.h"
#include "app/controllers/simulate_targets_controller.h"
#include "app/gui/bench.h"
#include "app/gui/calibration_quality.h"
#include "app/gui/controller_runner.h"
#include "app/gui/devices_page.h"
#include "app/gui/page_widgets.h"
#include "app/session/calibration_set.h"
#include "app/session/calibration_target.h"
#include "app/session/session.h"
#include "app/session/color_staleness.h"

namespace scanbench {
namespace fs = std::filesystem;
using Mark = QualityFigure::Mark;

namespace {

enum FigureColumn { kFigureName, kFigureValue, kFigureLimit, kFigureMark, kFigureColumns };
constexpr int kValueRole = Qt::UserRole;     // the figure's number (column kFigureValue)
constexpr int kMarkRole = Qt::UserRole + 1;  // its QualityFigure::Mark (column kFigureMark)
// The colour step's patch table; kValueRole holds the CIEDE2000 values.
enum PatchColumn { kPatchName, kPatchMeasured, kPatchReference, kPatchCorrected, kPatchBefore, kPatchAfter, kPatchUsed,
                   kPatchColumns };
constexpr int kSwatchPx = 36;  // one patch of the before / after image

// What the page needs to run a step: the target sessions, the set, and the
// page's options.
struct StepRunInputs {
  std::vector<fs::path> sessions;
  fs::path set_dir;
  bool replace_set = false;  // camera: "Replace an existing set"
};

// A started step: its controller and, once it has succeeded, its figures
// (and the colour step's fit, for the patch table).
struct StepRun {
  std::shared_ptr<BaseController> controller;
  std::function<std::vector<QualityFigure>()> figures;
  std::function<ColorCorrectionSummary()> color;  // empty for the other steps
};

// A step's section of the set on disk: its figures and date.
struct StoredStep {
  std::vector<QualityFigure> figures;
  std::string date;
  std::optional<ColorCorrectionSummary> color;  // the colour step's fit
};

// The rig description a light calibration started from: the first white
// sheet session's (empty when it cannot be read any more).
std::vector<LedDescription> MeasuredLeds(const std::string& session_dir) {
  try {
    return LoadSession(session_dir, SessionLoadOptions{.verify_checksums = false}).rig.leds;
  } catch (const std::exception&) {
    return {};
  }
}

// Everything that differs between the steps; the page is generic over it.
// Texts are translated where they are shown.
struct StepSpec {
  const char* prefix;  // widget object names and settings keys: "cameraRun", "calibration/camera_sessions"
  const char* title;
  CalibrationTargetDescription::Kind kind;
  CalibrationStep quality_step;
  const char* instructions;
  const char* sessions_label;
  int list_height;      // px: room for the sessions the step takes
  bool one_session;     // the gray chart: one session
  bool spacer;          // the white sheets: the spacer height to describe them with
  bool optional;        // colour: the set serves solves without it
  bool raw_photos;      // colour: RAW photo files may be added besides target sessions
  const char* describe_what;
  const char* describe_tooltip;
  const char* run_text;
  const char* job_name;
  const char* done_text;  // %1: the set folder
  StepRun (*start)(const StepRunInputs& inputs);
  std::optional<StoredStep> (*stored)(const CalibrationSet& set);
};

#define STEP_TR(text) QT_TRANSLATE_NOOP("scanbench::CalibrationPage", text)

const StepSpec kSteps[CalibrationPage::kStepCount] = {
    {"camera", STEP_TR("Camera"), CalibrationTargetDescription::Kind::kCheckerboard, CalibrationStep::kCamera,
     STEP_TR("<b>Target:</b> the checkerboard (9 × 6 inner corners, 9 mm squares), flat: mounted on glass or stiff "
             "card. <b>Capture</b> one session per pose, all LEDs as for a scan: first the board <b>lying flat on the "
             "table</b>, its rows along the image's x (this view places the table); then 5 to 8 more with the board "
             "<b>tilted 20–35°</b> in different directions, at different places in the view. The whole board must be "
             "visible and sharp in every pose. This step starts the calibration set."),
     STEP_TR("Target sessions"), 84, false, false, false, false, STEP_TR("board poses"),
     STEP_TR("Writes target.json (9 × 6 inner corners, 9 mm squares) into each selected session without one; the "
             "first becomes the board lying on the table unless a listed session already is"),
     STEP_TR("Run camera calibration"), STEP_TR("Camera calibration"), STEP_TR("Camera calibrated: a new set in %1."),
     [](const StepRunInputs& in) -> StepRun {
       CameraCalibrationJobOptions options;
       options.replace = in.replace_set;
       auto controller = std::make_shared<CameraCalibrationController>(in.sessions, in.set_dir, options);
       return {controller, [controller] { return CameraQuality(controller->summary()); }, {}};
     },
     [](const CalibrationSet& set) -> std::optional<StoredStep> {
       if (!set.camera_calibration) return std::nullopt;
       return StoredStep{CameraQuality(set.camera_calibration->summary), set.camera_calibration->date, std::nullopt};
     }},
    {"white", STEP_TR("White balance"), CalibrationTargetDescription::Kind::kGrayChart, CalibrationStep::kWhiteBalance,
     STEP_TR("<b>Target:</b> the matte <b>gray chart</b> (Munsell neutral value scale, N2 to N9.5) lying flat at the "
             "centre of the table, where its target.json puts the patches. <b>Capture</b> one session, all LEDs, at "
             "the exposure of a scan. Keep the chart clean, without glare or shadow. Needs step 1 in this set."),
     STEP_TR("Target session"), 30, true, false, false, false, STEP_TR("the gray chart"),
     STEP_TR("Writes target.json (the Munsell neutral scale, centred on the table) into the selected session"),
     STEP_TR("Run white balance"), STEP_TR("White balance"),
     STEP_TR("White balance and linearity measured into %1."),
     [](const StepRunInputs& in) -> StepRun {
       auto controller =
           std::make_shared<WhiteBalanceController>(in.sessions.front(), in.set_dir, WhiteBalanceJobOptions());
       return {controller, [controller] { return WhiteBalanceQuality(controller->summary()); }, {}};
     },
     [](const CalibrationSet& set) -> std::optional<StoredStep> {
       if (!set.white_balance) return std::nullopt;
       return StoredStep{WhiteBalanceQuality(set.white_balance->summary), set.white_balance->date, std::nullopt};
     }},
    {"lights", STEP_TR("Lights"), CalibrationTargetDescription::Kind::kWhiteSheet, CalibrationStep::kLights,
     STEP_TR("<b>Target:</b> a <b>99 % white sheet</b> (matte, no optical brighteners), flat and clean, filling the "
             "view. <b>Capture</b> two sessions, all LEDs: the sheet <b>on the table</b>, then on the <b>spacer</b> "
             "(40 mm, the height its target.json states). Nothing may clip at the scan's exposure. Needs step 1."),
     STEP_TR("Target sessions"), 48, false, true, false, false, STEP_TR("white sheets"),
     STEP_TR("Writes target.json (99 % sheet) into each selected session without one: the first on the table "
             "unless a listed session already is, the others on the spacer"),
     STEP_TR("Run light calibration"), STEP_TR("Light calibration"), STEP_TR("Lights calibrated into %1."),
     [](const StepRunInputs& in) -> StepRun {
       auto controller =
           std::make_shared<LightCalibrationController>(in.sessions, in.set_dir, LightCalibrationJobOptions());
       const std::string first = in.sessions.front().string();
       return {controller, [controller, first] { return LightsQuality(controller->summary(), MeasuredLeds(first)); },
               {}};
     },
     [](const CalibrationSet& set) -> std::optional<StoredStep> {
       if (!set.lights) return std::nullopt;
       const std::vector<LedDescription> measured =
           set.lights->targets.empty() ? std::vector<LedDescription>() : MeasuredLeds(set.lights->targets[0].session);
       return StoredStep{LightsQuality(set.lights->summary, measured), set.lights->date, std::nullopt};
     }},
    {"color", STEP_TR("Colour"), CalibrationTargetDescription::Kind::kColorChart, CalibrationStep::kColor,
     STEP_TR("<b>Target:</b> an X-Rite <b>ColorChecker Classic</b> (24 patches) lying flat, face up and whole in "
             "view anywhere on the table: the detector finds it. <b>Capture</b> one session, all LEDs, at the "
             "exposure of a scan, without glare or shadow; no patch may clip. After steps 1 and 3 the patches are "
             "measured as absolute reflectances in the solver's albedo space. Or add a <b>RAW photo</b> of the "
             "chart (any light): a relative fit, balanced on its gray row. Optional: without it a solve takes the "
             "RAW file's own camera matrix."),
     STEP_TR("Target sessions or RAW photos"), 48, false, false, true, true, STEP_TR("the colour chart"),
     STEP_TR("Writes target.json (a ColorChecker Classic of the real size on the table) into each selected session "
             "without one"),
     STEP_TR("Run colour calibration"), STEP_TR("Colour calibration"),
     STEP_TR("Colour calibrated into %1: solves with this set write linear Rec.709 albedo."),
     [](const StepRunInputs& in) -> StepRun {
       auto controller =
           std::make_shared<ColorCalibrationController>(in.sessions, in.set_dir, ColorCalibrationJobOptions());
       return {controller,
               [controller] { return ColorQuality(controller->summary().fit, controller->summary().white_reference); },
               [controller] { return controller->summary().fit; }};
     },
     [](const CalibrationSet& set) -> std::optional<StoredStep> {
       if (!set.color) return std::nullopt;
       return StoredStep{ColorQuality(set.color->summary, set.color->white_reference), set.color->date,
                         set.color->summary};
     }},
};

#undef STEP_TR

QString Tr(const char* text) { return QCoreApplication::translate("scanbench::CalibrationPage", text); }

QStringList ToStrings(const std::vector<fs::path>& paths) {
  QStringList strings;
  for (const fs::path& path : paths) strings << QString::fromStdString(path.string());
  return strings;
}

std::vector<fs::path> ToPaths(const QStringList& strings) {
  std::vector<fs::path> paths;
  for (const QString& string : strings) paths.push_back(string.toStdString());
  return paths;
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

}  // namespace

CalibrationPage::CalibrationPage(ControllerRunner* runner, DevicesPage* devices, QWidget* parent)
    : QWidget(parent), runner_(runner), devices_(devices) {
  worst_.fill(-1);
  auto* layout = new QVBoxLayout(this);
  layout->addWidget(MakeSetBox());
  layout->addWidget(MakeTargetsBox());
  layout->addWidget(MakeSteps(), 1);
  layout->addLayout(MakeProgressRow());
  ConnectRunner();
  step_list_->setCurrentRow(0);
  UpdateStepList();
  ReloadSet();
}

// The set: created by step 1, completed by steps 2 and 3.
QWidget* CalibrationPage::MakeSetBox() {
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

  connect(browse_set, &QPushButton::clicked, this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(this, tr("Calibration set folder"), set_folder_->text());
    if (!dir.isEmpty()) SetCalibrationFolder(dir);
  });
  connect(set_folder_, &QLineEdit::editingFinished, this, [this] {
    if (set_folder_->text() != loaded_folder_) SetCalibrationFolder(set_folder_->text());
  });
  connect(use_set_, &QPushButton::clicked, this, [this] { emit UseCalibrationSet(calibration_folder()); });
  return set_box;
}

// Where the target sessions are.
QWidget* CalibrationPage::MakeTargetsBox() {
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
                         "sheets, colour chart) into the folder, as scanbench calibrate simulate-targets does"));
  sim_width_ = MakeSizeBox("targetsWidth", 1232, targets_box);
  sim_height_ = MakeSizeBox("targetsHeight", 816, targets_box);
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

  connect(browse_targets, &QPushButton::clicked, this, [this] {
    const QString dir =
        QFileDialog::getExistingDirectory(this, tr("Folder of target sessions"), targets_folder_->text());
    if (!dir.isEmpty()) SetTargetsFolder(dir);
  });
  connect(find_, &QPushButton::clicked, this, &CalibrationPage::FindTargets);
  connect(render_, &QPushButton::clicked, this, &CalibrationPage::RenderSimulatedTargets);
  // Simulated targets are rendered at the simulated camera's size, so that
  // the set fits the sessions captured on this bench.
  connect(devices_, &DevicesPage::BenchChanged, this, [this] {
    Bench* bench = devices_->bench();
    if (bench && bench->options().simulated_camera) {
      sim_width_->setValue(bench->options().sim_width);
      sim_height_->setValue(bench->options().sim_height);
    }
  });
  return targets_box;
}

QSpinBox* CalibrationPage::MakeSizeBox(const char* name, int value, QWidget* parent) {
  auto* box = new QSpinBox(parent);
  box->setObjectName(name);
  box->setRange(64, 8192);
  box->setValue(value);
  return box;
}

// The step list beside the page of the step chosen.
QWidget* CalibrationPage::MakeSteps() {
  step_list_ = new QListWidget(this);
  step_list_->setObjectName("calibrationSteps");
  step_list_->setMaximumWidth(200);
  stack_ = new QStackedWidget(this);
  for (int step = 0; step < kStepCount; ++step) {
    stack_->addWidget(MakeStep(Step(step)));
    step_list_->addItem(QString());
  }
  auto* splitter = new QSplitter(Qt::Horizontal, this);
  splitter->addWidget(step_list_);
  splitter->addWidget(stack_);
  splitter->setStretchFactor(1, 1);
  connect(step_list_, &QListWidget::currentRowChanged, stack_, &QStackedWidget::setCurrentIndex);
  return splitter;
}

QLayout* CalibrationPage::MakeProgressRow() {
  progress_ = new QProgressBar(this);
  progress_->setObjectName("calibrationProgress");
  progress_->setRange(0, 1000);
  progress_->setTextVisible(false);
  stage_ = new QLabel(this);
  stage_->setObjectName("calibrationStage");
  cancel_ = new QPushButton(tr("Cancel"), this);
  cancel_->setObjectName("cancelCalibration");
  auto* progress_row = new QHBoxLayout;
  progress_row->addWidget(progress_, 1);
  progress_row->addWidget(stage_);
  progress_row->addWidget(cancel_);
  connect(cancel_, &QPushButton::clicked, this, [this] {
    if (running_ != kNoJob) runner_->Cancel();
  });
  return progress_row;
}

void CalibrationPage::ConnectRunner() {
  // The job's one bar (issue #36 item 8): forward only across its stages.
  connect(runner_, &ControllerRunner::JobProgressChanged, this, [this](double fraction, const QString& text) {
    if (running_ == kNoJob) return;
    progress_->setValue(int(fraction * 1000));
    stage_->setText(text);
  });
  connect(runner_, &ControllerRunner::Started, this, &CalibrationPage::UpdateButtons);
  connect(runner_, &ControllerRunner::Finished, this, &CalibrationPage::UpdateButtons);
}

QWidget* CalibrationPage::MakeStep(Step step) {
  const StepSpec& spec = kSteps[step];
  const QString prefix = QString::fromLatin1(spec.prefix);
  auto* page = new QWidget(this);
  StepWidgets& w = steps_[step];
  auto* text = new QLabel(Tr(spec.instructions), page);
  text->setWordWrap(true);
  text->setTextFormat(Qt::RichText);

  auto* layout = new QVBoxLayout(page);
  layout->addWidget(text);
  layout->addWidget(new QLabel(Tr(spec.sessions_label), page));
  layout->addLayout(MakeSessionList(step, page));
  layout->addLayout(MakeDescribeRow(step, page));
  layout->addLayout(MakeRunRow(step, page));

  w.status = new QLabel(page);
  w.status->setObjectName(prefix + "Status");
  w.status->setWordWrap(true);
  w.status->setTextInteractionFlags(Qt::TextSelectableByMouse);
  layout->addWidget(w.status);
  MakeFigures(step, page);
  if (spec.kind == CalibrationTargetDescription::Kind::kColorChart) {
    layout->addLayout(MakeColorPatches(step, page), 1);
  } else {
    layout->addWidget(w.figures, 1);
    layout->addWidget(w.hints_area);
  }
  return page;
}

QLayout* CalibrationPage::MakeSessionList(Step step, QWidget* page) {
  const QString prefix = QString::fromLatin1(kSteps[step].prefix);
  StepWidgets& w = steps_[step];
  w.sessions = new QListWidget(page);
  w.sessions->setObjectName(prefix + "Sessions");
  w.sessions->setSelectionMode(QAbstractItemView::ExtendedSelection);
  w.sessions->setMaximumHeight(kSteps[step].list_height);
  auto* add = new QPushButton(tr("Add…"), page);
  add->setObjectName(prefix + "Add");
  auto* remove = new QPushButton(tr("Remove"), page);
  remove->setObjectName(prefix + "Remove");
  auto* list_buttons = new QVBoxLayout;
  list_buttons->addWidget(add);
  if (kSteps[step].raw_photos) {
    auto* add_raw = new QPushButton(tr("Add RAW photos…"), page);
    add_raw->setObjectName(prefix + "AddRaw");
    add_raw->setToolTip(tr("Single RAW photos (DNG, NEF, CR2, …) of the ColorChecker, taken with this camera"));
    list_buttons->addWidget(add_raw);
    connect(add_raw, &QPushButton::clicked, this, [this, step] { AddRawPhotos(step); });
  }
  list_buttons->addWidget(remove);
  list_buttons->addStretch();
  auto* list_row = new QHBoxLayout;
  list_row->addWidget(w.sessions, 1);
  list_row->addLayout(list_buttons);
  connect(add, &QPushButton::clicked, this, [this, step] { AddFromFolder(step); });
  connect(remove, &QPushButton::clicked, this, [this, step] { qDeleteAll(steps_[step].sessions->selectedItems()); });
  return list_row;
}

// Real bench: a capture of the target becomes a target session.
QLayout* CalibrationPage::MakeDescribeRow(Step step, QWidget* page) {
  const StepSpec& spec = kSteps[step];
  auto* describe = new QPushButton(tr("Describe selected as %1").arg(Tr(spec.describe_what)), page);
  describe->setObjectName(QString::fromLatin1(spec.prefix) + "Describe");
  describe->setToolTip(Tr(spec.describe_tooltip));
  auto* describe_row = new QHBoxLayout;
  describe_row->addWidget(new QLabel(tr("Captured on the real bench, without a target.json?"), page));
  describe_row->addWidget(describe);
  if (spec.spacer) {
    QDoubleSpinBox*& spacer = steps_[step].spacer_mm;
    spacer = new QDoubleSpinBox(page);
    spacer->setObjectName("spacerMm");
    spacer->setRange(1, 200);
    spacer->setValue(SimulateTargetsOptions().spacer_mm);
    spacer->setSuffix(tr(" mm"));
    describe_row->addWidget(new QLabel(tr("spacer"), page));
    describe_row->addWidget(spacer);
  }
  describe_row->addStretch();
  connect(describe, &QPushButton::clicked, this, [this, step] { DescribeSelected(step); });
  return describe_row;
}

QLayout* CalibrationPage::MakeRunRow(Step step, QWidget* page) {
  const QString prefix = QString::fromLatin1(kSteps[step].prefix);
  const bool last = step + 1 == kStepCount;
  StepWidgets& w = steps_[step];
  w.run = new QPushButton(Tr(kSteps[step].run_text), page);
  w.run->setObjectName(prefix + "Run");
  auto* next = new QPushButton(last ? tr("Use this set for solves") : tr("Next step →"), page);
  next->setObjectName(prefix + "Next");
  auto* run_row = new QHBoxLayout;
  run_row->addWidget(w.run);
  run_row->addStretch();
  run_row->addWidget(next);
  connect(w.run, &QPushButton::clicked, this, [this, step] { RunStep(step); });
  connect(next, &QPushButton::clicked, this, [this, step, last] {
    if (last) {
      if (use_set_->isEnabled()) emit UseCalibrationSet(calibration_folder());
    } else {
      ShowStep(Step(step + 1));
    }
  });
  return run_row;
}

void CalibrationPage::MakeFigures(Step step, QWidget* page) {
  const QString prefix = QString::fromLatin1(kSteps[step].prefix);
  StepWidgets& w = steps_[step];
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
}

// The per-patch table and the swatches beside it.
QLayout* CalibrationPage::MakeColorPatches(Step step, QWidget* page) {
  const QString prefix = QString::fromLatin1(kSteps[step].prefix);
  StepWidgets& w = steps_[step];
  w.patch_stats = new QLabel(page);
  w.patch_stats->setObjectName(prefix + "PatchStats");
  w.patch_stats->setWordWrap(true);
  w.patch_stats->setTextInteractionFlags(Qt::TextSelectableByMouse);
  w.patches = new QTableWidget(0, kPatchColumns, page);
  w.patches->setObjectName(prefix + "Patches");
  w.patches->setHorizontalHeaderLabels({tr("Patch"), tr("Measured (camera)"), tr("Reference (Rec.709)"),
                                        tr("Corrected (Rec.709)"), tr("ΔE00 before"), tr("after"), tr("Used")});
  w.patches->horizontalHeaderItem(kPatchMeasured)->setToolTip(tr("White-balanced camera RGB, as measured"));
  w.patches->horizontalHeaderItem(kPatchReference)->setToolTip(tr("The ColorChecker's linear Rec.709 (D65)"));
  w.patches->horizontalHeaderItem(kPatchCorrected)->setToolTip(tr("The correction applied to the measured value"));
  w.patches->horizontalHeaderItem(kPatchAfter)->setToolTip(tr("CIEDE2000 of the corrected value"));
  w.patches->setEditTriggers(QAbstractItemView::NoEditTriggers);
  QFont small = w.patches->font();  // 24 rows of 7 columns beside the swatches
  small.setPointSizeF(small.pointSizeF() * 0.9);
  w.patches->setFont(small);
  w.patches->setAlternatingRowColors(true);
  w.patches->verticalHeader()->setDefaultSectionSize(w.patches->fontMetrics().height() + 4);
  w.patches->horizontalHeader()->setSectionResizeMode(QHeaderView::ResizeToContents);
  w.patches->horizontalHeader()->setStretchLastSection(true);
  w.swatches = new QLabel(page);
  w.swatches->setObjectName(prefix + "Swatches");
  w.swatches->setAlignment(Qt::AlignTop | Qt::AlignLeft);
  auto* caption = new QLabel(tr("Each patch: before (camera RGB) | reference | after (corrected), sRGB."), page);
  caption->setWordWrap(true);
  const int gap = SwatchGapPx(kSwatchPx);
  caption->setMaximumWidth(gap + kColorCheckerColumns * (kSwatchPx + gap));  // as wide as the swatches
  auto* swatch_column = new QVBoxLayout;
  swatch_column->addWidget(w.swatches);
  swatch_column->addWidget(caption);
  swatch_column->addStretch();
  // The page has room for one table: the patches first, the few figures (their
  // marks summed up by the hints below) on the second tab; the swatches beside.
  auto* tabs = new QTabWidget(page);
  tabs->setObjectName(prefix + "Tabs");
  tabs->addTab(w.patches, tr("Patches"));
  tabs->addTab(w.figures, tr("Figures"));
  auto* column = new QVBoxLayout;
  column->addWidget(w.patch_stats);
  column->addWidget(tabs, 1);
  column->addWidget(w.hints_area);
  auto* row = new QHBoxLayout;
  row->addLayout(column, 1);
  row->addLayout(swatch_column);
  return row;
}

bool CalibrationPage::SetComplete() const {
  for (int step = 0; step < kStepCount; ++step) {
    if (!kSteps[step].optional && !done_[step]) return false;
  }
  return true;
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
  ShowStatusText(steps_[step].status, text, error);
}

void CalibrationPage::SetTargetsStatus(const QString& text, bool error) {
  ShowStatusText(targets_status_, text, error);
}

// ---------------------------------------------------------------------------
// Target sessions

void CalibrationPage::AddSessions(Step step, const QStringList& folders) {
  QListWidget* list = steps_[step].sessions;
  const bool one = kSteps[step].one_session;
  if (one && !folders.isEmpty()) list->clear();
  for (const QString& folder : folders) {
    if (list->findItems(folder, Qt::MatchExactly).isEmpty()) list->addItem(folder);
    if (one) break;
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
  const auto found = FindTargetSessions(dir.toStdString());
  const auto it = found.find(kSteps[step].kind);
  // A folder that is no target of this kind is added all the same: the run
  // then says what is wrong with it (a scan session has no target.json).
  AddSessions(step, it != found.end() ? ToStrings(it->second) : QStringList{dir});
}

void CalibrationPage::AddRawPhotos(Step step) {
  const QStringList files = QFileDialog::getOpenFileNames(
      this, tr("RAW photos of the ColorChecker"), targets_folder_->text(),
      tr("RAW photos (*.dng *.DNG *.nef *.NEF *.cr2 *.CR2 *.cr3 *.CR3 *.arw *.ARW *.raf *.RAF *.orf *.ORF *.rw2 "
         "*.RW2 *.pef *.PEF);;All files (*)"));
  AddSessions(step, files);
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
  QStringList folders;
  for (QListWidgetItem* item : selected) folders << item->text();
  DescribeTargetsOptions options;
  options.kind = kSteps[step].kind;
  if (steps_[step].spacer_mm) options.spacer_mm = steps_[step].spacer_mm->value();
  std::vector<DescribedTargetSession> described;
  try {
    described = DescribeTargetSessions(options, ToPaths(folders), ToPaths(Sessions(step)));
  } catch (const std::exception& error) {
    SetStepStatus(step, tr("Describe: %1").arg(error.what()), true);
    return;
  }
  QStringList written, kept;
  for (const DescribedTargetSession& d : described) {
    if (d.written) {
      written << tr("%1 (%2)").arg(QString::fromStdString(d.session.filename().string()),
                                   QString::fromStdString(d.what));
    } else {
      kept << QString::fromStdString(d.session.string());
    }
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
  const auto found = FindTargetSessions(folder);
  QStringList counts;
  int total = 0;
  for (int step = 0; step < kStepCount; ++step) {
    const auto it = found.find(kSteps[step].kind);
    const QStringList sessions = it == found.end() ? QStringList() : ToStrings(it->second);
    steps_[step].sessions->clear();
    AddSessions(Step(step), sessions);
    counts << tr("%1 %2").arg(sessions.size()).arg(QString::fromLatin1(CalibrationTargetKindName(kSteps[step].kind)));
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
        // The end, not the last stage's "100 %".
        const QString seconds = QString::number(runner_->job_seconds(), 'f', 1);
        const QString job = runner_->job_name();
        if (outcome == ControllerRunner::Outcome::kSucceeded) {
          progress_->setValue(progress_->maximum());
          stage_->setText(tr("%1 finished in %2 s").arg(job, seconds));
        } else {
          stage_->setText(outcome == ControllerRunner::Outcome::kCancelled ? tr("%1 cancelled").arg(job)
                                                                            : tr("%1 failed").arg(job));
        }
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
  const StepSpec& spec = kSteps[step];
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
  ClearFigures(step);
  SetStepStatus(step, tr("Running…"));
  const StepRun run = spec.start({ToPaths(sessions), set_dir, replace_->isChecked()});
  const QString set_name = calibration_folder();
  StartJob(step, run.controller, Tr(spec.job_name),
           [this, step, set_name, run](bool ok, bool cancelled, const QString& message) {
             const std::optional<ColorCorrectionSummary> color =
                 ok && run.color ? std::optional(run.color()) : std::nullopt;
             FinishStep(step, set_name, ok ? run.figures() : std::vector<QualityFigure>(), color ? &*color : nullptr,
                        ok, cancelled, message);
           });
}

// What every step does with the outcome of its run.
void CalibrationPage::FinishStep(Step step, const QString& set_name, const std::vector<QualityFigure>& figures,
                                 const ColorCorrectionSummary* color, bool ok, bool cancelled,
                                 const QString& message) {
  if (ok) {
    ShowFigures(step, figures);
    if (color) ShowColorPatches(step, *color);
    if (step == kCameraStep) {
      // A new set: the other steps' figures belonged to the old one.
      for (int other = kCameraStep + 1; other < kStepCount; ++other) {
        worst_[other] = -1;
        ClearFigures(Step(other));
        SetStepStatus(Step(other), QString());
      }
    }
  } else {
    // Cancelled: the set on disk (if any) is shown as it still is.
    worst_[step] = cancelled ? -1 : int(Mark::kFail);
  }
  ReloadSet();
  if (ok) {
    SetStepStatus(step, Tr(kSteps[step].done_text).arg(set_name));
  } else if (cancelled) {
    SetStepStatus(step, tr("Cancelled: nothing was written; the set in %1 is as it was.").arg(set_name), true);
  } else {
    SetStepStatus(step, tr("Failed: %1").arg(message), true);
    const std::string hint = FixHintForError(kSteps[step].quality_step, message.toStdString());
    QLabel* hints = steps_[step].hints;
    hints->setTextFormat(Qt::PlainText);
    hints->setText(hint.empty() ? QString() : tr("What to fix: %1").arg(QString::fromStdString(hint)));
    hints->setStyleSheet(QStringLiteral("color: #c0392b"));
    FitHints(step);
  }
}

// ---------------------------------------------------------------------------
// Figures

void CalibrationPage::ClearFigures(Step step) {
  StepWidgets& w = steps_[step];
  w.figures->clear();
  w.hints->clear();
  w.hints->setStyleSheet(QString());
  FitHints(step);
  if (w.patches) {
    w.patches->setRowCount(0);
    w.patch_stats->clear();
    w.swatches->clear();
  }
}

void CalibrationPage::ShowColorPatches(Step step, const ColorCorrectionSummary& fit) {
  StepWidgets& w = steps_[step];
  if (!w.patches) return;
  auto triple = [](const Eigen::Vector3d& v) {
    return QStringLiteral("%1 %2 %3").arg(v[0], 0, 'f', 3).arg(v[1], 0, 'f', 3).arg(v[2], 0, 'f', 3);
  };
  w.patches->setRowCount(int(fit.patches.size()));
  for (int row = 0; row < int(fit.patches.size()); ++row) {
    const ColorPatchResult& patch = fit.patches[row];
    const QString cells[kPatchColumns] = {
        QString::fromStdString(patch.name),
        triple(patch.measured_camera),
        triple(patch.reference_linear_rec709),
        triple(patch.corrected_linear_rec709),
        QString::number(patch.delta_e_before, 'f', 2),
        QString::number(patch.delta_e_after, 'f', 2),
        patch.used ? tr("used") : tr("no: %1").arg(QString::fromStdString(ColorPatchStatusText(patch)))};
    for (int column = 0; column < kPatchColumns; ++column) {
      auto* item = new QTableWidgetItem(cells[column]);
      if (column == kPatchBefore) item->setData(kValueRole, patch.delta_e_before);
      if (column == kPatchAfter) item->setData(kValueRole, patch.delta_e_after);
      if (column >= kPatchBefore && column <= kPatchAfter) item->setTextAlignment(Qt::AlignRight | Qt::AlignVCenter);
      if (!patch.used && column == kPatchUsed) {
        item->setBackground(MarkBackground(Mark::kFail));
        item->setForeground(MarkForeground(Mark::kFail));
      }
      w.patches->setItem(row, column, item);
    }
  }
  w.patch_stats->setText(tr("CIEDE2000 over %1 of %2 patches, before → after: mean %3 → %4, max %5 → %6 (%7).")
                             .arg(UsedColorPatches(fit))
                             .arg(fit.patches.size())
                             .arg(fit.mean_delta_e_before, 0, 'f', 2)
                             .arg(fit.mean_delta_e_after, 0, 'f', 2)
                             .arg(fit.max_delta_e_before, 0, 'f', 2)
                             .arg(fit.max_delta_e_after, 0, 'f', 2)
                             .arg(QString::fromStdString(fit.method)));
  const ImageU8 swatches = ColorChartSwatches(fit, kSwatchPx);
  const QImage image(swatches.data(), swatches.width(), swatches.height(), 3 * swatches.width(),
                     QImage::Format_RGB888);
  w.swatches->setPixmap(QPixmap::fromImage(image.copy()));  // copy: the pixels outlive `swatches`
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
  color_stale_.clear();
  std::error_code error;
  if (dir.empty()) {
    set_state_->setText(tr("Choose a folder for the calibration set: a new one for a new set."));
  } else if (!fs::exists(dir / kCalibrationManifestName, error)) {
    set_state_->setText(tr("No calibration set in %1 yet: step 1 (camera) creates it.").arg(calibration_folder()));
  } else {
    try {
      const CalibrationSet set = LoadCalibrationSet(dir);
      // A step shows the figures of the set on disk unless it has just run.
      for (int step = 0; step < kStepCount; ++step) {
        const std::optional<StoredStep> stored = kSteps[step].stored(set);
        done_[step] = stored.has_value();
        if (stored && worst_[step] < 0) {
          ShowFigures(Step(step), stored->figures);
          if (stored->color) ShowColorPatches(Step(step), *stored->color);
          SetStepStatus(Step(step), tr("In the set since %1.").arg(QString::fromStdString(stored->date)));
        }
      }
      // Issue #36 item 14: a colour section measured through an older light field.
      if (const auto stale = StaleColorReason(set, dir)) {
        color_stale_ = QString::fromStdString(*stale);
        SetStepStatus(kColorStep, tr("In the set since %1, but STALE: %2")
                                      .arg(QString::fromStdString(set.color->date), color_stale_),
                      true);
      }
      QStringList parts;
      for (int step = 0; step < kStepCount; ++step) {
        if (step == kColorStep && !color_stale_.isEmpty()) {
          parts << tr("%1 stale (run it again)").arg(Tr(kSteps[step].title));
          continue;
        }
        parts << tr("%1 %2").arg(Tr(kSteps[step].title), done_[step]             ? tr("done")
                                                         : kSteps[step].optional ? tr("not done (optional)")
                                                                                 : tr("missing"));
      }
      const bool complete = SetComplete();
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
    QString state = done_[step] ? tr("done") : kSteps[step].optional ? tr("not done (optional)") : tr("not done");
    Mark mark = Mark::kInfo;
    if (worst_[step] >= 0) {
      mark = Mark(worst_[step]);
      state = !done_[step] && mark == Mark::kFail ? tr("failed")
              : mark == Mark::kPass               ? tr("done: all figures pass")
              : mark == Mark::kWarn               ? tr("done: see the warnings")
                                                  : tr("done: figures fail");
    }
    if (step == kColorStep && !color_stale_.isEmpty()) {
      mark = Mark::kWarn;
      state = tr("stale: the lights or white balance changed since; run it again");
    }
    QListWidgetItem* item = step_list_->item(step);
    item->setText(tr("%1. %2\n      %3").arg(step + 1).arg(Tr(kSteps[step].title), state));
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
  use_set_->setEnabled(SetComplete());
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
                settings.value(QStringLiteral("calibration/%1_sessions").arg(QString::fromLatin1(kSteps[step].prefix))).toStringList());
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
    settings.setValue(QStringLiteral("calibration/%1_sessions").arg(QString::fromLatin1(kSteps[step].prefix)), Sessions(Step(step)));
  }
  settings.setValue("calibration/step", step_list_->currentRow());
}

void CalibrationPage::SetCalibrationFolder(const QString& folder) {
  set_folder_->setText(folder);
  loaded_folder_ = folder;
  worst_.fill(-1);  // another set: show what it holds
  for (int step = 0; step < kStepCount; ++step) {
    ClearFigures(Step(step));
    SetStepStatus(Step(step), QString());
  }
  ReloadSet();
}

}  // namespace scanbench
