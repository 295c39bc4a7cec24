#include "app/gui/export_dialog.h"

#include <QCheckBox>
#include <QComboBox>
#include <QDesktopServices>
#include <QDialogButtonBox>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QPlainTextEdit>
#include <QPointer>
#include <QProgressBar>
#include <QPushButton>
#include <QSettings>
#include <QUrl>
#include <QVBoxLayout>

#include "app/gui/controller_runner.h"
#include "app/gui/page_widgets.h"
#include "app/io/export_contents.h"

namespace scanbench {

ExportDialog::ExportDialog(ControllerRunner* runner, std::filesystem::path result_dir, QWidget* parent)
    : QDialog(parent), runner_(runner), result_dir_(std::move(result_dir)) {
  setObjectName("exportDialog");
  setWindowTitle(tr("Export maps"));
  auto* source = new QLabel(tr("Result: %1").arg(QString::fromStdString(result_dir_.string())), this);
  source->setWordWrap(true);
  source->setTextInteractionFlags(Qt::TextSelectableByMouse);
  QFormLayout* form = MakeOptionsForm();
  QPushButton* close = nullptr;
  QHBoxLayout* buttons = MakeButtons(&close);
  MakeProgressWidgets();

  auto* layout = new QVBoxLayout(this);
  layout->addWidget(source);
  layout->addLayout(form);
  layout->addLayout(buttons);
  layout->addWidget(progress_);
  layout->addWidget(stage_);
  layout->addWidget(status_);
  layout->addWidget(summary_, 1);
  resize(640, 520);
  RestoreSettings();
  Connect(close);
}

// The options an operator picks, at ExportOptions' defaults.
QFormLayout* ExportDialog::MakeOptionsForm() {
  const ExportOptions defaults;
  auto* form = new QFormLayout;
  preset_ = new QComboBox(this);
  preset_->setObjectName("exportPreset");
  // Each preset's title, and what its files hold under the choice: app/io/export_contents.h,
  // the table the CLI's help and docs/export.md show too.
  for (const ExportPresetContents& contents : ExportPresetContentsTable()) {
    const QString holds = QString::fromStdString(ExportPresetHolds(contents));
    preset_->addItem(QString::fromStdString(ExportPresetTitle(contents)),
                     int(ExportPresetFromName(contents.name)));
    preset_->setItemData(preset_->count() - 1, holds, Qt::ToolTipRole);
  }
  preset_->setCurrentIndex(preset_->findData(int(defaults.preset)));
  form->addRow(tr("Preset"), preset_);
  preset_contents_ = new QLabel(this);
  preset_contents_->setObjectName("exportPresetContents");
  preset_contents_->setWordWrap(true);
  preset_contents_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  form->addRow(tr("Files hold"), preset_contents_);
  convention_ = new QComboBox(this);
  convention_->setObjectName("normalConvention");
  convention_->addItem(tr("OpenGL (+Y up: Blender, Substance, Unity)"), int(ExportOptions::NormalConvention::kOpenGl));
  convention_->addItem(tr("DirectX (+Y down: Unreal, 3ds Max)"), int(ExportOptions::NormalConvention::kDirectX));
  convention_->setCurrentIndex(convention_->findData(int(defaults.normal_convention)));
  form->addRow(tr("Normal map"), convention_);
  flatten_ = new QCheckBox(tr("Flatten: take the sample's low-frequency slope out of the normals"), this);
  flatten_->setObjectName("flattenNormals");
  flatten_->setChecked(defaults.flatten_normals);
  form->addRow(QString(), flatten_);
  tileable_ = new QCheckBox(tr("Also write a seamless tileable crop of every map"), this);
  tileable_->setObjectName("tileable");
  tileable_->setChecked(defaults.tileable);
  form->addRow(QString(), tileable_);
  preview_page_ = new QCheckBox(tr("Write preview.html: the sample on a tile and a dome, for a browser"), this);
  preview_page_->setObjectName("previewPage");
  preview_page_->setChecked(defaults.preview_page);
  form->addRow(QString(), preview_page_);
  material_name_ = new QLineEdit(this);
  material_name_->setObjectName("materialName");
  material_name_->setPlaceholderText(tr("from the sample name"));
  form->addRow(tr("Material name"), material_name_);
  return form;
}

// Export, Cancel, the two that open what an export wrote, and *close at the end.
QHBoxLayout* ExportDialog::MakeButtons(QPushButton** close) {
  start_ = new QPushButton(tr("Export"), this);
  start_->setObjectName("startExport");
  start_->setDefault(true);
  cancel_ = new QPushButton(tr("Cancel export"), this);
  cancel_->setObjectName("cancelExport");
  cancel_->setEnabled(false);
  open_folder_ = new QPushButton(tr("Open export folder"), this);
  open_folder_->setObjectName("openExportFolder");
  open_folder_->setEnabled(false);
  open_preview_ = new QPushButton(tr("Open preview"), this);
  open_preview_->setObjectName("openPreview");
  open_preview_->setToolTip(tr("Opens the export's preview.html in the system's browser"));
  open_preview_->setEnabled(false);
  *close = new QPushButton(tr("Close"), this);
  auto* buttons = new QHBoxLayout;
  for (QPushButton* button : {start_, cancel_, open_folder_, open_preview_}) buttons->addWidget(button);
  buttons->addStretch();
  buttons->addWidget(*close);
  return buttons;
}

// The progress bar, the stage and status lines and the summary's text.
void ExportDialog::MakeProgressWidgets() {
  progress_ = new QProgressBar(this);
  progress_->setObjectName("exportProgress");
  progress_->setRange(0, 1000);
  progress_->setTextVisible(false);
  stage_ = new QLabel(this);
  stage_->setObjectName("exportStage");
  status_ = new QLabel(this);
  status_->setObjectName("exportStatus");
  status_->setWordWrap(true);
  status_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  summary_ = new QPlainTextEdit(this);
  summary_->setObjectName("exportSummary");
  summary_->setReadOnly(true);
  QFont mono("monospace");
  mono.setStyleHint(QFont::Monospace);
  mono.setPointSize(8);
  summary_->setFont(mono);
}

// The choices of the last export started (StartExport saves them).
void ExportDialog::RestoreSettings() {
  QSettings settings;
  settings.beginGroup("export");
  for (auto [combo, key] : {std::pair{preset_, "preset"}, std::pair{convention_, "convention"}}) {
    const int index = combo->findData(settings.value(key, combo->currentData()));
    if (index >= 0) combo->setCurrentIndex(index);
  }
  tileable_->setChecked(settings.value("tileable", tileable_->isChecked()).toBool());
  flatten_->setChecked(settings.value("flatten", flatten_->isChecked()).toBool());
  preview_page_->setChecked(settings.value("preview_page", preview_page_->isChecked()).toBool());
}

void ExportDialog::Connect(QPushButton* close) {
  // An engine preset writes its engine's normal convention whatever is chosen here.
  const auto follow_preset = [this] {
    const auto preset = ExportOptions::Preset(preset_->currentData().toInt());
    convention_->setEnabled(!IsEnginePreset(preset));
    preset_contents_->setText(QString::fromStdString(ExportPresetHolds(ExportPresetContentsOf(ExportPresetName(preset)))));
  };
  connect(preset_, &QComboBox::currentIndexChanged, this, follow_preset);
  follow_preset();
  connect(start_, &QPushButton::clicked, this, &ExportDialog::StartExport);
  connect(cancel_, &QPushButton::clicked, this, [this] {
    if (exporting_) runner_->Cancel();
  });
  connect(close, &QPushButton::clicked, this, &QDialog::close);
  connect(open_folder_, &QPushButton::clicked, this,
          [this] { QDesktopServices::openUrl(QUrl::fromLocalFile(QString::fromStdString(export_dir_.string()))); });
  connect(open_preview_, &QPushButton::clicked, this, [this] {
    if (!preview_path_.empty()) QDesktopServices::openUrl(PreviewUrl());
  });
  connect(runner_, &ControllerRunner::Progress, this,
          [this](const QString& stage, double fraction, const QString& detail) {
    if (!exporting_) return;
    progress_->setValue(int(fraction * 1000));
    stage_->setText(ProgressText(stage, detail));
  });
}

QString ExportDialog::PresetContentsText() const { return preset_contents_->text(); }

ExportOptions ExportDialog::OptionsFromWidgets() const {
  ExportOptions options;
  options.preset = ExportOptions::Preset(preset_->currentData().toInt());
  options.normal_convention = ExportOptions::NormalConvention(convention_->currentData().toInt());
  options.tileable = tileable_->isChecked();
  options.flatten_normals = flatten_->isChecked();
  options.preview_page = preview_page_->isChecked();
  options.material_name = material_name_->text().trimmed().toStdString();
  return options;
}

QUrl ExportDialog::PreviewUrl() const {
  return preview_path_.empty() ? QUrl() : QUrl::fromLocalFile(QString::fromStdString(preview_path_.string()));
}

void ExportDialog::SetStatus(const QString& text, bool error) {
  ShowStatusText(status_, text, error);
}

void ExportDialog::StartExport() {
  const ExportOptions options = OptionsFromWidgets();
  try {
    options.Check();
  } catch (const std::exception& error) {
    SetStatus(tr("Export options: %1").arg(error.what()), true);
    return;
  }
  QSettings settings;
  settings.beginGroup("export");
  settings.setValue("preset", preset_->currentData());
  settings.setValue("convention", convention_->currentData());
  settings.setValue("tileable", tileable_->isChecked());
  settings.setValue("flatten", flatten_->isChecked());
  settings.setValue("preview_page", preview_page_->isChecked());

  auto controller = std::make_shared<ExportController>(result_dir_, options);
  exporting_ = true;
  progress_->setValue(0);
  summary_->clear();
  preview_path_.clear();
  open_preview_->setEnabled(false);
  SetStatus(tr("Exporting into a new folder under the session's exports/…"));
  // The operator may close the dialog (deleting it) while the export runs;
  // the export then finishes on its own and the status bar tells its end.
  const QPointer<ExportDialog> alive(this);
  const bool started = runner_->Start(
      controller, tr("Export"), [this, alive, controller](ControllerRunner::Outcome outcome, const QString& message) {
        if (!alive) return;
        exporting_ = false;
        start_->setEnabled(true);
        cancel_->setEnabled(false);
        // The end in the stage line, not the last stage's progress.
        const QString seconds = QString::number(runner_->job_seconds(), 'f', 1);
        stage_->setText(outcome == ControllerRunner::Outcome::kSucceeded   ? tr("Export finished in %1 s").arg(seconds)
                        : outcome == ControllerRunner::Outcome::kCancelled ? tr("Export cancelled after %1 s").arg(seconds)
                                                                           : tr("Export failed after %1 s").arg(seconds));
        if (outcome == ControllerRunner::Outcome::kSucceeded) {
          const ExportSummary& summary = controller->summary();
          export_dir_ = summary.export_dir;
          progress_->setValue(1000);
          QString text = tr("Exported %1 files into %2")
                             .arg(summary.files.size())
                             .arg(QString::fromStdString(export_dir_.string()));
          if (summary.height_rms_error_mm) {
            text += tr("; height error vs ground truth %1 mm RMS").arg(*summary.height_rms_error_mm, 0, 'f', 4);
          }
          SetStatus(text + '.');
          summary_->setPlainText(QString::fromStdString(summary.FullReport()));
          open_folder_->setEnabled(true);
          const auto preview = summary.files.find("preview");
          if (preview != summary.files.end()) preview_path_ = export_dir_ / preview->second;
          open_preview_->setEnabled(!preview_path_.empty());
          emit Exported(QString::fromStdString(export_dir_.string()));
        } else if (outcome == ControllerRunner::Outcome::kCancelled) {
          progress_->setValue(0);
          SetStatus(tr("Export cancelled; no export folder was left."), true);
        } else {
          SetStatus(tr("Export failed: %1").arg(message), true);
        }
      });
  if (!started) {
    exporting_ = false;
    SetStatus(tr("%1 is running; export when it has finished").arg(runner_->job_name()), true);
    return;
  }
  start_->setEnabled(false);
  cancel_->setEnabled(true);
}

}  // namespace scanbench
