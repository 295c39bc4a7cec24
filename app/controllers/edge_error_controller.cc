#include "app/controllers/edge_error_controller.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numbers>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/field_error.h"
#include "core/format.h"
#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/io/raw_decoder.h"
#include "app/session/calibration_set.h"
#include "app/session/session.h"
#include "calibration/rig_light_field.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

nlohmann::json StatisticsJson(const ErrorStatistics& s) {
  return {{"pixels", s.num_pixels}, {"mean", s.mean}, {"median", s.median}, {"p95", s.percentile_95}, {"max", s.max}};
}

// Block means of the signed normal error (x, y), in degrees of tilt; blocks
// without a solved pixel hold NaN-free zeros and count 0.
struct TiltMap {
  int blocks_x = 0, blocks_y = 0, block = 1;
  std::vector<Eigen::Vector2d> tilt_deg;
  std::vector<int> count;
};

TiltMap ComputeTilt(const PhotometricSolution& solution, const ImageF& truth, int block) {
  TiltMap map;
  map.block = block;
  map.blocks_x = (truth.width() + block - 1) / block;
  map.blocks_y = (truth.height() + block - 1) / block;
  map.tilt_deg.assign(static_cast<size_t>(map.blocks_x) * map.blocks_y, Eigen::Vector2d::Zero());
  map.count.assign(map.tilt_deg.size(), 0);
  for (int y = 0; y < truth.height(); ++y) {
    for (int x = 0; x < truth.width(); ++x) {
      if (solution.status(x, y) != static_cast<uint8_t>(PixelStatus::kSolved)) continue;
      const size_t b = static_cast<size_t>(y / block) * map.blocks_x + x / block;
      map.tilt_deg[b] += Eigen::Vector2d(solution.normal_in_table(x, y, 0) - truth(x, y, 0),
                                         solution.normal_in_table(x, y, 1) - truth(x, y, 1));
      ++map.count[b];
    }
  }
  for (size_t b = 0; b < map.tilt_deg.size(); ++b) {
    if (map.count[b] > 0) map.tilt_deg[b] *= kRadToDeg / map.count[b];  // small angles: |dn| ~ radians
  }
  return map;
}

// The tilt map as colour, bilinear between block centres, at `width` pixels.
ImageU8 TiltImage(const TiltMap& map, int image_width, int image_height, int out_width, double scale_deg) {
  const int out_height = std::max(1, static_cast<int>(std::lround(double(out_width) * image_height / image_width)));
  ImageU8 image(out_width, out_height, 3);
  auto at = [&](int i, int j) {
    i = std::clamp(i, 0, map.blocks_x - 1);
    j = std::clamp(j, 0, map.blocks_y - 1);
    return map.tilt_deg[static_cast<size_t>(j) * map.blocks_x + i];
  };
  for (int y = 0; y < out_height; ++y) {
    for (int x = 0; x < out_width; ++x) {
      const double px = (x + 0.5) * image_width / out_width, py = (y + 0.5) * image_height / out_height;
      const double u = px / map.block - 0.5, v = py / map.block - 0.5;
      const int i = static_cast<int>(std::floor(u)), j = static_cast<int>(std::floor(v));
      const double fu = u - i, fv = v - j;
      const Eigen::Vector2d t = (1 - fv) * ((1 - fu) * at(i, j) + fu * at(i + 1, j)) +
                                fv * ((1 - fu) * at(i, j + 1) + fu * at(i + 1, j + 1));
      const double r = 0.5 + 0.5 * t.x() / scale_deg, g = 0.5 + 0.5 * t.y() / scale_deg;
      image(x, y, 0) = static_cast<uint8_t>(std::lround(255 * std::clamp(r, 0.0, 1.0)));
      image(x, y, 1) = static_cast<uint8_t>(std::lround(255 * std::clamp(g, 0.0, 1.0)));
      image(x, y, 2) = static_cast<uint8_t>(std::lround(255 * std::clamp(1.0 - 0.5 * (r + g), 0.0, 1.0)));
    }
  }
  return image;
}

