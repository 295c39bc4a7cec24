#include "solver/photometric_solver.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <Eigen/Dense>
#include <Eigen/SVD>

namespace scanbench {
namespace {

std::invalid_argument OptionError(const std::string& field, const std::string& value, const std::string& rule) {
  return std::invalid_argument("PhotometricSolverOptions." + field + " = " + value + " " + rule);
}

std::invalid_argument InputError(const std::string& what) {
  return std::invalid_argument("photometric solver input: " + what);
}

std::string SizeText(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

void CheckInput(const PhotometricSolverInput& input) {
  if (input.light_field == nullptr) throw InputError("light_field is null");
  const LightField& field = *input.light_field;
  const int num_lights = field.num_lights();
  if (static_cast<int>(input.images.size()) != num_lights) {
    throw InputError(std::to_string(input.images.size()) + " images but the light field has " +
                     std::to_string(num_lights) + " lights; they must match");
  }
  if (!input.sample_valid.empty() && input.sample_valid.size() != input.images.size()) {
    throw InputError(std::to_string(input.sample_valid.size()) + " sample masks for " +
                     std::to_string(input.images.size()) + " images; give one per image or none");
  }
  for (size_t k = 0; k < input.images.size(); ++k) {
    const ImageF* image = input.images[k];
    if (image == nullptr) throw InputError("image " + std::to_string(k) + " is null");
    if (image->channels() != 3) {
      throw InputError("image " + std::to_string(k) + " has " + std::to_string(image->channels()) +
                       " channels; 3 (RGB) required");
    }
    if (!image->SameSize(field.width(), field.height())) {
      throw InputError("image " + std::to_string(k) + " is " + SizeText(image->width(), image->height()) +
                       " but the light field is " + SizeText(field.width(), field.height()));
    }
    if (!input.sample_valid.empty()) {
      const ImageU8* valid = input.sample_valid[k];
      if (valid == nullptr || valid->channels() != 1 || !valid->SameSize(*image)) {
        throw InputError("sample mask " + std::to_string(k) + " must be a 1-channel " +
                         SizeText(image->width(), image->height()) + " image");
      }
    }
  }
  if (input.region != nullptr &&
      (input.region->channels() != 1 || !input.region->SameSize(field.width(), field.height()))) {
    throw InputError("region must be a 1-channel " + SizeText(field.width(), field.height()) + " image");
  }
}

// Per-thread scratch space, so the pixel loop does not allocate.
struct Workspace {
  explicit Workspace(int num_lights)
      : light_dirs(3 * num_lights), rgb_intensities(3 * num_lights), lights(num_lights, 3),
        samples(num_lights, 4) {}
  std::vector<float> light_dirs;
  std::vector<float> rgb_intensities;
  Eigen::Matrix<double, Eigen::Dynamic, 3> lights;
  Eigen::Matrix<double, Eigen::Dynamic, 4> samples;  // luminance, R, G, B
  Eigen::JacobiSVD<Eigen::Matrix<double, Eigen::Dynamic, 3>> svd;
};

struct PixelResult {
  PixelStatus status = PixelStatus::kSolved;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d albedo = Eigen::Vector3d::Zero();
  int lights_used = 0;
  double condition_number = 0;
  double residual = 0;
};

PixelResult SolvePixel(const PhotometricSolverOptions& options, const PhotometricSolverInput& input, int x,
                       int y, Workspace& ws) {
  PixelResult result;
  const int num_lights = static_cast<int>(input.images.size());
  input.light_field->Evaluate(x, y, ws.light_dirs.data(), ws.rgb_intensities.data());
  const auto& w = options.luminance_weights;
  int m = 0;
  for (int k = 0; k < num_lights; ++k) {
    if (!input.sample_valid.empty() && (*input.sample_valid[k])(x, y) == 0) continue;
    const float* dir = &ws.light_dirs[3 * k];
    const float* intensity = &ws.rgb_intensities[3 * k];
    const float* sample = &(*input.images[k])(x, y, 0);
    bool finite = true;
    for (int c = 0; c < 3; ++c) {
      finite = finite && std::isfinite(dir[c]) && std::isfinite(intensity[c]);
    }
    if (!finite) {
      result.status = PixelStatus::kInvalidInput;
      return result;
    }
    if (!(std::isfinite(sample[0]) && std::isfinite(sample[1]) && std::isfinite(sample[2]))) continue;
    const double luminance_intensity = w[0] * intensity[0] + w[1] * intensity[1] + w[2] * intensity[2];
    if (!(luminance_intensity >= options.min_light_intensity) || intensity[0] <= 0 || intensity[1] <= 0 ||
        intensity[2] <= 0) {
      continue;
    }
    if (options.min_sample_value > 0 &&
        w[0] * sample[0] + w[1] * sample[1] + w[2] * sample[2] <= options.min_sample_value) {
      continue;  // in shadow
    }
    double luminance = 0;
    for (int c = 0; c < 3; ++c) {
      const double divided = sample[c] / double(intensity[c]);
      ws.samples(m, 1 + c) = divided;
      luminance += w[c] * divided;
    }
    ws.samples(m, 0) = luminance;
    ws.lights.row(m) << dir[0], dir[1], dir[2];
    ++m;
  }
  result.lights_used = m;
  if (m < std::max(3, options.min_lights)) {
    result.status = PixelStatus::kTooFewLights;
    return result;
  }

  ws.svd.compute(ws.lights.topRows(m), Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::Vector3d& singular = ws.svd.singularValues();
  result.condition_number = singular[2] > 0 ? singular[0] / singular[2] : std::numeric_limits<double>::infinity();
  if (!(result.condition_number <= options.max_condition_number)) {
    result.status = PixelStatus::kIllConditioned;
    result.condition_number = std::min(result.condition_number, double(std::numeric_limits<float>::max()));
    return result;
  }
  const int num_rhs = options.compute_albedo ? 4 : 1;
  const Eigen::Matrix<double, 3, Eigen::Dynamic> scaled_normals =
      ws.svd.solve(ws.samples.topLeftCorner(m, num_rhs));
  const Eigen::Vector3d scaled_normal = scaled_normals.col(0);
  const double length = scaled_normal.norm();
  if (!(length >= options.min_albedo) || !std::isfinite(length)) {
    result.status = PixelStatus::kNoSignal;
    return result;
  }
  result.normal = scaled_normal / length;
  if (!(result.normal.z() > 0)) {
    result.status = PixelStatus::kFacingAway;
    result.normal = Eigen::Vector3d::UnitZ();
    return result;
  }
  if (options.compute_albedo) {
    for (int c = 0; c < 3; ++c) result.albedo[c] = scaled_normals.col(1 + c).norm();
  }
  const Eigen::VectorXd residuals = ws.lights.topRows(m) * scaled_normal - ws.samples.col(0).head(m);
  result.residual = std::sqrt(residuals.squaredNorm() / m) / length;
  return result;
}

void StorePixel(const PixelResult& r, int x, int y, PhotometricSolution* s) {
  for (int c = 0; c < 3; ++c) {
    s->normal_in_table(x, y, c) = static_cast<float>(r.normal[c]);
    s->albedo(x, y, c) = static_cast<float>(r.albedo[c]);
  }
  s->status(x, y) = static_cast<uint8_t>(r.status);
  s->lights_used(x, y) = static_cast<uint8_t>(std::min(r.lights_used, 255));
  s->condition_number(x, y) = static_cast<float>(r.condition_number);
  s->residual(x, y) = static_cast<float>(r.residual);
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

void PhotometricSolverOptions::Check() const {
  double weight_sum = 0;
  for (int c = 0; c < 3; ++c) {
    if (!(luminance_weights[c] >= 0) || !std::isfinite(luminance_weights[c])) {
      throw OptionError("luminance_weights[" + std::to_string(c) + "]", std::to_string(luminance_weights[c]),
                        "must be finite and >= 0");
    }
    weight_sum += luminance_weights[c];
  }
  if (!(weight_sum > 0)) throw OptionError("luminance_weights", "all zero", "must sum to > 0");
  if (min_lights < 3 || min_lights > 1000) {
    throw OptionError("min_lights", std::to_string(min_lights), "must lie in [3, 1000]");
  }
  if (!(max_condition_number > 1)) {
    throw OptionError("max_condition_number", std::to_string(max_condition_number), "must be > 1");
  }
  if (!(min_sample_value >= 0) || !std::isfinite(min_sample_value)) {
    throw OptionError("min_sample_value", std::to_string(min_sample_value), "must be finite and >= 0");
  }
  if (!(min_light_intensity >= 0) || !std::isfinite(min_light_intensity)) {
    throw OptionError("min_light_intensity", std::to_string(min_light_intensity), "must be finite and >= 0");
  }
  if (!(min_albedo >= 0) || !std::isfinite(min_albedo)) {
    throw OptionError("min_albedo", std::to_string(min_albedo), "must be finite and >= 0");
  }
  if (num_threads < 0 || num_threads > 256) {
    throw OptionError("num_threads", std::to_string(num_threads), "must lie in [0, 256]");
  }
}

std::string PhotometricSolverSummary::BriefReport() const {
  std::ostringstream out;
  const char* how = termination == Termination::kSuccess     ? "success"
                    : termination == Termination::kCancelled ? "cancelled"
                                                             : "failure";
  out << "Photometric solve: " << how << ", " << num_solved() << " / " << num_pixels << " pixels solved from "
      << num_lights << " lights in " << seconds << " s on " << num_threads << " threads";
  for (int s = 1; s < kNumPixelStatuses; ++s) {
    if (pixels_by_status[s] > 0) {
      out << ", " << pixels_by_status[s] << " " << PixelStatusName(static_cast<PixelStatus>(s));
    }
  }
  if (!message.empty()) out << " (" << message << ")";
  return out.str();
}

PhotometricSolverSummary SolvePhotometricStereo(const PhotometricSolverOptions& options,
                                                const PhotometricSolverInput& input,
                                                PhotometricSolution* solution, const ProgressCallback& progress) {
  options.Check();
  CheckInput(input);
  if (solution == nullptr) throw InputError("solution is null");
  const auto start = std::chrono::steady_clock::now();
  const int width = input.light_field->width();
  const int height = input.light_field->height();
  const int num_lights = input.light_field->num_lights();

  solution->normal_in_table = ImageF(width, height, 3, 0.0f);
  solution->albedo = ImageF(width, height, 3, 0.0f);
  solution->status = ImageU8(width, height, 1, static_cast<uint8_t>(PixelStatus::kOutsideRegion));
  solution->lights_used = ImageU8(width, height, 1, 0);
  solution->condition_number = ImageF(width, height, 1, 0.0f);
  solution->residual = ImageF(width, height, 1, 0.0f);
  for (size_t i = 0; i < solution->normal_in_table.num_pixels(); ++i) solution->normal_in_table.data()[3 * i + 2] = 1;

  PhotometricSolverSummary summary;
  summary.num_lights = num_lights;
  summary.num_pixels = static_cast<size_t>(width) * height;
  const int hardware_threads = std::max(1u, std::thread::hardware_concurrency());
  summary.num_threads = std::clamp(options.num_threads == 0 ? hardware_threads : options.num_threads, 1,
                                   std::max(1, height));

  std::atomic<int> next_row{0};
  std::atomic<int> rows_done{0};
  std::atomic<bool> stop{false};
  auto worker = [&]() {
    Workspace ws(num_lights);
    for (int y = next_row++; y < height && !stop.load(std::memory_order_relaxed); y = next_row++) {
      for (int x = 0; x < width; ++x) {
        if (input.region != nullptr && (*input.region)(x, y) == 0) continue;
        StorePixel(SolvePixel(options, input, x, y, ws), x, y, solution);
      }
      ++rows_done;
    }
  };
  std::vector<std::thread> threads;
  for (int t = 1; t < summary.num_threads; ++t) threads.emplace_back(worker);
  if (progress) {
    // The caller's callback runs on the calling thread only.
    threads.emplace_back(worker);
    while (rows_done.load() < height && !stop.load()) {
      if (!progress(double(rows_done.load()) / height)) stop = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  } else {
    worker();
  }
  for (std::thread& thread : threads) thread.join();
  const bool cancelled = stop.load() && rows_done.load() < height;
  if (progress && !cancelled) progress(1.0);

  for (size_t i = 0; i < solution->status.num_pixels(); ++i) {
    ++summary.pixels_by_status[std::min<int>(solution->status.data()[i], kNumPixelStatuses - 1)];
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (cancelled) {
    summary.termination = PhotometricSolverSummary::Termination::kCancelled;
    summary.message = "cancelled after " + std::to_string(rows_done.load()) + " of " + std::to_string(height) + " rows";
  } else {
    summary.termination = PhotometricSolverSummary::Termination::kSuccess;
  }
  return summary;
}

}  // namespace scanbench
