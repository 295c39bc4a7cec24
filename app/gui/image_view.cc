#include "app/gui/image_view.h"

#include <QMouseEvent>
#include <QPainter>
#include <QWheelEvent>

#include <algorithm>
#include <cmath>

namespace scanbench {

ImageView::ImageView(QWidget* parent) : QWidget(parent) {
  setMinimumSize(200, 150);
  setMouseTracking(true);  // the pixel readout follows the cursor
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

void ImageView::SetPixelPitchMm(double mm_per_pixel) {
  pixel_pitch_mm_ = std::isfinite(mm_per_pixel) && mm_per_pixel > 0 ? mm_per_pixel : 0;
  update();
}

double ImageView::NiceScaleBarMm(double mm_per_widget_px, double target_px) {
  if (!(mm_per_widget_px > 0) || !std::isfinite(mm_per_widget_px)) return 0;
  const double most = mm_per_widget_px * target_px;
  const double decade = std::pow(10.0, std::floor(std::log10(most)));
  for (double step : {5.0, 2.0, 1.0}) {
    if (step * decade <= most * (1 + 1e-9)) return step * decade;
  }
  return decade;
}

double ImageView::ScaleBarMm() const {
  if (image_.isNull() || pixel_pitch_mm_ <= 0 || zoom_ <= 0) return 0;
  return NiceScaleBarMm(pixel_pitch_mm_ / zoom_);
}

QString ImageView::ScaleBarText() const {
  const double mm = ScaleBarMm();
  if (mm <= 0) return {};
  return mm >= 1000 ? QStringLiteral("%1 m").arg(mm / 1000, 0, 'g', 3) : QStringLiteral("%1 mm").arg(mm, 0, 'g', 3);
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
  const double bar_mm = ScaleBarMm();
  if (bar_mm > 0) {
    // Bottom-left, white on a dark band so it reads on every map.
    const double length = bar_mm * zoom_ / pixel_pitch_mm_;
    const QString text = ScaleBarText();
    const int text_width = painter.fontMetrics().horizontalAdvance(text);
    const QRectF band(8, height() - 34, std::max(length, double(text_width)) + 12, 26);
    painter.setRenderHint(QPainter::SmoothPixmapTransform, false);
    painter.fillRect(band, QColor(0, 0, 0, 150));
    painter.fillRect(QRectF(band.left() + 6, band.bottom() - 9, length, 4), Qt::white);
    painter.setPen(Qt::white);
    painter.drawText(QRectF(band.left() + 6, band.top() + 1, band.width() - 12, 14), Qt::AlignLeft | Qt::AlignVCenter,
                     text);
  }
}

void ImageView::ReportHover(QPointF widget_point) {
  QPoint pixel(-1, -1);
  if (!image_.isNull() && zoom_ > 0) {
    const QPointF at = WidgetToImage(widget_point);
    const int x = int(std::floor(at.x())), y = int(std::floor(at.y()));
    if (x >= 0 && y >= 0 && x < image_.width() && y < image_.height()) pixel = QPoint(x, y);
  }
  if (pixel == hovered_) return;
  hovered_ = pixel;
  emit PixelHovered(pixel.x(), pixel.y());
}

void ImageView::leaveEvent(QEvent*) {
  if (hovered_ == QPoint(-1, -1)) return;
  hovered_ = QPoint(-1, -1);
  emit PixelHovered(-1, -1);
}

void ImageView::wheelEvent(QWheelEvent* event) {
  ZoomBy(std::pow(1.0015, event->angleDelta().y()), event->position());
  event->accept();
}

void ImageView::mousePressEvent(QMouseEvent* event) { drag_from_ = event->position(); }

void ImageView::mouseMoveEvent(QMouseEvent* event) {
  ReportHover(event->position());
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
