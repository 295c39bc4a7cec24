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

StatusLegend::StatusLegend(QWidget* parent) : QWidget(parent) {
  setMinimumHeight(76);
  setSizePolicy(QSizePolicy::Expanding, QSizePolicy::Fixed);
}

void StatusLegend::SetCounts(const StatusCounts& counts) {
  counts_ = counts;
  QStringList tips;
  for (const StatusCodeInfo& info : StatusCodes()) {
    tips << QStringLiteral("%1 = %2: %3").arg(info.code).arg(QString::fromUtf8(info.name), QString::fromUtf8(info.meaning));
  }
  setToolTip(tr("status.png codes:\n%1").arg(tips.join('\n')));
  update();
}

QString StatusLegend::Headline() const { return QString::fromStdString(counts_.Headline()); }

QStringList StatusLegend::EntryTexts() const {
  QStringList texts;
  for (const StatusCodeInfo& info : StatusCodes()) {
    const size_t pixels = counts_.pixels[info.code];
    const QString share = counts_.total == 0 || pixels == 0 ? QString()
                                             : QStringLiteral(" (%1)").arg(QString::fromStdString(
                                                   FlooredPercentText(pixels, counts_.total)));
    texts << QStringLiteral("%1: %2 px%3").arg(QString::fromUtf8(info.name)).arg(pixels).arg(share);
  }
  return texts;
}

void StatusLegend::paintEvent(QPaintEvent*) {
  QPainter painter(this);
  const int margin = 8, line = painter.fontMetrics().height() + 2;
  QFont bold = font();
  bold.setBold(true);
  painter.setFont(bold);
  const bool all_solved = counts_.solved() == counts_.in_region();
  painter.setPen(all_solved ? palette().color(QPalette::WindowText) : QColor(200, 60, 40));
  painter.drawText(QRect(margin, 2, width() - 2 * margin, line), Qt::AlignLeft | Qt::AlignVCenter, Headline());
  painter.setFont(font());
  painter.setPen(palette().color(QPalette::WindowText));
  // The solved codes on the first row, the failures three a row below: every
  // colour named, the ones absent from the map dimmed.
  const QStringList texts = EntryTexts();
  QList<int> solved, failed;
  for (const StatusCodeInfo& info : StatusCodes()) (info.solved ? solved : failed).append(info.code);
  const int full_width = width() - 2 * margin;
  auto draw = [&](int code, int x, int y, int column_width) {
    const StatusCodeInfo& info = StatusCodes()[code];
    const QRect swatch(x, y + 2, line - 4, line - 4);
    painter.fillRect(swatch, QColor(info.r, info.g, info.b));
    painter.setPen(palette().color(QPalette::WindowText));
    painter.drawRect(swatch.adjusted(0, 0, -1, -1));
    const bool present = counts_.pixels[info.code] > 0;
    painter.setPen(present ? palette().color(QPalette::WindowText) : palette().color(QPalette::PlaceholderText));
    const int text_width = column_width - line - 4;
    painter.drawText(QRect(x + line, y, text_width, line), Qt::AlignLeft | Qt::AlignVCenter,
                     painter.fontMetrics().elidedText(texts[code], Qt::ElideRight, text_width));
  };
  for (int i = 0; i < int(solved.size()); ++i) {
    const int column_width = full_width / int(solved.size());
    draw(solved[i], margin + i * column_width, 2 + line, column_width);
  }
  constexpr int kColumns = 3;
  for (int i = 0; i < int(failed.size()); ++i) {
    const int column_width = full_width / kColumns;
    draw(failed[i], margin + (i % kColumns) * column_width, 2 + line * (2 + i / kColumns), column_width);
  }
}

}  // namespace scanbench
