#include "app/gui/relight_renderer.h"

#include <QCoreApplication>
#include <QDeadlineTimer>
#include <QThread>
#include <QtConcurrent/QtConcurrentRun>

#include <atomic>
#include <cmath>
#include <exception>

#include "core/field_error.h"

namespace scanbench {

namespace {

// Every `step`-th pixel of the maps, from (0, 0).
RelightMaps Subsample(const RelightMaps& maps, int step) {
  RelightMaps small;
  const int width = (maps.normal.width() + step - 1) / step, height = (maps.normal.height() + step - 1) / step;
  small.normal = ImageF(width, height, 3);
  small.albedo = ImageF(width, height, 3);
  small.albedo_scale = maps.albedo_scale;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      for (int c = 0; c < 3; ++c) {
        small.normal(x, y, c) = maps.normal(x * step, y * step, c);
        small.albedo(x, y, c) = maps.albedo(x * step, y * step, c);
      }
    }
  }
  return small;
}

}  // namespace

void RelightRendererOptions::Check() const {
  SCANBENCH_REQUIRE_GE("RelightRendererOptions", "preview_max_pixels", preview_max_pixels, 0);
}

RelightRenderer::RelightRenderer(const RelightRendererOptions& options, QObject* parent)
    : QObject(parent), options_(options), watcher_(new QFutureWatcher<Result>(this)) {
  options_.Check();
  connect(watcher_, &QFutureWatcher<Result>::finished, this, &RelightRenderer::OnFinished);
}

RelightRenderer::~RelightRenderer() {
  if (running_) running_stop_->store(true);  // its image would be dropped
}

void RelightRenderer::SetMaps(std::shared_ptr<const RelightMaps> maps) {
  if (running_) running_stop_->store(true);  // its image would be dropped
  maps_ = std::move(maps);
  ++maps_generation_;
  pending_.reset();
}

void RelightRenderer::Request(double lx, double ly, double lz, const RelightShading& shading) {
  shading.Check();
  if (!maps_) return;
  const LightRequest request{lx, ly, lz, shading};
  if (running_) {
    pending_ = request;  // an older waiting request is stale: drop it
    // Refining an older position to full size takes seconds on a large map:
    // abandon it, so that the new position's preview comes at once. (A render
    // without a preview before it is let finish: on a drag something shows.)
    if (running_full_size_ && PreviewStep() > 1) running_stop_->store(true);
    return;
  }
  Start(request, PreviewStep() == 1);
}

int RelightRenderer::PreviewStep() const {
  const double pixels = double(maps_->normal.width()) * maps_->normal.height();
  if (options_.preview_max_pixels == 0 || pixels <= options_.preview_max_pixels) return 1;
  return int(std::ceil(std::sqrt(pixels / options_.preview_max_pixels)));
}

void RelightRenderer::Start(const LightRequest& request, bool full_size) {
  running_ = true;
  running_full_size_ = full_size;
  running_request_ = request;
  running_generation_ = maps_generation_;
  running_stop_ = std::make_shared<std::atomic<bool>>(false);
  ++renders_started_;
  // The worker owns a reference to the maps and copies of everything else,
  // so it may outlive this object.
  const int step = full_size ? 1 : PreviewStep();
  watcher_->setFuture(QtConcurrent::run([maps = maps_, request, step, stop = running_stop_,
                                         hook = worker_hook_]() -> Result {
    Result result;
    try {
      if (hook) hook();
      if (step == 1) {
        result.image = Relight(*maps, request.lx, request.ly, request.lz, request.shading, stop.get());
      } else {
        // Enlarged by repeating pixels, so that the preview sits where the
        // full image will (the view keeps its zoom and pan).
        const QImage preview =
            Relight(Subsample(*maps, step), request.lx, request.ly, request.lz, request.shading, stop.get());
        if (!preview.isNull()) {
          result.image = preview.scaled(maps->normal.width(), maps->normal.height(), Qt::IgnoreAspectRatio,
                                        Qt::FastTransformation);
        }
      }
    } catch (const std::exception& error) {
      result.error = QString::fromUtf8(error.what());
    }
    return result;
  }));
}

void RelightRenderer::OnFinished() {
  const Result result = watcher_->result();
  running_ = false;
  const bool current = running_generation_ == maps_generation_;
  const bool full_size = running_full_size_;
  // Start the next render before painting this one, so that the worker is
  // busy while the UI thread paints: a newer light position first (its
  // preview), else this preview's full size.
  if (pending_) {
    const LightRequest next = *pending_;
    pending_.reset();
    Start(next, PreviewStep() == 1);
  } else if (current && !full_size && result.error.isEmpty()) {
    Start(running_request_, true);
  }
  if (!current) return;
  if (result.error.isEmpty() && result.image.isNull()) return;  // stopped for a newer position
  if (!result.error.isEmpty()) {
    emit Failed(result.error);
  } else {
    emit Rendered(result.image, full_size);
  }
}

bool RelightRenderer::WaitUntilIdle(int timeout_ms) {
  QDeadlineTimer deadline(timeout_ms);
  while (busy() && !deadline.hasExpired()) {
    QCoreApplication::processEvents(QEventLoop::AllEvents, 20);
    if (busy()) QThread::msleep(1);
  }
  return !busy();
}

}  // namespace scanbench