// The mean block tilt in the centre box and the border band, and the largest,
// over blocks that are mostly solved.
struct TiltFigures {
  double centre_deg = 0, border_deg = 0, max_deg = 0;
};

TiltFigures MeasureTilt(const TiltMap& tilt, int width, int height, double centre_fraction, double border_fraction) {
  const int block = tilt.block;
  TiltFigures figures;
  double centre_sum = 0, border_sum = 0;
  int centre_count = 0, border_count = 0;
  for (int j = 0; j < tilt.blocks_y; ++j) {
    for (int i = 0; i < tilt.blocks_x; ++i) {
      const size_t b = static_cast<size_t>(j) * tilt.blocks_x + i;
      if (tilt.count[b] < block * block / 4) continue;  // mostly unsolved: not a fair mean
      const double magnitude = tilt.tilt_deg[b].norm();
      const double cx = ((i + 0.5) * block) / width, cy = ((j + 0.5) * block) / height;
      const bool centre = std::abs(cx - 0.5) <= 0.5 * centre_fraction && std::abs(cy - 0.5) <= 0.5 * centre_fraction;
      const bool border =
          cx < border_fraction || cx > 1 - border_fraction || cy < border_fraction || cy > 1 - border_fraction;
      if (centre) {
        centre_sum += magnitude;
        ++centre_count;
      }
      if (border) {
        border_sum += magnitude;
        ++border_count;
      }
      figures.max_deg = std::max(figures.max_deg, magnitude);
    }
  }
  figures.centre_deg = centre_count > 0 ? centre_sum / centre_count : 0.0;
  figures.border_deg = border_count > 0 ? border_sum / border_count : 0.0;
  return figures;
}

// `left` | `right` with a white gap.
ImageU8 SideBySide(const ImageU8& left, const ImageU8& right) {
  constexpr int kGap = 8;
  ImageU8 both(left.width() + kGap + right.width(), std::max(left.height(), right.height()), 3, 255);
  for (int y = 0; y < left.height(); ++y) {
    for (int x = 0; x < left.width(); ++x) {
      for (int c = 0; c < 3; ++c) {
        both(x, y, c) = left(x, y, c);
        both(left.width() + kGap + x, y, c) = right(x, y, c);
      }
    }
  }
  return both;
}

nlohmann::json CaseJson(const EdgeErrorCase& result) {
  return {{"description", result.description},
          {"angular_error_deg", StatisticsJson(result.error_deg)},
          {"sample_angular_error_deg", StatisticsJson(result.sample_error_deg)},
          {"centre_tilt_deg", result.centre_tilt_deg},
          {"border_tilt_deg", result.border_tilt_deg},
          {"max_tilt_deg", result.max_tilt_deg},
          {"image", result.image}};
}

// One way of treating the lights, solved and measured alike.
struct LightCase {
  std::string name, description;
  std::unique_ptr<LightField> field;
};

// distant_uniform (from the rig description, then from the calibrated LEDs),
// the uncalibrated near-field rig and the calibration; the calibrated light
// field moves out of `calibrated`.
std::vector<LightCase> MakeLightCases(const Session& session, const CalibrationSet& set,
                                      CalibratedLighting* calibrated) {
  const int width = session.camera.width, height = session.camera.height;
  const std::vector<LedDescription> fitted = set.lights->summary.ModelLeds();
  std::vector<LightCase> cases;
  cases.push_back({"distant_uniform",
                   "lights distant and uniform: each LED's direction and intensity at the table origin from the "
                   "session's rig description, the same at every pixel",
                   MakeDistantUniformLightField(session.rig.leds, width, height)});
  cases.push_back({"distant_uniform_fitted",
                   "lights distant and uniform, from the calibrated LED positions and intensities: the "
                   "far-field assumption alone",
                   MakeDistantUniformLightField(fitted, width, height)});
  cases.push_back({"rig_description",
                   "near-field LEDs of the session's (uncalibrated) rig description on its nominal camera",
                   MakeRigLightField(session.rig)});
  cases.push_back({"calibrated", calibrated->light_model, std::move(calibrated->light_field)});
  return cases;
}

}  // namespace

