#include "app/gui/sessions_page.h"

#include <QComboBox>
#include <QDir>
#include <QDoubleSpinBox>
#include <QFileDialog>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QLineEdit>
#include <QListWidget>
#include <QProgressBar>
#include <QPushButton>
#include <QSettings>
#include <QSplitter>
#include <QTreeWidget>
#include <QVBoxLayout>
#include <algorithm>
#include <vector>

#include "app/controllers/import_controller.h"
#include "app/controllers/progress_plans.h"
#include "app/controllers/solve_controller.h"
#include "app/gui/controller_runner.h"
#include "app/gui/export_dialog.h"
#include "app/gui/page_widgets.h"
#include "app/session/rig_json.h"
#include "app/session/session.h"
#include "solver/photometric_methods.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {
enum Column { kName, kSample, kFrames, kState, kResults, kColumnCount };
constexpr int kPathRole = Qt::UserRole;

}  // namespace

SessionsPage::SessionsPage(ControllerRunner* runner, QWidget* parent) : QWidget(parent), runner_(runner) {
  auto* layout = new QVBoxLayout(this);
  layout->addLayout(MakeFolderRow());
  layout->addWidget(MakeLists(), 1);
  layout->addLayout(MakeSolveForm());
  layout->addLayout(MakeButtonRow());
  layout->addWidget(MakeProgressBar());
  status_ = new QLabel(this);
  status_->setObjectName("sessionsStatus");
  status_->setWordWrap(true);
  layout->addWidget(status_);
}

// The folder the sessions are listed from.
QLayout* SessionsPage::MakeFolderRow() {
  root_ = new QLineEdit(this);
  root_->setObjectName("sessionsRoot");
  root_->setPlaceholderText(tr("a folder holding session folders"));
  auto* browse = new QPushButton(tr("Browse…"), this);
  auto* refresh = NamedButton(tr("Refresh"), "refreshSessions", this);
  auto* top = new QHBoxLayout;
  top->addWidget(new QLabel(tr("Folder"), this));
  top->addWidget(root_, 1);
  top->addWidget(browse);
  top->addWidget(refresh);

  connect(browse, &QPushButton::clicked, this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(this, tr("Sessions folder"), root_->text());
    if (!dir.isEmpty()) SetRoot(dir);
  });
  connect(refresh, &QPushButton::clicked, this, &SessionsPage::Refresh);
  connect(root_, &QLineEdit::returnPressed, this, &SessionsPage::Refresh);
  return top;
}

// The sessions above the result folders of the one selected.
QWidget* SessionsPage::MakeLists() {
  sessions_ = new QTreeWidget(this);
  sessions_->setObjectName("sessionList");
  sessions_->setColumnCount(kColumnCount);
  sessions_->setHeaderLabels({tr("Folder"), tr("Sample"), tr("Frames"), tr("State"), tr("Results")});
  sessions_->setRootIsDecorated(false);
  sessions_->header()->setSectionResizeMode(QHeaderView::ResizeToContents);
  results_ = new QListWidget(this);
  results_->setObjectName("resultList");
  auto* splitter = new QSplitter(Qt::Vertical, this);
  splitter->addWidget(sessions_);
  auto* results_box = new QWidget(splitter);
  auto* results_layout = new QVBoxLayout(results_box);
  results_layout->setContentsMargins(0, 0, 0, 0);
  results_layout->addWidget(new QLabel(tr("Result folders of the selected session (newest last)"), results_box));
  results_layout->addWidget(results_);
  splitter->addWidget(results_box);

  connect(sessions_, &QTreeWidget::itemSelectionChanged, this, &SessionsPage::ShowResults);
  connect(results_, &QListWidget::itemDoubleClicked, this,
          [this](QListWidgetItem* item) { emit OpenResult(item->data(kPathRole).toString()); });
  return splitter;
}

// The solve's inputs the operator may change: the solver method (issue #3),
// the shadow level, and a calibration set (issue #4).
QLayout* SessionsPage::MakeSolveForm() {
  auto* solve_form = new QFormLayout;
  const SolveOptions defaults;
  solve_form->addRow(tr("Solver method"), MakeMethodRow(defaults));
  solve_form->addRow(tr("Shadow level"), MakeShadowRow(defaults));
  calibration_ = new QLineEdit(this);
  calibration_->setObjectName("calibrationFolder");
  calibration_->setPlaceholderText(tr("none: the session's rig description"));
  solve_form->addRow(tr("Calibration set"), calibration_);
  return solve_form;
}

