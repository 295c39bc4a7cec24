// Export of one result folder (issue #7's ExportController): the preset
// (linear EXR, 16-bit PNG or TIFF, an engine's; under it what its files hold,
// from app/io/export_contents.h), the normal map's convention (OpenGL +Y up
// or DirectX +Y down), an optional tileable crop and the material name; runs
// through the window's ControllerRunner with progress and Cancel, then shows
// the new export folder and the export's summary (the height error against
// ground truth for a simulated session); "Open preview" opens the export's
// preview.html in the system browser.
#pragma once

#include <QDialog>
#include <QUrl>
#include <filesystem>

#include "app/controllers/export_controller.h"

class QCheckBox;
class QComboBox;
class QFormLayout;
class QHBoxLayout;
class QLabel;
class QLineEdit;
class QPlainTextEdit;
class QProgressBar;
class QPushButton;

namespace scanbench {

class ControllerRunner;

class ExportDialog : public QDialog {
  Q_OBJECT

 public:
  ExportDialog(ControllerRunner* runner, std::filesystem::path result_dir, QWidget* parent = nullptr);

  const std::filesystem::path& result_dir() const { return result_dir_; }
  QComboBox* preset() const { return preset_; }
  // What the chosen preset's files hold, as shown under the choice.
  QString PresetContentsText() const;
  ExportOptions OptionsFromWidgets() const;
  // The folder the last export wrote; empty before one succeeded.
  const std::filesystem::path& export_dir() const { return export_dir_; }
  // file:// URL of the last export's preview.html, what "Open preview" opens;
  // empty before an export that wrote one.
  QUrl PreviewUrl() const;

 signals:
  void Exported(const QString& export_dir);

 public slots:
  void StartExport();

 private:
  // The constructor's steps.
  QFormLayout* MakeOptionsForm();
  QHBoxLayout* MakeButtons(QPushButton** close);
  void MakeProgressWidgets();
  void RestoreSettings();
  void Connect(QPushButton* close);
  void SetStatus(const QString& text, bool error = false);

  ControllerRunner* runner_;
  std::filesystem::path result_dir_;
  std::filesystem::path export_dir_;
  std::filesystem::path preview_path_;  // empty unless the last export wrote preview.html
  QComboBox* preset_;
  QLabel* preset_contents_;  // what the chosen preset's files hold (app/io/export_contents.h)
  QComboBox* convention_;
  QCheckBox* tileable_;
  QCheckBox* flatten_;
  QCheckBox* preview_page_;
  QLineEdit* material_name_;
  QPushButton* start_;
  QPushButton* cancel_;
  QPushButton* open_folder_;
  QPushButton* open_preview_;
  QProgressBar* progress_;
  QLabel* stage_;
  QLabel* status_;
  QPlainTextEdit* summary_;
  bool exporting_ = false;
};

}  // namespace scanbench