void EdgeErrorOptions::Check() const {
  solver.Check();
  develop.Check();
  calibration.Check();
  if (calibration_dir.empty()) throw std::invalid_argument("EdgeErrorOptions.calibration_dir must be given");
  if (output_dir.empty()) throw std::invalid_argument("EdgeErrorOptions.output_dir must be given");
  const std::string where = "EdgeErrorOptions";
  SCANBENCH_REQUIRE_GE_LE(where, "block_px", block_px, 0, 4096);
  SCANBENCH_REQUIRE_GT_LT(where, "border_fraction", border_fraction, 0, 0.5);
  SCANBENCH_REQUIRE_GT_LT(where, "centre_fraction", centre_fraction, 0, 1);
  SCANBENCH_REQUIRE_GT(where, "colour_scale_deg", colour_scale_deg, 0);
}

const EdgeErrorCase* EdgeErrorSummary::Find(const std::string& name) const {
  for (const EdgeErrorCase& c : cases) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

std::string EdgeErrorSummary::FullReport() const {
  std::ostringstream out;
  out << "scanbench edge error (low-frequency normal tilt, blocks of " << block_px << " px)\n";
  for (const EdgeErrorCase& c : cases) {
    out << "  " << std::left << std::setw(24) << c.name << " tilt: centre " << Fixed(c.centre_tilt_deg, 3)
        << " deg, border " << Fixed(c.border_tilt_deg, 3) << " deg, max " << Fixed(c.max_tilt_deg, 3)
        << " deg; angular error mean " << Fixed(c.error_deg.mean, 3) << " deg (sample " << Fixed(c.sample_error_deg.mean, 3)
        << ")\n    " << c.description << "\n";
  }
  out << "  images in " << output_dir.string() << " (" << comparison_image << ": distant-uniform | calibrated)\n";
  return out.str();
}

struct EdgeErrorController::Inputs {
  Session session;
  std::string session_name;
  ImageF truth;         // normals in the table frame
  ImageU8 sample_mask;  // as stored: > 127 on the sample
  std::vector<ImageF> images;
  std::vector<ImageU8> valid;
};

EdgeErrorController::EdgeErrorController(fs::path session_dir, EdgeErrorOptions options)
    : session_dir_(std::move(session_dir)), options_(std::move(options)) {}

void EdgeErrorController::Run() {
  options_.Check();
  summary_ = EdgeErrorSummary();
  Inputs inputs = LoadSessionWithTruth();
  DevelopFrames(&inputs);
  const CalibrationSet set = LoadCalibrationSet(options_.calibration_dir);
  const std::string set_name = (options_.calibration_dir / kCalibrationManifestName).string();
  CalibratedLighting calibrated =
      MakeCalibratedLighting(set, set_name, inputs.session, inputs.session_name, options_.calibration);
  const std::vector<LightCase> cases = MakeLightCases(inputs.session, set, &calibrated);

  const int width = inputs.session.camera.width;
  summary_.block_px = options_.block_px > 0 ? options_.block_px : std::max(4, width / 40);
  summary_.output_dir = options_.output_dir;
  fs::create_directories(options_.output_dir);
  nlohmann::json report;
  report["schema"] = "scanbench.edge_error/1";
  report["session"] = fs::absolute(session_dir_).string();
  report["calibration"] = fs::absolute(options_.calibration_dir).string();
  report["block_px"] = summary_.block_px;
  report["border_fraction"] = options_.border_fraction;
  report["centre_fraction"] = options_.centre_fraction;
  std::vector<ImageU8> case_images;
  for (const LightCase& light_case : cases) {
    case_images.push_back(MeasureCase(inputs, light_case.name, light_case.description, *light_case.field));
    report["cases"][light_case.name] = CaseJson(summary_.cases.back());
  }

  summary_.comparison_image = "edge_error.png";
  WritePng(options_.output_dir / summary_.comparison_image, SideBySide(case_images.front(), case_images.back()),
           OverwritePolicy::kReplace);
  report["comparison_image"] = summary_.comparison_image;
  report["colour_scale_deg"] = options_.colour_scale_deg;
  report["warnings"] = calibrated.warnings;
  WriteFileAtomic(options_.output_dir / "edge_error.json", report.dump(2) + "\n", OverwritePolicy::kReplace);
  WriteFileAtomic(options_.output_dir / "edge_error.txt", summary_.FullReport(), OverwritePolicy::kReplace);
  ReportProgress("edge error", 1);
}

EdgeErrorController::Inputs EdgeErrorController::LoadSessionWithTruth() const {
  BeginStage("load session");
  Inputs inputs;
  SessionLoadOptions load;
  load.verify_checksums = options_.verify_checksums;
  inputs.session = LoadSession(session_dir_, load);
  inputs.session_name = (session_dir_ / "session.json").string();
  if (!inputs.session.ground_truth) {
    throw SessionError(inputs.session_name + ": ground_truth: missing; the edge error is measured against ground truth "
                                             "(a simulated session)");
  }
  inputs.truth = ReadImageFloat(session_dir_ / inputs.session.ground_truth->normal_file);
  inputs.sample_mask = ReadImageU8(session_dir_ / inputs.session.ground_truth->mask_file);
  return inputs;
}

void EdgeErrorController::DevelopFrames(Inputs* inputs) const {
  const Session& session = inputs->session;
  auto decode = [&](const FrameRecord& record) {
    const fs::path path = session_dir_ / record.file;
    RawImage raw = DecodeRawFile(path);
    CheckRawSize(raw, session.camera.width, session.camera.height, path.string());
    return raw;
  };
  const RawImage dark = decode(*FindDarkFrame(session));
  for (size_t k = 0; k < session.rig.leds.size(); ++k) {
    ThrowIfStopRequested("decode RAW");
    ReportProgress("decode RAW", double(k) / session.rig.leds.size());
    DevelopedFrame developed = DevelopRaw(decode(*FindLedFrame(session, static_cast<int>(k))), &dark, options_.develop);
    inputs->images.push_back(std::move(developed.rgb));
    inputs->valid.push_back(std::move(developed.valid));
  }
}

ImageU8 EdgeErrorController::MeasureCase(const Inputs& inputs, const std::string& name, const std::string& description,
                                         const LightField& field) {
  const std::string stage = "solve " + name;
  BeginStage(stage);
  PhotometricSolverInput input;
  for (size_t k = 0; k < inputs.images.size(); ++k) {
    input.images.push_back(&inputs.images[k]);
    input.sample_valid.push_back(&inputs.valid[k]);
  }
  input.light_field = &field;
  PhotometricSolution solution;
  const PhotometricSolverSummary solved =
      SolvePhotometricStereo(options_.solver, input, &solution, StageCallback(stage));
  if (solved.IsCancelled()) throw Cancelled(stage);

  const int width = inputs.session.camera.width, height = inputs.session.camera.height;
  EdgeErrorCase result;
  result.name = name;
  result.description = description;
  ImageU8 solved_mask(width, height, 1), sample_mask(width, height, 1);
  for (size_t i = 0; i < solved_mask.num_pixels(); ++i) {
    solved_mask.data()[i] = solution.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved);
    sample_mask.data()[i] =
        solved_mask.data()[i] && inputs.sample_mask.data()[i * inputs.sample_mask.channels()] > 127;
  }
  result.error_deg = AngularErrorDegrees(solution.normal_in_table, inputs.truth, solved_mask);
  result.sample_error_deg = AngularErrorDegrees(solution.normal_in_table, inputs.truth, sample_mask);
  const TiltMap tilt = ComputeTilt(solution, inputs.truth, summary_.block_px);
  const TiltFigures figures =
      MeasureTilt(tilt, width, height, options_.centre_fraction, options_.border_fraction);
  result.centre_tilt_deg = figures.centre_deg;
  result.border_tilt_deg = figures.border_deg;
  result.max_tilt_deg = figures.max_deg;
  const ImageU8 image = TiltImage(tilt, width, height, std::min(width, 616), options_.colour_scale_deg);
  result.image = "edge_error_" + result.name + ".png";
  WritePng(options_.output_dir / result.image, image, OverwritePolicy::kReplace);
  summary_.cases.push_back(result);
  ThrowIfStopRequested(stage);
  return image;
}

}  // namespace scanbench
