#include "app/controllers/simulate_dataset_controller.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <sstream>

#include "app/io/dataset_io.h"
#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/io/staged_folder.h"
#include "core/field_error.h"
#include "core/format.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

// Numbers for the text files: enough digits that nothing is lost.
std::string Row(std::initializer_list<double> values) {
  std::ostringstream out;
  out << std::setprecision(10);
  bool first = true;
  for (double v : values) {
    out << (first ? "" : " ") << v;
    first = false;
  }
  out << "\n";
  return out.str();
}

ImageU16 ToPng16(const ImageF& image) {
  ImageU16 out(image.width(), image.height(), image.channels());
  for (size_t i = 0; i < image.size(); ++i) {
    const double v = std::clamp(double(image.data()[i]), 0.0, 1.0);
    out.data()[i] = static_cast<uint16_t>(std::lround(v * 65535));
  }
  return out;
}

}  // namespace

SimulateDatasetOptions::SimulateDatasetOptions() {
  rig.width = 320;
  rig.height = 240;
}

void SimulateDatasetOptions::Check() const {
  rig.Check();
  scene.Check();
  develop.Check();
}

std::string SimulateDatasetSummary::BriefReport() const {
  std::ostringstream out;
  out << std::fixed << std::setprecision(2) << "near-field folder " << folder.string() << ": " << width << "x"
      << height << ", " << num_lights << " LEDs, " << mask_pixels << " mask pixels, mean distance "
      << mean_distance_mm << " mm (table " << table_distance_mm << " mm, highest point " << max_height_mm
      << " mm above it), " << Significant(seconds) << " s";
  return out.str();
}

RigDescription SimulatedDatasetRig(int width, int height, SensorColorModel color) {
  RigDescription rig = MakeDefaultSimulatedRig(width, height, color);
  CameraIntrinsics& k = rig.camera.intrinsics;
  k.k1 = k.k2 = k.k3 = k.p1 = k.p2 = 0;  // the layout's camera is a pinhole K
  rig.name += ", no lens distortion";
  return rig;
}

SimulateDatasetController::SimulateDatasetController(fs::path folder, SimulateDatasetOptions options)
    : folder_(std::move(folder)), options_(std::move(options)) {}

