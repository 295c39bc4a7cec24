#include "solver/photometric_solver.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <iterator>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "core/field_error.h"
#include "core/format.h"
#include "core/parallel_for.h"
#include "solver/coherent_lobe.h"
#include "solver/coherent_sheen.h"
#include "solver/cpu_dispatch.h"
#include "solver/normal_network.h"
#include "solver/photometric_methods.h"
#include "solver/pixel_kernels.h"
#include "solver/tile_lights.h"

namespace scanbench {
namespace {

constexpr const char* kOptions = "PhotometricSolverOptions";

std::invalid_argument InputError(const std::string& what) {
  return std::invalid_argument("photometric solver input: " + what);
}

std::string NumberText(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

void CheckSampleMasks(const std::vector<const ImageU8*>& masks, size_t num_images, int width, int height) {
  if (masks.empty()) return;
  if (masks.size() != num_images) {
    throw InputError(std::to_string(masks.size()) + " sample masks for " + std::to_string(num_images) +
                     " images; give one per image or none");
  }
  for (size_t k = 0; k < masks.size(); ++k) {
    const ImageU8* valid = masks[k];
    if (valid == nullptr || valid->channels() != 1 || !valid->SameSize(width, height)) {
      throw InputError("sample mask " + std::to_string(k) + " must be a 1-channel " + SizeText(width, height) +
                       " image");
    }
  }
}

void CheckLightsAndRegion(const LightField* field, size_t num_images, const ImageU8* region, const char* what) {
  if (field == nullptr) throw InputError("light_field is null");
  if (static_cast<int>(num_images) != field->num_lights()) {
    throw InputError(std::to_string(num_images) + " " + what + " but the light field has " +
                     std::to_string(field->num_lights()) + " lights; they must match");
  }
  if (region != nullptr && (region->channels() != 1 || !region->SameSize(field->width(), field->height()))) {
    throw InputError("region must be a 1-channel " + SizeText(field->width(), field->height()) + " image");
  }
}

void CheckImages(const std::vector<const ImageF*>& images, int channels, const LightField& field, const char* what) {
  for (size_t k = 0; k < images.size(); ++k) {
    const ImageF* image = images[k];
    if (image == nullptr) throw InputError(std::string(what) + " " + std::to_string(k) + " is null");
    if (image->channels() != channels) {
      throw InputError(std::string(what) + " " + std::to_string(k) + " has " + std::to_string(image->channels()) +
                       " channels; " + std::to_string(channels) + (channels == 3 ? " (RGB)" : "") + " required");
    }
    if (!image->SameSize(field.width(), field.height())) {
      throw InputError(std::string(what) + " " + std::to_string(k) + " is " +
                       SizeText(image->width(), image->height()) + " but the light field is " +
                       SizeText(field.width(), field.height()));
    }
  }
}

// A tile: [x0, x1) x [y0, y1).
struct Tile {
  int x0, y0, x1, y1;
};

// ---------------------------------------------------------------------------
// The tile loop every method shares, per thread: classify the tile's lights,
// then per row fill the lights, accumulate the samples and let the method's
// kernel (chosen once, at construction) solve the span.
class TileWorker {
 public:
  explicit TileWorker(const tiled::SolveJob& job)
      : job_(job),
        sharing_(PhotometricMethodRowOf(job.options->method).light_sharing),
        buffers_(job.num_lights, job.options->tile_size),
        lights_(job),
        kernel_(PhotometricMethodRowOf(job.options->method).make_kernel(job, job.options->tile_size)),
        writer_(job),
        accumulate_exact_(tiled::ChooseAccumulator(job.bayer, job.with_albedo, false)),
        accumulate_uniform_(tiled::ChooseAccumulator(job.bayer, job.with_albedo, true)) {}

  void SolveTile(const Tile& tile) {
    const tiled::TileLights lights = lights_.Classify(sharing_, tile.x0, tile.y0, tile.x1, tile.y1);
    const tiled::AccumulateSpanFn accumulate =
        lights == tiled::TileLights::kUniform ? accumulate_uniform_ : accumulate_exact_;
    tiled::Span span;
    span.lights = lights;
    span.x0 = tile.x0;
    span.count = tile.x1 - tile.x0;
    span.buffers = &buffers_;
    span.shared = &lights_.shared();
    for (int y = tile.y0; y < tile.y1; ++y) {
      const uint8_t* region = job_.region != nullptr ? job_.region->row(y) + tile.x0 : nullptr;
      // Rows of the tile with no pixel in the region cost nothing.
      if (region != nullptr && std::all_of(region, region + span.count, [](uint8_t v) { return v == 0; })) continue;
      lights_.FillRow(lights, tile.x0, tile.x1, y, &buffers_);
      accumulate(job_, lights_.shared(), tile.x0, span.count, y, &buffers_);
      span.y = y;
      span.region = region;
      kernel_->SolveSpan(span, &writer_);
    }
  }

  const std::array<size_t, kNumSolvePaths>& pixels_by_path() const { return writer_.pixels_by_path(); }

 private:
  const tiled::SolveJob& job_;
  const LightSharing sharing_;
  tiled::SpanBuffers buffers_;
  tiled::TileLightSampler lights_;
  std::unique_ptr<tiled::PixelKernel> kernel_;
  tiled::PixelWriter writer_;
  const tiled::AccumulateSpanFn accumulate_exact_, accumulate_uniform_;
};

// ---------------------------------------------------------------------------
// Bilinear demosaic of the per-raw-pixel albedo: a pixel's own channel is its
// own value; the others average the solved neighbours of that channel in the
// 3x3 window (0 when none is solved).
void DemosaicAlbedo(const ImageF& mosaic, const ImageU8& status, const std::array<int, 4>& cfa, ImageF* albedo) {
  const int width = mosaic.width(), height = mosaic.height();
  *albedo = ImageF(width, height, 3, 0.0f);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (status(x, y) != static_cast<uint8_t>(PixelStatus::kSolved)) continue;
      double sum[3] = {0, 0, 0};
      int count[3] = {0, 0, 0};
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (xx < 0 || yy < 0 || xx >= width || yy >= height) continue;
          if (status(xx, yy) != static_cast<uint8_t>(PixelStatus::kSolved)) continue;
          const int c = cfa[(yy & 1) * 2 + (xx & 1)];
          sum[c] += mosaic(xx, yy);
          ++count[c];
        }
      }
      const int own = cfa[(y & 1) * 2 + (x & 1)];
      for (int c = 0; c < 3; ++c) {
        (*albedo)(x, y, c) = c == own ? mosaic(x, y) : (count[c] > 0 ? static_cast<float>(sum[c] / count[c]) : 0.0f);
      }
    }
  }
}

