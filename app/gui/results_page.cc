#include "app/gui/results_page.h"

#include <QCheckBox>
#include <QCoreApplication>
#include <QElapsedTimer>
#include <QComboBox>
#include <QDoubleSpinBox>
#include <QFile>
#include <QFileDialog>
#include <QFormLayout>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QSettings>
#include <QSplitter>
#include <QStackedWidget>
#include <QTextBrowser>
#include <QVBoxLayout>
#include <QtConcurrent/QtConcurrentRun>

#include "app/gui/colour_legend.h"
#include "app/gui/export_dialog.h"
#include "app/gui/image_view.h"
#include "app/gui/page_widgets.h"
#include "app/gui/relight_renderer.h"
#include "app/gui/report_text.h"
#include "app/io/result_maps.h"

namespace scanbench {

ResultsPage::ResultsPage(ControllerRunner* runner, QWidget* parent) : QWidget(parent), runner_(runner) {
  auto* layout = new QVBoxLayout(this);
  layout->addLayout(MakeTopRow());
  // The maps above, the solve's report across the whole width below (its
  // lines run to 400 characters: a side column would squeeze them).
  summary_ = new QTextBrowser(this);
  summary_->setObjectName("resultSummary");
  summary_->setOpenLinks(false);
  summary_->setLineWrapMode(QTextEdit::WidgetWidth);
  auto* upper = new QWidget(this);
  auto* middle = MakeMiddle();
  middle->setContentsMargins(0, 0, 0, 0);
  upper->setLayout(middle);
  auto* splitter = new QSplitter(Qt::Vertical, this);
  splitter->setObjectName("resultSplitter");
  splitter->addWidget(upper);
  splitter->addWidget(summary_);
  splitter->setStretchFactor(0, 3);
  splitter->setStretchFactor(1, 1);
  splitter->setChildrenCollapsible(false);
  layout->addWidget(splitter, 1);
  probe_loader_ = new QFutureWatcher<std::shared_ptr<const PixelProbeMaps>>(this);
  connect(probe_loader_, &QFutureWatcherBase::finished, this, [this] {
    // A result opened since is loading its own maps: this one's are dropped.
    if (probe_loader_->property("generation").toInt() != probe_generation_) return;
    probe_ = probe_loader_->result();
    const QPoint at = view_->hovered_pixel();
    UpdateReadout(at.x(), at.y());
  });
  status_ = new QLabel(tr("Wheel: zoom, drag: pan, double-click: fit."), this);
  status_->setObjectName("resultStatus");
  status_->setWordWrap(true);
  layout->addWidget(status_);
  MakeRenderer();
  // The relight controls and the legend show with the layers that use them.
  pad_->setVisible(false);
  pad_label_->setVisible(false);
  specular_box_->setVisible(false);
}

// The folder shown, the map chosen, export.
QLayout* ResultsPage::MakeTopRow() {
  folder_ = new QLineEdit(this);
  folder_->setObjectName("resultFolder");
  folder_->setPlaceholderText(tr("a result folder: <session>/results/<run-id> (type one and press Enter)"));
  folder_->setToolTip(tr("The result shown; type or paste another result folder and press Enter to open it"));
  connect(folder_, &QLineEdit::returnPressed, this, [this] {
    const QString typed = folder_->text().trimmed();
    if (!typed.isEmpty()) OpenResult(typed);
  });
  auto* open = new QPushButton(tr("Open result folder…"), this);
  layer_ = new QComboBox(this);
  layer_->setObjectName("resultLayer");
  auto* top = new QHBoxLayout;
  top->addWidget(folder_, 1);
  top->addWidget(open);
  top->addWidget(new QLabel(tr("Map"), this));
  top->addWidget(layer_);
  export_ = NamedButton(tr("Export…"), "exportResult", this);
  export_->setToolTip(tr("Derived maps (height, occlusion, cavity, roughness) in a preset for a material pipeline"));
  export_->setEnabled(false);
  top->addWidget(export_);

  connect(open, &QPushButton::clicked, this, [this] {
    QSettings settings;
    const QString dir = QFileDialog::getExistingDirectory(this, tr("Result folder"),
                                                          settings.value("results/last_folder").toString());
    if (dir.isEmpty()) return;
    settings.setValue("results/last_folder", dir);
    OpenResult(dir);
  });
  connect(layer_, &QComboBox::currentIndexChanged, this, &ResultsPage::ShowSelectedLayer);
  connect(export_, &QPushButton::clicked, this, &ResultsPage::OpenExportDialog);
  return top;
}

// The map view with its key and the pixel readout below, the side panel
// beside them. The key's place and the side panel keep their size whatever
// is shown, so switching maps never moves the picture.
QLayout* ResultsPage::MakeMiddle() {
  view_ = new ImageView(this);
  view_->setObjectName("resultView");
  connect(view_, &ImageView::PixelHovered, this, &ResultsPage::UpdateReadout);
  QWidget* side_widget = MakeSidePanel();
  legend_ = new ColourLegend(this);
  legend_->setObjectName("heatmapLegend");
  status_legend_ = new StatusLegend(this);
  status_legend_->setObjectName("statusLegend");
  keys_ = new QStackedWidget(this);
  keys_->setObjectName("mapKey");
  keys_->addWidget(new QWidget(keys_));  // albedo, normal, relight: no key
  keys_->addWidget(legend_);
  keys_->addWidget(status_legend_);
  keys_->setFixedHeight(std::max(legend_->sizeHint().height(), status_legend_->sizeHint().height()));
  readout_ = new QLabel(tr("Point at the map to read a pixel."), this);
  readout_->setObjectName("pixelReadout");
  readout_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  readout_->setFixedHeight(readout_->sizeHint().height());
  readout_->setSizePolicy(QSizePolicy::Ignored, QSizePolicy::Fixed);
  auto* map_column = new QVBoxLayout;
  map_column->addWidget(view_, 1);
  map_column->addWidget(keys_);
  map_column->addWidget(readout_);
  auto* middle = new QHBoxLayout;
  middle->addLayout(map_column, 1);
  middle->addWidget(side_widget);
  return middle;
}

// The light pad, the specular controls and the albedo's colour, in a column of a fixed width.
QWidget* ResultsPage::MakeSidePanel() {
  pad_ = new LightPad(this);
  pad_->setObjectName("lightPad");
  pad_->setFixedSize(170, 170);
  pad_label_ = new QLabel(tr("Drag the light (seen from above; centre = overhead)."), this);
  pad_label_->setWordWrap(true);
  specular_box_ = MakeSpecularBox();
  albedo_color_ = new QLabel(this);
  albedo_color_->setObjectName("resultAlbedoColor");
  albedo_color_->setWordWrap(true);
  albedo_color_->setTextInteractionFlags(Qt::TextSelectableByMouse);
  albedo_color_->setAlignment(Qt::AlignTop | Qt::AlignLeft);
  auto* side = new QVBoxLayout;
  side->setContentsMargins(0, 0, 0, 0);
  side->addWidget(pad_, 0, Qt::AlignHCenter);
  side->addWidget(pad_label_);
  side->addWidget(specular_box_);
  side->addWidget(albedo_color_);
  side->addStretch(1);
  auto* side_widget = new QWidget(this);
  side_widget->setObjectName("resultSidePanel");
  side_widget->setLayout(side);
  side_widget->setFixedWidth(280);
  return side_widget;
}

// UE4's specular lobe on top of the Lambertian term: how the fabric would
// look with a sheen; the solve itself is Lambertian only.
QWidget* ResultsPage::MakeSpecularBox() {
  auto* box = new QWidget(this);
  auto* specular_form = new QFormLayout(box);
  specular_form->setContentsMargins(0, 0, 0, 0);
  const RelightShading shading_defaults;
  specular_ = new QCheckBox(tr("Specular lobe (GGX)"), box);
  specular_->setObjectName("relightSpecular");
  specular_->setChecked(shading_defaults.specular);
  specular_form->addRow(specular_);
  roughness_ = new QDoubleSpinBox(box);
  roughness_->setObjectName("relightRoughness");
  roughness_->setRange(0.02, 1.0);
  roughness_->setSingleStep(0.05);
  roughness_->setDecimals(2);
  roughness_->setValue(shading_defaults.roughness);
  roughness_->setToolTip(tr("Perceptual roughness: 0.02 mirror-like .. 1 matte; GGX alpha = roughness²"));
  specular_form->addRow(tr("Roughness"), roughness_);
  f0_ = new QDoubleSpinBox(box);
  f0_->setObjectName("relightF0");
  f0_->setRange(0.0, 1.0);
  f0_->setSingleStep(0.01);
  f0_->setDecimals(3);
  f0_->setValue(shading_defaults.f0);
  f0_->setToolTip(tr("Reflectance at normal incidence: about 0.04 for fibres and plastics, 0.5-1 for metal threads"));
  specular_form->addRow(tr("F0"), f0_);

  auto rerender = [this] {
    roughness_->setEnabled(specular_->isChecked());
    f0_->setEnabled(specular_->isChecked());
    const QPointF xy = pad_->direction_xy();
    if (pad_->isVisible()) pad_->SetDirectionXY(xy);  // requests a render through UpdateRelight
  };
  connect(specular_, &QCheckBox::toggled, this, rerender);
  connect(roughness_, &QDoubleSpinBox::valueChanged, this, rerender);
  connect(f0_, &QDoubleSpinBox::valueChanged, this, rerender);
  roughness_->setEnabled(specular_->isChecked());
  f0_->setEnabled(specular_->isChecked());
  return box;
}

// The relight renders on a worker as the light moves and is painted when it arrives.
void ResultsPage::MakeRenderer() {
  connect(pad_, &LightPad::DirectionChanged, this, &ResultsPage::UpdateRelight);
  renderer_ = new RelightRenderer(RelightRendererOptions(), this);
  connect(renderer_, &RelightRenderer::Rendered, this, [this](const QImage& image) {
    // A render that ends after the operator switched maps must not cover the map shown.
    if (layer_->currentIndex() >= 0 && ResultLayer(layer_->currentData().toInt()) == ResultLayer::kRelight) {
      view_->SetImage(image, true);
    }
  });
  connect(renderer_, &RelightRenderer::Failed, this,
          [this](const QString& message) { ShowStatusText(status_, tr("Cannot relight: %1").arg(message), true); });
}

RelightShading ResultsPage::relight_shading() const {
  RelightShading shading;
  shading.specular = specular_->isChecked();
  shading.roughness = roughness_->value();
  shading.f0 = f0_->value();
  return shading;
}

void ResultsPage::SetRelightShading(const RelightShading& shading) {
  // One render for the three changes.
  {
    const QSignalBlocker block_specular(specular_), block_roughness(roughness_), block_f0(f0_);
    specular_->setChecked(shading.specular);
    roughness_->setValue(shading.roughness);
    f0_->setValue(shading.f0);
  }
  roughness_->setEnabled(shading.specular);
  f0_->setEnabled(shading.specular);
  if (pad_->isVisible()) pad_->SetDirectionXY(pad_->direction_xy());
}

ExportDialog* ResultsPage::OpenExportDialog() {
  if (result_dir_.empty() || layer_->count() == 0) return nullptr;
  // One dialog per result; a new one replaces an earlier, finished one.
  for (ExportDialog* old : findChildren<ExportDialog*>()) {
    if (old->result_dir() == result_dir_) {
      old->show();
      old->raise();
      return old;
    }
  }
  auto* dialog = new ExportDialog(runner_, result_dir_, this);
  dialog->setAttribute(Qt::WA_DeleteOnClose);
  dialog->show();
  return dialog;
}

bool ResultsPage::OpenResult(const QString& dir) {
  result_dir_ = std::filesystem::path(dir.toStdString());
  folder_->setText(dir);
  relight_.reset();
  renderer_->SetMaps(nullptr);
  fit_next_ = true;
  shown_.reset();
  probe_.reset();
  ++probe_generation_;
  readout_->setText(tr("Point at the map to read a pixel."));
  std::string no_scale;
  const std::optional<double> pitch = ResultPixelPitchMm(result_dir_, &no_scale);
  view_->SetPixelPitchMm(pitch.value_or(0));
  view_->setToolTip(pitch ? tr("%1 mm per pixel on the sample (the session rig at the image centre)")
                                .arg(*pitch, 0, 'g', 4)
                          : tr("No scale bar: %1").arg(QString::fromStdString(no_scale)));
  const QList<ResultLayer> layers = AvailableLayers(result_dir_);
  {
    const QSignalBlocker block(layer_);
    layer_->clear();
    for (ResultLayer layer : layers) layer_->addItem(ResultLayerName(layer), int(layer));
  }
  QFile summary(dir + "/summary.txt");
  summary_->setHtml(ReportHtml(summary.open(QIODevice::ReadOnly) ? QString::fromUtf8(summary.readAll())
                                                                 : tr("(no summary.txt in this folder)")));
  ShowAlbedoColor();
  export_->setEnabled(!layers.isEmpty());
  if (layers.isEmpty()) {
    keys_->setCurrentIndex(0);
    view_->SetImage(QImage());
    ShowStatusText(status_,
                   tr("%1 holds no maps: open a folder under <session>/results/, or solve the session first.")
                       .arg(dir),
                   true);
    return false;
  }
  // The readout's maps, off the UI thread (four full-size maps at 16 MP).
  probe_loader_->setProperty("generation", probe_generation_);
  probe_loader_->setFuture(QtConcurrent::run([dir = result_dir_]() -> std::shared_ptr<const PixelProbeMaps> {
    try {
      return std::make_shared<const PixelProbeMaps>(LoadPixelProbeMaps(dir));
    } catch (const std::exception&) {
      return nullptr;  // the readout then says the maps cannot be read
    }
  }));
  ShowSelectedLayer();
  return true;
}

bool ResultsPage::WaitForPixelProbe(int timeout_ms) {
  QElapsedTimer timer;
  timer.start();
  while (!(probe_loader_->isFinished() && probe_loader_->property("generation").toInt() == probe_generation_ &&
           probe_)) {
    if (timer.elapsed() > timeout_ms) return false;
    QCoreApplication::processEvents(QEventLoop::AllEvents, 20);
  }
  return true;
}

void ResultsPage::UpdateReadout(int x, int y) {
  if (x < 0 || y < 0) {
    readout_->setText(tr("Point at the map to read a pixel."));
    return;
  }
  if (!probe_) {
    readout_->setText(probe_loader_->isRunning() ? tr("x %1, y %2 · reading the maps…").arg(x).arg(y)
                                                 : tr("x %1, y %2 · the result's maps cannot be read").arg(x).arg(y));
    return;
  }
  readout_->setText(DescribePixel(*probe_, x, y, shown_ ? &*shown_ : nullptr));
}

void ResultsPage::ShowAlbedoColor() {
  QFile report(QString::fromStdString((result_dir_ / "report.json").string()));
  if (!report.open(QIODevice::ReadOnly)) {
    ShowStatusText(albedo_color_, tr("Albedo colour: unknown (no report.json in this folder)"), true);
    albedo_color_->setToolTip(QString());
    return;
  }
  try {
    const ResultAlbedoColor color = AlbedoColorOfReport(report.readAll().toStdString());
    ShowStatusText(albedo_color_,
                   tr("Albedo: %1, %2 — %3")
                       .arg(QString::fromStdString(color.color_space), QString::fromStdString(color.scale),
                            QString::fromStdString(color.description)),
                   false);
    albedo_color_->setToolTip(QString::fromStdString(color.scale_source));
  } catch (const std::exception& error) {
    ShowStatusText(albedo_color_, tr("Albedo colour: unknown (%1: %2)").arg(report.fileName(), error.what()), true);
    albedo_color_->setToolTip(QString());
  }
}

bool ResultsPage::ShowLayer(ResultLayer layer) {
  const int index = layer_->findData(int(layer));
  if (index < 0) return false;
  layer_->setCurrentIndex(index);
  ShowSelectedLayer();
  return true;
}

void ResultsPage::ShowSelectedLayer() {
  if (layer_->currentIndex() < 0) return;
  const auto layer = ResultLayer(layer_->currentData().toInt());
  const bool relight = layer == ResultLayer::kRelight;
  pad_->setVisible(relight);
  pad_label_->setVisible(relight);
  specular_box_->setVisible(relight);
  keys_->setCurrentIndex(0);
  shown_.reset();
  // A new result's first map fits the view; switching maps keeps zoom and pan.
  const bool keep_view = !fit_next_;
  fit_next_ = false;
  try {
    if (relight) {
      if (!relight_) {
        relight_ = std::make_shared<const RelightMaps>(LoadRelightMaps(result_dir_));
        renderer_->SetMaps(relight_);
      }
      if (!keep_view) view_->FitToWidget();
      const QPointF xy = pad_->direction_xy();
      pad_->SetDirectionXY(xy);  // requests a render through UpdateRelight
    } else {
      LayerImage shown = LoadResultLayerImage(result_dir_, layer);
      view_->SetImage(shown.image, keep_view);
      if (shown.scale) {
        legend_->SetScale(*shown.scale);
        keys_->setCurrentWidget(legend_);
      } else if (shown.status) {
        status_legend_->SetCounts(*shown.status);
        keys_->setCurrentWidget(status_legend_);
      }
      shown.image = QImage();  // the view holds it; the readout needs the values only
      shown_ = std::move(shown);
    }
    const QPoint at = view_->hovered_pixel();
    UpdateReadout(at.x(), at.y());
    ShowStatusText(status_, tr("%1 — wheel: zoom, drag: pan, double-click: fit.").arg(ResultLayerName(layer)),
                   false);
  } catch (const std::exception& error) {
    ShowStatusText(status_, tr("Cannot show %1: %2").arg(ResultLayerName(layer), error.what()), true);
  }
}

bool ResultsPage::WaitForRelight(int timeout_ms) { return renderer_->WaitUntilIdle(timeout_ms); }

void ResultsPage::UpdateRelight(double x, double y, double z) {
  if (!relight_) return;
  try {
    renderer_->Request(x, y, z, relight_shading());
  } catch (const std::exception& error) {  // an exception must not leave a Qt slot
    ShowStatusText(status_, tr("Cannot relight: %1").arg(error.what()), true);
  }
}

}  // namespace scanbench