void SimulateDatasetController::Run() {
  const auto start = std::chrono::steady_clock::now();
  options_.Check();
  if (fs::exists(folder_) && !options_.overwrite) {
    throw std::invalid_argument("SimulateDatasetController: " + folder_.string() +
                                " already exists; choose a new folder or allow overwrite");
  }
  summary_ = SimulateDatasetSummary();
  SimulatedRigOptions rig_options = options_.rig;
  if (!options_.raw_path) rig_options.ambient = 0;
  const RigDescription description = SimulatedDatasetRig(rig_options.width, rig_options.height, rig_options.color);
  BeginStage("trace");
  const SimulatedRig rig(rig_options, TextileScene(options_.scene), description, StageCallback("trace"));
  const int width = rig.width(), height = rig.height();
  const GroundTruthMaps truth = rig.RenderGroundTruth();

  // OpenCV camera frame (x right, y down, z forward) and the layout's solver
  // frame for normals (x right, y up, z towards the camera).
  const Eigen::Isometry3d& cam_from_table = description.camera.cam_from_table;
  const Eigen::Vector3d flip(1, -1, -1);
  ImageF normal_gt(width, height, 3);
  double sum_z = 0, max_height = 0;
  size_t mask_pixels = 0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      if (!truth.sample_mask(x, y)) continue;  // (0, 0, 0) off the object, as DiLiGenT's Normal_gt
      const Eigen::Vector3d n(truth.normal_in_table(x, y, 0), truth.normal_in_table(x, y, 1),
                              truth.normal_in_table(x, y, 2));
      const Eigen::Vector3d n_solver = (cam_from_table.linear() * n).cwiseProduct(flip).normalized();
      for (int c = 0; c < 3; ++c) normal_gt(x, y, c) = static_cast<float>(n_solver[c]);
      const Eigen::Vector3d p(truth.point_in_table(x, y, 0), truth.point_in_table(x, y, 1),
                              truth.point_in_table(x, y, 2));
      sum_z += (cam_from_table * p).z();
      max_height = std::max(max_height, p.z());
      ++mask_pixels;
    }
  }
  if (mask_pixels == 0) throw std::invalid_argument("SimulateDatasetController: the sample is not in view");
  summary_.mean_distance_mm = sum_z / double(mask_pixels);
  summary_.table_distance_mm = cam_from_table.translation().z();
  summary_.max_height_mm = max_height;

  StagedFolder staged = [&] {
    if (fs::exists(folder_)) fs::remove_all(folder_);  // overwrite was allowed
    return StagedFolder::OntoAbsent(folder_);
  }();
  const fs::path out = staged.staging();
  std::string names, positions, axes, intensities, mus;
  const int num_leds = rig.num_leds();
  BeginStage("render");
  RawImage dark;
  if (options_.raw_path) dark = rig.RenderFrame(std::nullopt, 0);
  for (int k = 0; k < num_leds; ++k) {
    ThrowIfStopRequested("render");
    const ImageF frame = options_.raw_path ? DevelopRaw(rig.RenderFrame(k, k + 1), &dark, options_.develop).rgb
                                           : rig.RenderLinear(k);
    char name[32] = {};
    std::snprintf(name, sizeof(name), "%02d.png", k + 1);
    WritePng(out / name, ToPng16(frame), OverwritePolicy::kRefuse);
    names += std::string(name) + "\n";
    const LedDescription& led = description.leds[k];
    const Eigen::Vector3d p = cam_from_table * led.position_in_table_mm;
    const Eigen::Vector3d a = (cam_from_table.linear() * led.axis_in_table).normalized();
    positions += Row({p.x(), p.y(), p.z()});
    axes += Row({a.x(), a.y(), a.z()});
    // The rig states the reading at 1000 mm; the layout's at 1 mm.
    const Eigen::Vector3d e = led.rgb_intensity * (kLedReferenceDistanceMm * kLedReferenceDistanceMm);
    intensities += Row({e.x(), e.y(), e.z()});
    mus += Row({led.mu});
    ReportProgress("render", double(k + 1) / num_leds);
  }
  const CameraIntrinsics& k = description.camera.intrinsics;
  WriteFileAtomic(out / "filenames.txt", names, OverwritePolicy::kRefuse);
  WriteFileAtomic(out / "light_positions.txt", positions, OverwritePolicy::kRefuse);
  WriteFileAtomic(out / "light_directions.txt", axes, OverwritePolicy::kRefuse);
  WriteFileAtomic(out / "light_intensities.txt", intensities, OverwritePolicy::kRefuse);
  WriteFileAtomic(out / "light_mu.txt", mus, OverwritePolicy::kRefuse);
  WriteFileAtomic(out / "K.txt", Row({k.fx, 0, k.cx}) + Row({0, k.fy, k.cy}) + Row({0, 0, 1}),
                  OverwritePolicy::kRefuse);
  WriteFileAtomic(out / "mean_distance.txt", Row({summary_.mean_distance_mm}), OverwritePolicy::kRefuse);
  ImageU8 mask(width, height, 1);
  for (size_t i = 0; i < mask.num_pixels(); ++i) mask.data()[i] = truth.sample_mask.data()[i] ? 255 : 0;
  WritePng(out / "mask.png", mask, OverwritePolicy::kRefuse);
  WriteMatImage(out / "Normal_gt.mat", "Normal_gt", normal_gt);
  ThrowIfStopRequested("write");
  staged.Commit();

  summary_.folder = folder_;
  summary_.width = width;
  summary_.height = height;
  summary_.num_lights = num_leds;
  summary_.mask_pixels = mask_pixels;
  summary_.seconds = SecondsSince(start);
}

}  // namespace scanbench