// The method list (default selected) and the chosen method's description.
QLayout* SessionsPage::MakeMethodRow(const SolveOptions& defaults) {
  method_ = new QComboBox(this);
  method_->setObjectName("solverMethod");
  for (const PhotometricMethodRow& method : PhotometricMethods()) {
    // The method table's one line (docs/solver.md has the figures).
    QString description = QString::fromUtf8(method.description);
    if (method.method == defaults.solver.method) description += tr(" (default)");
    method_->addItem(QString::fromLatin1(method.name), QString::fromLatin1(method.name));
    method_->setItemData(method_->count() - 1, description, Qt::ToolTipRole);
  }
  method_->setCurrentIndex(method_->findData(QString::fromLatin1(PhotometricMethodName(defaults.solver.method))));
  method_description_ = new QLabel(this);
  method_description_->setObjectName("solverMethodDescription");
  method_description_->setWordWrap(true);
  auto* method_row = new QHBoxLayout;
  method_row->addWidget(method_);
  method_row->addWidget(method_description_, 1);

  auto describe_method = [this] { method_description_->setText(method_->currentData(Qt::ToolTipRole).toString()); };
  connect(method_, &QComboBox::currentIndexChanged, this, describe_method);
  describe_method();
  return method_row;
}

// The shadow level and what it means.
QLayout* SessionsPage::MakeShadowRow(const SolveOptions& defaults) {
  shadow_level_ = new QDoubleSpinBox(this);
  shadow_level_->setObjectName("shadowLevel");
  shadow_level_->setDecimals(4);
  shadow_level_->setRange(0, 0.2);
  shadow_level_->setSingleStep(0.001);
  shadow_level_->setValue(defaults.solver.min_sample_value);
  shadow_level_->setToolTip(
      tr("A sample at or below this (linear, fraction of the sensor range) is taken as shadowed "
         "and left out; 0 keeps every sample (plain least squares)."));
  auto* shadow_row = new QHBoxLayout;
  shadow_row->addWidget(shadow_level_);
  shadow_row->addWidget(new QLabel(tr("of the sensor range; samples at or below are shadowed and left out "
                                      "(default %1, 0 = keep all)")
                                       .arg(defaults.solver.min_sample_value),
                                   this),
                        1);
  return shadow_row;
}

// Open, re-solve, export, resume, import and cancel.
QLayout* SessionsPage::MakeButtonRow() {
  open_ = NamedButton(tr("Open result"), "openResult", this);
  resolve_ = NamedButton(tr("Re-solve"), "resolveSession", this);
  resume_ = NamedButton(tr("Resume capture"), "resumeSession", this);
  export_ = NamedButton(tr("Export…"), "exportSelectedResult", this);
  import_ = NamedButton(tr("Import RAW folder…"), "importRawFolder", this);
  auto* cancel = new QPushButton(tr("Cancel"), this);
  auto* buttons = new QHBoxLayout;
  for (QPushButton* button : {open_, resolve_, export_, resume_, import_, cancel}) buttons->addWidget(button);
  buttons->addStretch();

  connect(open_, &QPushButton::clicked, this, [this] {
    QListWidgetItem* item = results_->currentItem();
    if (!item && results_->count() > 0) item = results_->item(results_->count() - 1);
    if (item) emit OpenResult(item->data(kPathRole).toString());
  });
  connect(resolve_, &QPushButton::clicked, this, &SessionsPage::Resolve);
  connect(export_, &QPushButton::clicked, this, &SessionsPage::ExportSelectedResult);
  connect(resume_, &QPushButton::clicked, this, [this] {
    const fs::path session = SelectedSession();
    if (!session.empty()) emit ResumeCapture(QString::fromStdString(session.string()));
  });
  connect(import_, &QPushButton::clicked, this, [this] {
    const QString raw = QFileDialog::getExistingDirectory(this, tr("Folder of RAW files to import"), root_->text());
    if (raw.isEmpty()) return;
    const QString rig = QFileDialog::getOpenFileName(this, tr("Rig description of the bench"), raw,
                                                     tr("Rig description (*.json)"));
    if (!rig.isEmpty()) ImportRawFolder(raw, rig);
  });
  connect(cancel, &QPushButton::clicked, this, [this] {
    if (solving_) runner_->Cancel();
  });
  return buttons;
}

// The re-solve's progress (other jobs' progress is not shown here).
QProgressBar* SessionsPage::MakeProgressBar() {
  progress_ = new QProgressBar(this);
  progress_->setRange(0, 1000);
  progress_->setTextVisible(false);
  // The job's one bar (issue #36 item 8): it does not start again at each stage.
  connect(runner_, &ControllerRunner::JobProgressChanged, this, [this](double fraction) {
    if (solving_) progress_->setValue(int(fraction * 1000));
  });
  return progress_;
}