// The largest difference (radians / relative) between the light field at the
// image's corners and centre: how far from uniform it is.
double LightFieldSpread(const LightField& field) {
  const int k3 = 3 * field.num_lights();
  std::vector<float> centre_dirs(k3), centre_int(k3), dirs(k3), intensities(k3);
  const int w = field.width() - 1, h = field.height() - 1;
  field.Evaluate(w / 2, h / 2, centre_dirs.data(), centre_int.data());
  double spread = 0;
  const int points[4][2] = {{0, 0}, {w, 0}, {0, h}, {w, h}};
  for (const auto& point : points) {
    field.Evaluate(point[0], point[1], dirs.data(), intensities.data());
    for (int j = 0; j < k3; ++j) {
      spread = std::max(spread, double(std::abs(dirs[j] - centre_dirs[j])));
      if (centre_int[j] > 0) spread = std::max(spread, std::abs(intensities[j] - centre_int[j]) / double(centre_int[j]));
    }
  }
  return spread;
}

// uniform_pinv shares one light matrix over the image: refuse a light field
// that varies by more than light_tolerance.
void CheckUniformPinvField(const PhotometricSolverOptions& options, const LightField& field) {
  const PhotometricMethodRow& method = PhotometricMethodRowOf(options.method);
  if (!NeedsUniformLightField(method) || field.IsUniform()) return;
  const double spread = LightFieldSpread(field);
  if (!(spread <= options.light_tolerance)) {
    throw InputError("method " + std::string(method.name) +
                     " needs a uniform light field (distant lights); this one varies by " +
                     NumberText(spread) + " over the image, more than light_tolerance = " +
                     NumberText(options.light_tolerance) + ": use adaptive or normal_equations");
  }
}

