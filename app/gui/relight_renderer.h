// Computes the relight preview (Relight, app/gui/result_images.h) on a worker
// thread, the latest request winning: while one render runs, newer requests
// replace each other and only the last one is rendered next. Dragging the
// light over a full-resolution result (4928x3264) therefore never stalls the
// window, and the image shown at the end is always that of the last light
// position. A large map is first rendered subsampled (shown enlarged to the
// map's size, so zoom and pan stay) and refined to full size once no newer
// light position waits: a drag shows previews, the resting light the full
// image. The UI thread only receives finished images.
#pragma once

#include <QFutureWatcher>
#include <QImage>
#include <QObject>
#include <QString>

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>

#include "app/gui/relight_shading.h"
#include "app/gui/result_images.h"

namespace scanbench {

struct RelightRendererOptions {
  // Maps with more pixels are first rendered every n-th pixel, n the
  // smallest that leaves at most this many (~ a screen); 0 = full size only. >= 0
  int preview_max_pixels = 1 << 20;

  // Throws std::invalid_argument (FieldError) naming the field, its value and the rule.
  void Check() const;
};

class RelightRenderer : public QObject {
  Q_OBJECT

 public:
  // Throws std::invalid_argument if `options` fail Check().
  explicit RelightRenderer(const RelightRendererOptions& options = {}, QObject* parent = nullptr);
  // A render still running is stopped at its next row and dropped: it owns
  // what it reads.
  ~RelightRenderer() override;

  // The maps to shade; null for none. A render of earlier maps that is still
  // running is stopped and dropped, and a waiting request too.
  void SetMaps(std::shared_ptr<const RelightMaps> maps);
  const std::shared_ptr<const RelightMaps>& maps() const { return maps_; }

  // Renders the maps for a distant light towards (lx, ly, lz) (unit, tangent
  // frame) now, or after the running render, replacing a request that waits
  // (a running full-size refinement of an older position is stopped).
  // Throws std::invalid_argument (FieldError) if `shading` fails Check(),
  // before anything is queued. Ignored without maps.
  void Request(double lx, double ly, double lz, const RelightShading& shading);

  // A render runs (until its Rendered or Failed was sent) or a request waits.
  bool busy() const { return running_ || pending_.has_value(); }
  // Renders started so far, previews and full size (requests replaced while
  // waiting never start).
  int renders_started() const { return renders_started_; }
  // Processes events until nothing runs or waits (tests, the screenshot
  // tour); true if idle.
  bool WaitUntilIdle(int timeout_ms);

  // Called on the worker thread before each render: a test can hold a
  // render there while it checks that the UI thread goes on.
  void SetWorkerHook(std::function<void()> hook) { worker_hook_ = std::move(hook); }

 signals:
  // The image of the request the finished render was started for, at the
  // maps' size; full_size false for a preview (subsampled, enlarged).
  void Rendered(const QImage& image, bool full_size);
  // A render failed (e.g. out of memory); the message says why.
  void Failed(const QString& message);

 private:
  struct LightRequest {
    double lx, ly, lz;
    RelightShading shading;
  };
  struct Result {
    QImage image;
    QString error;
  };
  // Every n-th pixel for the preview of the current maps; 1: no preview.
  int PreviewStep() const;
  void Start(const LightRequest& request, bool full_size);
  void OnFinished();

  RelightRendererOptions options_;
  std::shared_ptr<const RelightMaps> maps_;
  uint64_t maps_generation_ = 0;    // counts SetMaps calls: a render of older maps is dropped
  uint64_t running_generation_ = 0;
  bool running_ = false;
  bool running_full_size_ = false;
  std::shared_ptr<std::atomic<bool>> running_stop_;  // shared with the running render
  LightRequest running_request_{};
  std::optional<LightRequest> pending_;
  int renders_started_ = 0;
  std::function<void()> worker_hook_;
  QFutureWatcher<Result>* watcher_;
};

}  // namespace scanbench
