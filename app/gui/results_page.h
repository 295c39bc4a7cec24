// Results: one result folder's maps (albedo, normal, status, confidence,
// angular error when the session had ground truth) in a zoom-and-pan view,
// the solver's summary beside them with the albedo's colour space and scale
// (report.json's "color"), and a relight preview driven by a light the
// operator drags over a pad.
#pragma once

#include <QWidget>

#include <filesystem>
#include <memory>

#include "app/gui/result_images.h"

class QCheckBox;
class QComboBox;
class QDoubleSpinBox;
class QLabel;
class QLayout;
class QPushButton;
class QLineEdit;
class QPlainTextEdit;

namespace scanbench {

class ColourLegend;
class ControllerRunner;
class ExportDialog;
class ImageView;
class LightPad;
class RelightRenderer;

class ResultsPage : public QWidget {
  Q_OBJECT

 public:
  ResultsPage(ControllerRunner* runner, QWidget* parent = nullptr);

  // Shows `result_dir`; false (and the reason on the page) if it holds no maps.
  bool OpenResult(const QString& result_dir);
  // Selects a layer by its ResultLayerName; false if absent.
  bool ShowLayer(ResultLayer layer);
  const std::filesystem::path& result_dir() const { return result_dir_; }
  ImageView* view() const { return view_; }
  LightPad* light_pad() const { return pad_; }
  // Shown under heatmaps only.
  ColourLegend* legend() const { return legend_; }
  // The relight's shading as the controls set it.
  RelightShading relight_shading() const;
  void SetRelightShading(const RelightShading& shading);
  // Opens the export dialog for the shown result (nullptr without one).
  ExportDialog* OpenExportDialog();
  // The relight is rendered on a worker (RelightRenderer) and painted when
  // it arrives; this processes events until the last light position's image
  // is shown (tests, the screenshot tour). True if it is.
  bool WaitForRelight(int timeout_ms);
  RelightRenderer* relight_renderer() const { return renderer_; }

 private:
  // The constructor's steps; each builds one row or panel and connects its
  // own widgets.
  QLayout* MakeTopRow();
  QLayout* MakeMiddle();
  QWidget* MakeSidePanel();
  QWidget* MakeSpecularBox();
  void MakeRenderer();

  void ShowSelectedLayer();
  // The albedo's colour line from the result's report.json.
  void ShowAlbedoColor();
  void UpdateRelight(double x, double y, double z);

  ControllerRunner* runner_;
  std::filesystem::path result_dir_;
  QLineEdit* folder_;
  QComboBox* layer_;
  ImageView* view_;
  LightPad* pad_;
  QLabel* pad_label_;
  QWidget* specular_box_;
  QCheckBox* specular_;
  QDoubleSpinBox* roughness_;
  QDoubleSpinBox* f0_;
  ColourLegend* legend_;
  QPushButton* export_;
  QLabel* albedo_color_;  // report.json's "color": colour space, scale, description
  QPlainTextEdit* summary_;
  QLabel* status_;
  std::shared_ptr<const RelightMaps> relight_;  // loaded when the relight is first shown
  RelightRenderer* renderer_;
};

}  // namespace scanbench