// `image` as a width x height x channels image with every value `value`:
// filled in place when it already has that shape (a solution solved into
// again, e.g. band after band: no fresh memory, whose first touch costs more
// than the fill), else made anew; empty when `wanted` is false.
template <typename T>
void Reset(bool wanted, int width, int height, int channels, T value, Image<T>* image) {
  if (wanted) {
    image->Reshape(width, height, channels, value);
  } else {
    *image = Image<T>();
  }
}

// Every output at its "not solved" value, sized to the light field; the job
// the workers get (Bayer: the per-raw-pixel albedo goes to `albedo_mosaic`).
// Fresh images are mostly the page faults of their first touch (0.7 GB at
// 16 MP): each is set up as one task on the solve's threads.
tiled::SolveJob PrepareSolution(const tiled::SolveJob& job, ImageF* albedo_mosaic) {
  const int width = job.field->width(), height = job.field->height();
  PhotometricSolution* solution = job.solution;
  const bool lobe = job.options->compute_specular && MethodRunsPass(*job.options, SolverPass::kPixelLobe);
  // adaptive's network runs only up to its light limit (pixel_kernels.cc): no map it would leave empty.
  const bool learned = job.with_confidence && MethodRunsPass(*job.options, SolverPass::kLearnedNormals) &&
                       (job.options->method == PhotometricSolverOptions::Method::kLearned ||
                        job.num_lights <= job.options->adaptive_learned_max_lights);
  // The largest first, so that the threads finish together.
  const std::function<void()> fills[] = {
      [&] {
        Reset(true, width, height, 3, 0.0f, &solution->normal_in_table);
        float* normal = solution->normal_in_table.data();
        for (size_t i = 0; i < solution->normal_in_table.num_pixels(); ++i) normal[3 * i + 2] = 1;
      },
      [&] { Reset(job.with_albedo, width, height, 3, 0.0f, &solution->albedo); },
      [&] { Reset(lobe, width, height, 2, 0.0f, &solution->specular); },
      [&] { Reset(job.with_confidence, width, height, 1, 0.0f, &solution->condition_number); },
      [&] { Reset(job.with_confidence, width, height, 1, 0.0f, &solution->residual); },
      [&] { Reset(learned, width, height, 1, 0.0f, &solution->learned_error_deg); },
      [&] { Reset(job.bayer, width, height, 1, 0.0f, albedo_mosaic); },
      [&] {
        Reset(true, width, height, 1, static_cast<uint8_t>(PixelStatus::kOutsideRegion), &solution->status);
      },
      [&] { Reset(true, width, height, 1, uint8_t{0}, &solution->lights_used); },
      [&] { Reset(true, width, height, 1, static_cast<uint8_t>(SolvePath::kNone), &solution->solve_path); },
      [&] {
        Reset(lobe, width, height, 1, static_cast<uint8_t>(SpecularStatus::kNotSolved), &solution->specular_status);
      },
  };
  const int num_fills = static_cast<int>(std::size(fills));
  ParallelFor(num_fills, ResolveThreadCount(job.options->num_threads), 1, [&](int first, int last, int) {
    for (int f = first; f < last; ++f) fills[f]();
  });
  tiled::SolveJob worker_job = job;
  if (job.bayer) {
    // Raw pixels carry one channel each: only the luminance solve runs per
    // pixel, its albedo kept per raw pixel (and dropped unless asked for).
    worker_job.albedo_mosaic = albedo_mosaic;
    worker_job.with_albedo = false;
  }
  return worker_job;
}

