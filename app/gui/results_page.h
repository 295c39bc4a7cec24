// Results: one result folder's maps (albedo, normal, status, confidence,
// angular error when the session had ground truth, specular F0 and roughness
// with specular.exr, height and occlusion from the result's newest export)
// in a zoom-and-pan view with a mm scale bar, a key under the map (the
// heatmap's scale or the status map's colours), the pixel under the cursor
// read out below it, the albedo's colour space and scale (report.json's
// "color"), a relight preview driven by a light the operator drags over a
// pad, and the solve's report across the page's width below.
#pragma once

#include <QFutureWatcher>
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
class QStackedWidget;
class QTextBrowser;

namespace scanbench {

class ColourLegend;
class ControllerRunner;
class ExportDialog;
class ImageView;
class LightPad;
class RelightRenderer;
class StatusLegend;

class ResultsPage : public QWidget {
  Q_OBJECT

 public:
  ResultsPage(ControllerRunner* runner, QWidget* parent = nullptr);

  // Shows `result_dir`, fitted to the view; false (and the reason on the
  // page) if it holds no maps. Typing a folder into the path field and Enter does the same.
  bool OpenResult(const QString& result_dir);
  // Selects a layer by its ResultLayerName; false if absent.
  bool ShowLayer(ResultLayer layer);
  const std::filesystem::path& result_dir() const { return result_dir_; }
  ImageView* view() const { return view_; }
  LightPad* light_pad() const { return pad_; }
  // Shown under heatmaps only.
  ColourLegend* legend() const { return legend_; }
  // Shown under the status map only.
  StatusLegend* status_legend() const { return status_legend_; }
  // The line under the map: the pixel under the cursor (DescribePixel).
  QLabel* readout() const { return readout_; }
  // The readout's maps are loaded off the UI thread when a result opens:
  // processes events until they are (tests). True if they are.
  bool WaitForPixelProbe(int timeout_ms);
  // The solve's report (summary.txt) as laid out on the page.
  QTextBrowser* report() const { return summary_; }
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
  void UpdateReadout(int x, int y);
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
  QStackedWidget* keys_;  // under the map, a fixed height: nothing, the heatmap's scale or the status key
  QDoubleSpinBox* roughness_;
  QDoubleSpinBox* f0_;
  ColourLegend* legend_;
  StatusLegend* status_legend_;
  QLabel* readout_;
  QPushButton* export_;
  QLabel* albedo_color_;  // report.json's "color": colour space, scale, description
  QTextBrowser* summary_;
  QLabel* status_;
  bool fit_next_ = true;  // a new result opens fitted, not at the last one's zoom
  std::optional<LayerImage> shown_;  // the map shown (not the relight), for the readout
  std::shared_ptr<const PixelProbeMaps> probe_;
  QFutureWatcher<std::shared_ptr<const PixelProbeMaps>>* probe_loader_;
  int probe_generation_ = 0;
  std::shared_ptr<const RelightMaps> relight_;  // loaded when the relight is first shown
  RelightRenderer* renderer_;
};

}  // namespace scanbench
