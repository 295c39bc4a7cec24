#include "app/gui/colour_legend.h"

#include <QLinearGradient>
#include <QPainter>

namespace scanbench {

ColourLegend::ColourLegend(QWidget* parent) : QWidget(parent) {
  setMinimumHeight(46);
  setSizePolicy(QSizePolicy::Expanding, QSizePolicy::Fixed);
}

void ColourLegend::SetScale(const HeatmapScale& scale) {
  scale_ = scale;
  setToolTip(RangeText());
  update();
}

QString ColourLegend::WithUnit(double value) const {
  const QString number = QString::number(value, 'g', 3);
  return scale_.unit.isEmpty() ? number : number + QLatin1Char(' ') + scale_.unit;
}

QString ColourLegend::LowText() const { return WithUnit(scale_.lo); }
QString ColourLegend::HighText() const { return WithUnit(scale_.hi); }

QString ColourLegend::RangeText() const {
  if (!scale_.has_values) return tr("%1: no finite value in the map").arg(scale_.quantity);
  return tr("%1: map min %2, max %3").arg(scale_.quantity, WithUnit(scale_.min), WithUnit(scale_.max));
}

void ColourLegend::paintEvent(QPaintEvent*) {
  QPainter painter(this);
  const int margin = 8;
  const QRect bar(margin, 4, width() - 2 * margin, 14);
  // The heatmap's own colours, sampled densely enough to look continuous.
  QLinearGradient gradient(bar.topLeft(), bar.topRight());
  constexpr int kStops = 32;
  for (int i = 0; i <= kStops; ++i) gradient.setColorAt(double(i) / kStops, QColor(HeatmapColour(double(i) / kStops)));
  painter.fillRect(bar, gradient);
  painter.setPen(palette().color(QPalette::WindowText));
  painter.drawRect(bar.adjusted(0, 0, -1, -1));
  const QRect text(margin, bar.bottom() + 3, bar.width(), height() - bar.bottom() - 3);
  painter.drawText(text, Qt::AlignLeft | Qt::AlignTop, LowText());
  const bool clamped = scale_.has_values && scale_.max > scale_.hi;
  painter.drawText(text, Qt::AlignRight | Qt::AlignTop, clamped ? QStringLiteral("≥ ") + HighText() : HighText());
  painter.drawText(text, Qt::AlignHCenter | Qt::AlignTop, RangeText());
}

}  // namespace scanbench
