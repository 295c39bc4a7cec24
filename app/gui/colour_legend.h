// The colour scale of a heatmap under the map: the gradient from the scale's
// low to high end with their values and unit, and the map's own smallest and
// largest value (which may lie beyond the scale: those pixels are clamped).
#pragma once

#include <QWidget>

#include "app/gui/result_images.h"
#include "app/io/status_codes.h"

namespace scanbench {

class ColourLegend : public QWidget {
  Q_OBJECT

 public:
  explicit ColourLegend(QWidget* parent = nullptr);
  void SetScale(const HeatmapScale& scale);
  const HeatmapScale& scale() const { return scale_; }
  // The texts drawn: "0 deg" at the low end, "5 deg" at the high end, and
  // "angular error: map min 0.01 deg, max 7.2 deg".
  QString LowText() const;
  QString HighText() const;
  QString RangeText() const;
  QSize sizeHint() const override { return {400, 46}; }

 protected:
  void paintEvent(QPaintEvent* event) override;

 private:
  QString WithUnit(double value) const;
  HeatmapScale scale_;
};

// The key of the status map: a headline ("100 % solved (…)") and a swatch
// for every code of app/io/status_codes.h with its name and pixel count, in
// the colours the map is drawn in.
class StatusLegend : public QWidget {
  Q_OBJECT

 public:
  explicit StatusLegend(QWidget* parent = nullptr);
  void SetCounts(const StatusCounts& counts);
  const StatusCounts& counts() const { return counts_; }
  QString Headline() const;
  // One per code, in code order: "solved, no specular lobe: 76 000 px (99 %)".
  QStringList EntryTexts() const;
  QSize sizeHint() const override { return {600, 76}; }

 protected:
  void paintEvent(QPaintEvent* event) override;

 private:
  StatusCounts counts_;
};

}  // namespace scanbench
