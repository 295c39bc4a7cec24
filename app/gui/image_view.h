// A map viewer: the image fitted to the widget at first, zoomed with the
// wheel about the cursor, panned by dragging; double-click fits again.
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

 protected:
  void paintEvent(QPaintEvent* event) override;
  void wheelEvent(QWheelEvent* event) override;
  void mousePressEvent(QMouseEvent* event) override;
  void mouseMoveEvent(QMouseEvent* event) override;
  void mouseDoubleClickEvent(QMouseEvent* event) override;
  void resizeEvent(QResizeEvent* event) override;

 private:
  QImage image_;
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