// The tiles of the image that meet the region, row-major; `num_tiles` counts
// them all.
std::vector<Tile> PlanTiles(int width, int height, int tile, const ImageU8* region, size_t* num_tiles) {
  // Tiles over the region's bounding box; tiles without a region pixel are skipped.
  int box_x0 = 0, box_y0 = 0, box_x1 = width, box_y1 = height;
  if (region != nullptr) {
    box_x0 = width, box_y0 = height, box_x1 = 0, box_y1 = 0;
    for (int y = 0; y < height; ++y) {
      const uint8_t* row = region->row(y);
      for (int x = 0; x < width; ++x) {
        if (row[x] == 0) continue;
        box_x0 = std::min(box_x0, x), box_x1 = std::max(box_x1, x + 1);
        box_y0 = std::min(box_y0, y), box_y1 = std::max(box_y1, y + 1);
      }
    }
  }
  const int tiles_x = (width + tile - 1) / tile, tiles_y = (height + tile - 1) / tile;
  *num_tiles = static_cast<size_t>(tiles_x) * tiles_y;
  std::vector<Tile> tiles;
  for (int ty = 0; ty < tiles_y; ++ty) {
    for (int tx = 0; tx < tiles_x; ++tx) {
      const Tile t{tx * tile, ty * tile, std::min(width, (tx + 1) * tile), std::min(height, (ty + 1) * tile)};
      const int x0 = std::max(t.x0, box_x0), x1 = std::min(t.x1, box_x1);
      const int y0 = std::max(t.y0, box_y0), y1 = std::min(t.y1, box_y1);
      bool any = x0 < x1 && y0 < y1;
      if (any && region != nullptr) {
        any = false;
        for (int y = y0; y < y1 && !any; ++y) {
          const uint8_t* row = region->row(y);
          any = std::any_of(row + x0, row + x1, [](uint8_t v) { return v != 0; });
        }
      }
      if (any) tiles.push_back(t);
    }
  }
  return tiles;
}

// Solves every tile on `num_threads` threads (the caller included), one
// TileWorker per thread; returns the tiles done. Each pixel's result depends
// on its tile only, so it is the same for any thread count.
int SolveTiles(const tiled::SolveJob& job, const std::vector<Tile>& tiles, int num_threads,
               const ProgressCallback& progress, std::array<size_t, kNumSolvePaths>* pixels_by_path) {
  const int num_tiles = static_cast<int>(tiles.size());
  std::vector<std::unique_ptr<TileWorker>> workers(num_threads);
  std::atomic<int> tiles_done{0};
  ParallelFor(
      num_tiles, num_threads, 1,
      [&](int first, int last, int worker) {
        // Built on the thread that uses it, so that its scratch is local there.
        if (!workers[worker]) workers[worker] = std::make_unique<TileWorker>(job);
        for (int t = first; t < last; ++t) {
          workers[worker]->SolveTile(tiles[t]);
          ++tiles_done;
        }
      },
      progress ? std::function<bool(int)>([&](int done) { return progress(double(done) / num_tiles); })
               : std::function<bool(int)>());
  for (const auto& worker : workers) {
    if (!worker) continue;
    for (int p = 0; p < kNumSolvePaths; ++p) (*pixels_by_path)[p] += worker->pixels_by_path()[p];
  }
  return tiles_done.load();
}

