#include "app/gui/results_page.h"

#include <QComboBox>
#include <QFile>
#include <QFileDialog>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QPlainTextEdit>
#include <QPushButton>
#include <QSettings>
#include <QVBoxLayout>

#include "app/gui/image_view.h"

namespace scanbench {

ResultsPage::ResultsPage(QWidget* parent) : QWidget(parent) {
  folder_ = new QLineEdit(this);
  folder_->setObjectName("resultFolder");
  folder_->setReadOnly(true);
  folder_->setPlaceholderText(tr("a result folder: <session>/results/<run-id>"));
  auto* open = new QPushButton(tr("Open result folder…"), this);
  layer_ = new QComboBox(this);
  layer_->setObjectName("resultLayer");
  auto* top = new QHBoxLayout;
  top->addWidget(folder_, 1);
  top->addWidget(open);
  top->addWidget(new QLabel(tr("Map"), this));
  top->addWidget(layer_);

  view_ = new ImageView(this);
  view_->setObjectName("resultView");
  pad_ = new LightPad(this);
  pad_->setObjectName("lightPad");
  pad_->setFixedSize(170, 170);
  pad_label_ = new QLabel(tr("Drag the light (seen from above; centre = overhead)."), this);
  pad_label_->setWordWrap(true);
  summary_ = new QPlainTextEdit(this);
  summary_->setObjectName("resultSummary");
  summary_->setReadOnly(true);
  summary_->setLineWrapMode(QPlainTextEdit::WidgetWidth);
  QFont mono("monospace");
  mono.setStyleHint(QFont::Monospace);
  mono.setPointSize(8);
  summary_->setFont(mono);
  auto* side = new QVBoxLayout;
  side->addWidget(pad_, 0, Qt::AlignHCenter);
  side->addWidget(pad_label_);
  side->addWidget(summary_, 1);
  auto* side_widget = new QWidget(this);
  side_widget->setLayout(side);
  side_widget->setMaximumWidth(360);

  auto* middle = new QHBoxLayout;
  middle->addWidget(view_, 1);
  middle->addWidget(side_widget);
  status_ = new QLabel(tr("Wheel: zoom, drag: pan, double-click: fit."), this);
  status_->setObjectName("resultStatus");
  status_->setWordWrap(true);
  auto* layout = new QVBoxLayout(this);
  layout->addLayout(top);
  layout->addLayout(middle, 1);
  layout->addWidget(status_);

  connect(open, &QPushButton::clicked, this, [this] {
    QSettings settings;
    const QString dir = QFileDialog::getExistingDirectory(this, tr("Result folder"),
                                                          settings.value("results/last_folder").toString());
    if (dir.isEmpty()) return;
    settings.setValue("results/last_folder", dir);
    OpenResult(dir);
  });
  connect(layer_, &QComboBox::currentIndexChanged, this, &ResultsPage::ShowSelectedLayer);
  connect(pad_, &LightPad::DirectionChanged, this, &ResultsPage::UpdateRelight);
  pad_->setVisible(false);
  pad_label_->setVisible(false);
}

bool ResultsPage::OpenResult(const QString& dir) {
  result_dir_ = std::filesystem::path(dir.toStdString());
  folder_->setText(dir);
  relight_.reset();
  const QList<ResultLayer> layers = AvailableLayers(result_dir_);
  {
    const QSignalBlocker block(layer_);
    layer_->clear();
    for (ResultLayer layer : layers) layer_->addItem(ResultLayerName(layer), int(layer));
  }
  QFile summary(dir + "/summary.txt");
  summary_->setPlainText(summary.open(QIODevice::ReadOnly) ? QString::fromUtf8(summary.readAll())
                                                           : tr("(no summary.txt in this folder)"));
  if (layers.isEmpty()) {
    view_->SetImage(QImage());
    status_->setText(tr("%1 holds no maps: open a folder under <session>/results/, or solve the session first.")
                         .arg(dir));
    return false;
  }
  ShowSelectedLayer();
  return true;
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
  try {
    if (relight) {
      if (!relight_) relight_ = LoadRelightMaps(result_dir_);
      const QPointF xy = pad_->direction_xy();
      pad_->SetDirectionXY(xy);  // renders through UpdateRelight
    } else {
      view_->SetImage(LoadResultLayer(result_dir_, layer), true);
    }
    status_->setText(tr("%1 — wheel: zoom, drag: pan, double-click: fit.").arg(ResultLayerName(layer)));
  } catch (const std::exception& error) {
    status_->setText(tr("Cannot show %1: %2").arg(ResultLayerName(layer), error.what()));
  }
}

void ResultsPage::UpdateRelight(double x, double y, double z) {
  if (!relight_) return;
  view_->SetImage(Relight(*relight_, x, y, z), true);
}

}  // namespace scanbench