void SessionsPage::SetStatus(const QString& text, bool error) {
  ShowStatusText(status_, text, error);
}

void SessionsPage::SetRoot(const QString& folder) {
  root_->setText(folder);
  Refresh();
}

void SessionsPage::Refresh() {
  sessions_->clear();
  results_->clear();
  const fs::path root(root_->text().trimmed().toStdString());
  std::error_code error;
  if (root.empty() || !fs::is_directory(root, error)) {
    SetStatus(tr("%1 is not a folder: choose the folder your sessions are in.").arg(root_->text()), true);
    return;
  }
  std::vector<fs::path> dirs;
  // The root itself may be a session; otherwise its sub-folders are.
  if (fs::exists(root / "session.json")) dirs.push_back(root);
  for (const auto& entry : fs::directory_iterator(root, error)) {
    if (entry.is_directory() && fs::exists(entry.path() / "session.json")) dirs.push_back(entry.path());
  }
  std::sort(dirs.begin(), dirs.end());
  for (const fs::path& dir : dirs) {
    auto* item = new QTreeWidgetItem(sessions_);
    item->setText(kName, QString::fromStdString(dir.filename().string()));
    item->setData(kName, kPathRole, QString::fromStdString(dir.string()));
    try {
      // Listing only: hashing every RAW file would make browsing slow.
      const Session session = LoadSession(dir, SessionLoadOptions{.verify_checksums = false});
      item->setText(kSample, QString::fromStdString(session.sample_name));
      item->setText(kFrames, QString::number(session.frames.size()));
      item->setText(kState, session.capture_complete ? tr("complete") : tr("interrupted"));
    } catch (const std::exception& load_error) {
      item->setText(kState, tr("unreadable"));
      item->setToolTip(kState, QString::fromStdString(load_error.what()));
    }
    item->setText(kResults, QString::number(ListResultFolders(dir).size()));
  }
  SetStatus(tr("%1 session(s) in %2").arg(dirs.size()).arg(root_->text()));
}

bool SessionsPage::SelectSession(const QString& session_dir) {
  const QString wanted = QDir::cleanPath(session_dir);
  for (int i = 0; i < sessions_->topLevelItemCount(); ++i) {
    QTreeWidgetItem* item = sessions_->topLevelItem(i);
    if (QDir::cleanPath(item->data(kName, kPathRole).toString()) == wanted) {
      sessions_->setCurrentItem(item);
      return true;
    }
  }
  return false;
}

fs::path SessionsPage::SelectedSession() const {
  const QTreeWidgetItem* item = sessions_->currentItem();
  return item ? fs::path(item->data(kName, kPathRole).toString().toStdString()) : fs::path();
}

void SessionsPage::ShowResults() {
  results_->clear();
  const fs::path session = SelectedSession();
  if (session.empty()) return;
  for (const fs::path& folder : ListResultFolders(session)) {
    auto* item = new QListWidgetItem(QString::fromStdString(folder.filename().string()), results_);
    item->setData(kPathRole, QString::fromStdString(folder.string()));
  }
  if (results_->count() > 0) results_->setCurrentRow(results_->count() - 1);
  const QTreeWidgetItem* current = sessions_->currentItem();
  resume_->setEnabled(current && current->text(kState) == tr("interrupted"));
  resolve_->setEnabled(current && current->text(kState) == tr("complete"));
  export_->setEnabled(results_->count() > 0);
}

void SessionsPage::Resolve() {
  const fs::path session = SelectedSession();
  if (session.empty()) {
    SetStatus(tr("Select a session first."), true);
    return;
  }
  const SolveOptions options = SolveOptionsFromWidgets();
  try {
    options.Check();
  } catch (const std::exception& error) {
    SetStatus(tr("Solve options: %1").arg(error.what()), true);
    return;
  }
  auto controller = std::make_shared<SolveController>(session, options);
  solving_ = true;
  progress_->setValue(0);
  SetStatus(tr("Solving %1 (%2) into a new result folder…")
                .arg(QString::fromStdString(session.string()), method_->currentText()));
  const bool started = runner_->Start(
      controller, tr("Solve"), [this, controller, session](ControllerRunner::Outcome outcome, const QString& message) {
        solving_ = false;
        if (outcome == ControllerRunner::Outcome::kSucceeded) {
          const QString result = QString::fromStdString(controller->summary().result_dir.string());
          SetStatus(tr("Solved into %1").arg(result));
          Refresh();
          SelectSession(QString::fromStdString(session.string()));
          emit OpenResult(result);
        } else if (outcome == ControllerRunner::Outcome::kCancelled) {
          SetStatus(tr("Solve cancelled; no result folder was left."), true);
        } else {
          SetStatus(tr("Solve failed: %1").arg(message), true);
        }
      },
      SolveProgressPlan());
  if (!started) {
    solving_ = false;
    SetStatus(tr("%1 is running; re-solve when it has finished").arg(runner_->job_name()), true);
  }
}