PhotometricSolverSummary RunSolve(const PhotometricSolverOptions& options, const tiled::SolveJob& job,
                                  const ProgressCallback& progress, const BayerSolverInput* lobe_mosaics = nullptr,
                                  PhotometricSolution* lobe_bayer = nullptr) {
  const auto start = std::chrono::steady_clock::now();
  const int width = job.field->width(), height = job.field->height();
  CheckUniformPinvField(options, *job.field);
  ImageF albedo_mosaic;
  tiled::SolveJob worker_job = PrepareSolution(job, &albedo_mosaic);
  worker_job.kernels = &tiled::KernelsOf(job);

  PhotometricSolverSummary summary;
  summary.method = PhotometricMethodName(options.method);
  summary.bayer_domain = job.bayer;
  summary.num_lights = job.num_lights;
  summary.kernel_isa = KernelIsaName(worker_job.kernels->isa);
  summary.num_pixels = static_cast<size_t>(width) * height;
  const std::vector<Tile> tiles = PlanTiles(width, height, options.tile_size, job.region, &summary.num_tiles);
  summary.tiles_skipped = summary.num_tiles - tiles.size();
  const int num_tiles = static_cast<int>(tiles.size());
  summary.num_threads = std::clamp(ResolveThreadCount(options.num_threads), 1, std::max(1, num_tiles));

  // Asked once before any work, so that a stop already requested is honoured
  // however fast the solve would be.
  const bool stopped_before = progress && !progress(0.0);
  // The one pass after the per-pixel ones: a lobe shared by neighbouring
  // pixels (RGB input only; it reads the solved specular maps).
  const bool coherent =
      MethodRunsPass(options, SolverPass::kCoherentLobe) && !job.bayer && !job.solution->specular.empty();
  // Then a velvet sheen shared by neighbouring least-squares pixels (RGB and
  // Bayer input; after the lobe, whose pixels it leaves alone).
  const CoherentSheenOptions sheen_options = [&] {
    CoherentSheenOptions o;
    o.num_threads = summary.num_threads;
    return o;
  }();
  const bool coherent_sheen =
      MethodRunsPass(options, SolverPass::kCoherentSheen) && job.num_lights <= sheen_options.max_lights;
  const double tiles_share = coherent && coherent_sheen ? 0.7 : coherent ? 0.8 : coherent_sheen ? 0.85 : 1.0;
  const double lobe_end = coherent ? (coherent_sheen ? 0.9 : 1.0) : tiles_share;
  const int tiles_done = stopped_before ? 0
                                        : SolveTiles(worker_job, tiles, summary.num_threads,
                                                     SubRange(progress, 0.0, tiles_share), &summary.pixels_by_path);
  bool cancelled = tiles_done < num_tiles;
  if (!cancelled && coherent) {
    CoherentLobeOptions coherent_options;
    coherent_options.num_threads = summary.num_threads;
    PhotometricSolverInput input;
    input.images = *job.images;
    input.sample_valid = *job.sample_valid;
    input.light_field = job.field;
    input.region = job.region;
    input.lobe_mosaics = lobe_mosaics;
    input.lobe_bayer = lobe_bayer;
    const CoherentLobeSummary refined = RefineCoherentLobe(coherent_options, options, input, job.solution,
                                                           SubRange(progress, tiles_share, lobe_end));
    summary.pixels_coherent_lobe = refined.pixels_refined;
    cancelled = refined.IsCancelled();
  }
  job.solution->coherent_sheen = coherent_sheen ? ImageU8(width, height, 1, uint8_t{0}) : ImageU8();
  if (!cancelled && coherent_sheen) {
    const CoherentSheenSummary sheen =
        tiled::RefineCoherentSheenOfJob(sheen_options, worker_job, SubRange(progress, lobe_end, 1.0));
    summary.pixels_coherent_sheen = sheen.pixels_refined;
    cancelled = sheen.IsCancelled();
  }
  if (!cancelled && job.bayer && job.with_albedo) {
    DemosaicAlbedo(albedo_mosaic, job.solution->status, job.cfa_channels, &job.solution->albedo);
  }
  if (progress && !cancelled) progress(1.0);

  for (size_t i = 0; i < job.solution->status.num_pixels(); ++i) {
    ++summary.pixels_by_status[std::min<int>(job.solution->status.data()[i], kNumPixelStatuses - 1)];
  }
  const ImageU8& specular_status = job.solution->specular_status;
  for (size_t i = 0; i < specular_status.num_pixels(); ++i) {
    ++summary.pixels_by_specular[std::min<int>(specular_status.data()[i], kNumSpecularStatuses - 1)];
  }
  summary.pixels_by_path[0] = summary.num_pixels;
  for (int p = 1; p < kNumSolvePaths; ++p) summary.pixels_by_path[0] -= summary.pixels_by_path[p];
  if (summary.pixels_by_path[static_cast<int>(SolvePath::kLearned)] > 0) {
    summary.learned_model = NormalNetwork::Embedded().source();
    summary.learned_model_sha256 = NormalNetwork::Embedded().sha256();
  }
  summary.seconds = SecondsSince(start);
  if (cancelled) {
    summary.SetCancelled(tiles_done < num_tiles ? "cancelled after " + std::to_string(tiles_done) + " of " +
                                                      std::to_string(num_tiles) + " tiles"
                                                : std::string("cancelled in the coherent-lobe or coherent-sheen pass"));
  } else {
    summary.termination = Termination::kSuccess;
  }
  return summary;
}

}  // namespace

