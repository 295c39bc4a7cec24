// A map viewer: the image fitted to the widget at first, zoomed with the
// wheel about the cursor, panned by dragging; double-click fits again. It
// reports the image pixel under the cursor (PixelHovered) and, given the
// pixel pitch on the sample, draws a mm scale bar in the bottom-left corner.
#pragma once

#include <QImage>
#include <QPointF>
#include <QWidget>

namespace scanbench {

class ImageView : public QWidget {
  Q_OBJECT

 public:
  explicit ImageView(QWidget* parent = nullptr);

  // keep_view: the same zoom and pan (switching between maps of one result).
  void SetImage(const QImage& image, bool keep_view = false);
  const QImage& image() const { return image_; }
  double zoom() const { return zoom_; }
  void ZoomBy(double factor, QPointF about);
  void FitToWidget();
  bool fitted() const { return fitted_; }
  // Where image point `image_point` is on the widget, and back.
  QPointF ImageToWidget(QPointF image_point) const { return offset_ + image_point * zoom_; }
  QPointF WidgetToImage(QPointF widget_point) const { return (widget_point - offset_) / zoom_; }

  // The sample's mm per image pixel; 0 = unknown (no scale bar).
  void SetPixelPitchMm(double mm_per_pixel);
  double pixel_pitch_mm() const { return pixel_pitch_mm_; }
  // The image pixel under the cursor, (-1, -1) when none.
  QPoint hovered_pixel() const { return hovered_; }
  // The scale bar at the current zoom: its length in mm (a 1, 2 or 5 times a
  // power of ten, drawn 60 .. 150 widget pixels long) and its label ("5 mm",
  // "0.5 mm"); 0 and "" without a pixel pitch or image.
  double ScaleBarMm() const;
  QString ScaleBarText() const;
  // The nice length for a bar of about `target_px` widget pixels at
  // `mm_per_widget_px`: the largest 1, 2 or 5 x 10^k mm not above it.
  static double NiceScaleBarMm(double mm_per_widget_px, double target_px = 150);

 signals:
  // The image pixel under the cursor; (-1, -1) when it leaves the image.
  void PixelHovered(int x, int y);

 protected:
  void paintEvent(QPaintEvent* event) override;
  void wheelEvent(QWheelEvent* event) override;
  void mousePressEvent(QMouseEvent* event) override;
  void mouseMoveEvent(QMouseEvent* event) override;
  void mouseDoubleClickEvent(QMouseEvent* event) override;
  void resizeEvent(QResizeEvent* event) override;
  void leaveEvent(QEvent* event) override;

 private:
  void ReportHover(QPointF widget_point);
  QImage image_;
  double pixel_pitch_mm_ = 0;
  QPoint hovered_{-1, -1};
  double zoom_ = 1;   // widget pixels per image pixel
  QPointF offset_;    // widget position of the image's top-left corner
  QPointF drag_from_;
  bool fitted_ = true;  // follow resizes until the operator zooms or pans
};

// A round pad on which the operator drags a virtual light: the point is the
// light direction's (x, y) seen from above, z = sqrt(1 - x² - y²).
class LightPad : public QWidget {
  Q_OBJECT

 public:
  explicit LightPad(QWidget* parent = nullptr);
  QPointF direction_xy() const { return xy_; }
  void SetDirectionXY(QPointF xy);
  QSize sizeHint() const override { return {160, 160}; }

 signals:
  void DirectionChanged(double x, double y, double z);

 protected:
  void paintEvent(QPaintEvent* event) override;
  void mousePressEvent(QMouseEvent* event) override;
  void mouseMoveEvent(QMouseEvent* event) override;

 private:
  void SetFromWidget(QPointF position);
  QPointF xy_{0.35, 0.35};
};

}  // namespace scanbench
