#include "app/gui/image_view.h"

#include <QMouseEvent>
#include <QPainter>
#include <QWheelEvent>

#include <algorithm>
#include <cmath>

namespace scanbench {

ImageView::ImageView(QWidget* parent) : QWidget(parent) {
  setMinimumSize(200, 150);
  setMouseTracking(false);
  setCursor(Qt::OpenHandCursor);
}

void ImageView::SetImage(const QImage& image, bool keep_view) {
  const bool same_size = image.size() == image_.size();
  image_ = image;
  if (!keep_view || !same_size || fitted_) FitToWidget();
  update();
}

void ImageView::FitToWidget() {
  fitted_ = true;
  if (image_.isNull() || width() <= 0 || height() <= 0) return;
  zoom_ = std::min(double(width()) / image_.width(), double(height()) / image_.height());
  offset_ = QPointF((width() - image_.width() * zoom_) / 2, (height() - image_.height() * zoom_) / 2);
  update();
}

void ImageView::ZoomBy(double factor, QPointF about) {
  if (image_.isNull()) return;
  const double zoom = std::clamp(zoom_ * factor, 0.02, 64.0);
  // Keep the image point under `about` where it is.
  offset_ = about - (about - offset_) * (zoom / zoom_);
  zoom_ = zoom;
  fitted_ = false;
  update();
}

void ImageView::paintEvent(QPaintEvent*) {
  QPainter painter(this);
  painter.fillRect(rect(), QColor(40, 40, 40));
  if (image_.isNull()) {
    painter.setPen(Qt::lightGray);
    painter.drawText(rect(), Qt::AlignCenter, tr("No map loaded"));
    return;
  }
  // Magnified pixels stay sharp squares; reduced ones are smoothed.
  painter.setRenderHint(QPainter::SmoothPixmapTransform, zoom_ < 1);
  painter.drawImage(QRectF(offset_, QSizeF(image_.width() * zoom_, image_.height() * zoom_)), image_);
}

void ImageView::wheelEvent(QWheelEvent* event) {
  ZoomBy(std::pow(1.0015, event->angleDelta().y()), event->position());
  event->accept();
}

void ImageView::mousePressEvent(QMouseEvent* event) { drag_from_ = event->position(); }

void ImageView::mouseMoveEvent(QMouseEvent* event) {
  if (!(event->buttons() & Qt::LeftButton)) return;
  offset_ += event->position() - drag_from_;
  drag_from_ = event->position();
  fitted_ = false;
  update();
}

void ImageView::mouseDoubleClickEvent(QMouseEvent*) { FitToWidget(); }

void ImageView::resizeEvent(QResizeEvent*) {
  if (fitted_) FitToWidget();
}

LightPad::LightPad(QWidget* parent) : QWidget(parent) { setMinimumSize(120, 120); }

void LightPad::SetDirectionXY(QPointF xy) {
  const double r = std::hypot(xy.x(), xy.y());
  xy_ = r > 0.98 ? xy * (0.98 / r) : xy;  // stay above the horizon
  update();
  emit DirectionChanged(xy_.x(), xy_.y(), std::sqrt(std::max(0.0, 1 - xy_.x() * xy_.x() - xy_.y() * xy_.y())));
}

void LightPad::paintEvent(QPaintEvent*) {
  QPainter painter(this);
  painter.setRenderHint(QPainter::Antialiasing);
  const double radius = std::min(width(), height()) / 2.0 - 4;
  const QPointF centre(width() / 2.0, height() / 2.0);
  painter.setBrush(QColor(60, 60, 70));
  painter.setPen(QPen(Qt::gray, 1));
  painter.drawEllipse(centre, radius, radius);
  painter.drawLine(centre - QPointF(radius, 0), centre + QPointF(radius, 0));
  painter.drawLine(centre - QPointF(0, radius), centre + QPointF(0, radius));
  // +y of the tangent frame is the top of the image.
  const QPointF light = centre + QPointF(xy_.x() * radius, -xy_.y() * radius);
  painter.setBrush(QColor(255, 220, 90));
  painter.setPen(Qt::NoPen);
  painter.drawEllipse(light, 7, 7);
}

void LightPad::mousePressEvent(QMouseEvent* event) { SetFromWidget(event->position()); }
void LightPad::mouseMoveEvent(QMouseEvent* event) {
  if (event->buttons() & Qt::LeftButton) SetFromWidget(event->position());
}

void LightPad::SetFromWidget(QPointF position) {
  const double radius = std::min(width(), height()) / 2.0 - 4;
  SetDirectionXY(QPointF((position.x() - width() / 2.0) / radius, -(position.y() - height() / 2.0) / radius));
}

}  // namespace scanbench