const char* PixelStatusName(PixelStatus status) {
  switch (status) {
    case PixelStatus::kSolved: return "solved";
    case PixelStatus::kOutsideRegion: return "outside_region";
    case PixelStatus::kTooFewLights: return "too_few_lights";
    case PixelStatus::kIllConditioned: return "ill_conditioned";
    case PixelStatus::kNoSignal: return "no_signal";
    case PixelStatus::kFacingAway: return "facing_away";
    case PixelStatus::kInvalidInput: return "invalid_input";
  }
  return "unknown";
}

const char* SpecularStatusName(SpecularStatus status) {
  switch (status) {
    case SpecularStatus::kEstimated: return "estimated";
    case SpecularStatus::kNotSolved: return "not_solved";
    case SpecularStatus::kUnsupported: return "unsupported";
  }
  return "unknown";
}

const char* SolvePathName(SolvePath path) {
  switch (path) {
    case SolvePath::kNone: return "none";
    case SolvePath::kSharedLights: return "shared_lights";
    case SolvePath::kInterpolatedLights: return "interpolated_lights";
    case SolvePath::kExactLights: return "exact_lights";
    case SolvePath::kRobust: return "robust";
    case SolvePath::kLearned: return "learned";
  }
  return "unknown";
}

void PhotometricSolverOptions::Check() const {
  PhotometricMethodRowOf(method);  // throws for a method without a row
  double weight_sum = 0;
  for (int c = 0; c < 3; ++c) {
    SCANBENCH_REQUIRE_FINITE_GE(kOptions, "luminance_weights[" + std::to_string(c) + "]", luminance_weights[c], 0);
    weight_sum += luminance_weights[c];
  }
  if (!(weight_sum > 0)) throw FieldError(kOptions, "luminance_weights", "all zero", "must sum to > 0");
  SCANBENCH_REQUIRE_GE_LE(kOptions, "min_lights", min_lights, 3, 1000);
  SCANBENCH_REQUIRE_GT(kOptions, "max_condition_number", max_condition_number, 1);
  SCANBENCH_REQUIRE_FINITE_GE(kOptions, "min_sample_value", min_sample_value, 0);
  SCANBENCH_REQUIRE_FINITE_GE(kOptions, "min_light_intensity", min_light_intensity, 0);
  SCANBENCH_REQUIRE_FINITE_GE(kOptions, "min_albedo", min_albedo, 0);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "num_threads", num_threads, 0, 256);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "tile_size", tile_size, 8, 4096);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "light_tolerance", light_tolerance, 0, 0.1);
  SCANBENCH_REQUIRE_FINITE_GE(kOptions, "robust_loss_width", robust_loss_width, 0);
  SCANBENCH_REQUIRE_FINITE_GT(kOptions, "robust_min_scale", robust_min_scale, 0);
  SCANBENCH_REQUIRE_GE_LE(kOptions, "robust_max_iterations", robust_max_iterations, 1, 10000);
  SCANBENCH_REQUIRE_GE_LT(kOptions, "robust_dark_fraction", robust_dark_fraction, 0, 1);
  SCANBENCH_REQUIRE_GE(kOptions, "adaptive_robust_residual", adaptive_robust_residual, 0);
  SCANBENCH_REQUIRE_GE(kOptions, "adaptive_learned_max_lights", adaptive_learned_max_lights, 0);
}