bool SessionsPage::ImportRawFolder(const QString& raw_folder, const QString& rig_file, const QString& pattern) {
  const fs::path root = root_->text().trimmed().toStdString();
  if (root.empty()) {
    SetStatus(tr("Choose the sessions folder first: the import becomes a session in it."), true);
    return false;
  }
  const fs::path raw = fs::absolute(raw_folder.toStdString()).lexically_normal();
  const fs::path session = root / raw.filename();
  std::shared_ptr<ImportController> controller;
  try {
    ImportOptions options;
    options.sample_name = raw.filename().string();
    options.pattern = pattern.toStdString();
    controller = std::make_shared<ImportController>(raw, session, LoadRigDescriptionFile(rig_file.toStdString()),
                                                    options);
  } catch (const std::exception& error) {
    SetStatus(tr("Import: %1").arg(error.what()), true);
    return false;
  }
  solving_ = true;
  progress_->setValue(0);
  SetStatus(tr("Importing %1 into %2…")
                .arg(QString::fromStdString(raw.string()), QString::fromStdString(session.string())));
  const bool started = runner_->Start(
      controller, tr("Import"), [this, controller, session](ControllerRunner::Outcome outcome, const QString& message) {
        solving_ = false;
        if (outcome == ControllerRunner::Outcome::kSucceeded) {
          Refresh();
          SelectSession(QString::fromStdString(session.string()));
          QString text = tr("Imported %1 frames into %2").arg(controller->summary().frames_copied).arg(
              QString::fromStdString(session.string()));
          for (const std::string& warning : controller->summary().warnings) {
            text += "\n" + tr("warning: %1").arg(QString::fromStdString(warning));
          }
          SetStatus(text);
        } else if (outcome == ControllerRunner::Outcome::kCancelled) {
          Refresh();
          SetStatus(tr("Import cancelled; import again to resume it."), true);
        } else {
          SetStatus(tr("Import refused: %1").arg(message), true);
        }
      });
  if (!started) {
    solving_ = false;
    SetStatus(tr("%1 is running; import when it has finished").arg(runner_->job_name()), true);
  }
  return started;
}

void SessionsPage::SetCalibrationSet(const QString& calibration_dir) { calibration_->setText(calibration_dir); }

SolveOptions SessionsPage::SolveOptionsFromWidgets() const {
  SolveOptions options;
  options.solver.method = PhotometricMethodFromName(method_->currentData().toString().toStdString());
  options.solver.min_sample_value = shadow_level_->value();
  options.calibration_dir = calibration_->text().trimmed().toStdString();
  return options;
}

ExportDialog* SessionsPage::ExportSelectedResult() {
  const QListWidgetItem* item = results_->currentItem();
  if (!item) {
    SetStatus(tr("Select a session and one of its result folders to export."), true);
    return nullptr;
  }
  auto* dialog = new ExportDialog(runner_, item->data(kPathRole).toString().toStdString(), this);
  dialog->setAttribute(Qt::WA_DeleteOnClose);
  dialog->show();
  return dialog;
}

void SessionsPage::LoadSettings() {
  QSettings settings;
  const QString root = settings.value("sessions/root").toString();
  calibration_->setText(settings.value("sessions/calibration").toString());
  const int method = method_->findData(settings.value("sessions/method", method_->currentData()));
  if (method >= 0) method_->setCurrentIndex(method);
  shadow_level_->setValue(settings.value("sessions/shadow_level", shadow_level_->value()).toDouble());
  if (!root.isEmpty()) SetRoot(root);
}

void SessionsPage::SaveSettings() const {
  QSettings settings;
  settings.setValue("sessions/root", root_->text());
  settings.setValue("sessions/calibration", calibration_->text());
  settings.setValue("sessions/method", method_->currentData());
  settings.setValue("sessions/shadow_level", shadow_level_->value());
}

}  // namespace scanbench