std::string PhotometricSolverSummary::BriefReport() const {
  std::ostringstream out;
  const char* how = TerminationName(termination);
  out << "Photometric solve (" << (method.empty() ? "?" : method) << (bayer_domain ? ", Bayer domain" : "")
      << "): " << how << ", " << num_solved() << " / " << num_pixels << " pixels solved from " << num_lights
      << " lights in " << Significant(seconds) << " s on " << num_threads << " threads ("
      << (kernel_isa.empty() ? "?" : kernel_isa) << " kernels)";
  for (int s = 1; s < kNumPixelStatuses; ++s) {
    if (pixels_by_status[s] > 0) {
      out << ", " << pixels_by_status[s] << " " << PixelStatusName(static_cast<PixelStatus>(s));
    }
  }
  out << "; paths:";
  for (int p = 1; p < kNumSolvePaths; ++p) {
    if (pixels_by_path[p] > 0) out << " " << SolvePathName(static_cast<SolvePath>(p)) << " " << pixels_by_path[p];
  }
  if (pixels_by_specular[0] + pixels_by_specular[2] > 0) {
    out << "; specular lobe estimated at " << pixels_by_specular[0] << ", unsupported at " << pixels_by_specular[2];
  }
  if (pixels_coherent_lobe > 0) out << "; " << pixels_coherent_lobe << " refined by a shared anisotropic lobe";
  if (pixels_coherent_sheen > 0) out << "; " << pixels_coherent_sheen << " re-solved under a shared velvet sheen";
  if (pixels_bayer_blended > 0) {
    out << "; " << pixels_bayer_blended << " blended with the Bayer-domain normal (mean weight "
        << Fixed(bayer_blend_mean_weight, 2) << "; Bayer-domain solve on " << pixels_bayer_solved << " px)";
  }
  if (pixels_bayer_lobe > 0) out << "; " << pixels_bayer_lobe << " shared-lobe normals re-solved from the raw samples";
  if (!learned_model.empty()) out << "; network " << learned_model << " (sha256 " << learned_model_sha256.substr(0, 12) << ")";
  if (tiles_skipped > 0) out << "; " << tiles_skipped << " of " << num_tiles << " tiles outside the region";
  if (!message.empty()) out << " (" << message << ")";
  return out.str();
}

PhotometricSolverSummary SolvePhotometricStereo(const PhotometricSolverOptions& options,
                                                const PhotometricSolverInput& input,
                                                PhotometricSolution* solution, const ProgressCallback& progress) {
  options.Check();
  CheckLightsAndRegion(input.light_field, input.images.size(), input.region, "images");
  CheckImages(input.images, 3, *input.light_field, "image");
  CheckSampleMasks(input.sample_valid, input.images.size(), input.light_field->width(), input.light_field->height());
  if (solution == nullptr) throw InputError("solution is null");
  const tiled::SolveJob job =
      tiled::RgbSolveJob(options, input, solution, options.compute_albedo, options.compute_confidence);
  if ((input.lobe_mosaics == nullptr) != (input.lobe_bayer == nullptr)) {
    throw InputError("lobe_mosaics and lobe_bayer must be given together");
  }
  return RunSolve(options, job, progress, input.lobe_mosaics, input.lobe_bayer);
}

PhotometricSolverSummary SolvePhotometricStereoBayer(const PhotometricSolverOptions& options,
                                                     const BayerSolverInput& input, PhotometricSolution* solution,
                                                     const ProgressCallback& progress) {
  options.Check();
  CheckLightsAndRegion(input.light_field, input.mosaics.size(), input.region, "mosaics");
  CheckImages(input.mosaics, 1, *input.light_field, "mosaic");
  CheckSampleMasks(input.sample_valid, input.mosaics.size(), input.light_field->width(), input.light_field->height());
  for (int p = 0; p < 4; ++p) {
    if (input.cfa_channels[p] < 0 || input.cfa_channels[p] > 2) {
      throw InputError("cfa_channels[" + std::to_string(p) + "] = " + std::to_string(input.cfa_channels[p]) +
                       " must be 0 (R), 1 (G) or 2 (B)");
    }
  }
  if (solution == nullptr) throw InputError("solution is null");
  tiled::SolveJob job;
  job.options = &options;
  job.field = input.light_field;
  if (input.sheen_pixels != nullptr && !input.sheen_pixels->SameSize(input.light_field->width(), input.light_field->height())) {
    throw InputError("sheen_pixels must be a 1-channel image of the light field's size");
  }
  job.sheen_pixels = input.sheen_pixels;
  job.images = &input.mosaics;
  job.sample_valid = &input.sample_valid;
  job.region = input.region;
  job.bayer = true;
  job.cfa_channels = input.cfa_channels;
  job.num_lights = input.light_field->num_lights();
  job.with_albedo = options.compute_albedo;
  job.with_confidence = options.compute_confidence;
  job.solution = solution;
  return RunSolve(options, job, progress);
}

}  // namespace scanbench
