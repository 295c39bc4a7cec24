// Writes the seed corpora of tests/fuzz/corpus/ with the project's own
// writers (the DNG writer, the session, rig and calibration set writers, the
// EXR and PNG writers), so that every seed is a file scanbench itself would
// write or accept. Run by hand after a format change:
//   build-fuzz/tests/fuzz/make_seeds tests/fuzz/corpus
// (scripts/fuzz.sh --seeds). Seeds are kept small: a few KB each.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "app/io/dng_writer.h"
#include "app/io/image_io.h"
#include "app/io/result_maps.h"
#include "app/session/calibration_set.h"
#include "app/session/rig_json.h"
#include "app/session/session.h"
#include "tests/app/session/session_test_util.h"
#include "tests/fuzz/fuzz_support.h"

#ifndef SCANBENCH_SOURCE_DIR
#error "SCANBENCH_SOURCE_DIR: tests/fuzz/CMakeLists.txt defines it"
#endif

namespace fs = std::filesystem;
using namespace scanbench;

namespace {

std::string ReadFile(const fs::path& path) { return testing_util::ReadText(path); }

void Seed(const fs::path& corpus, const std::string& harness, const std::string& name, const std::string& bytes) {
  fs::create_directories(corpus / harness);
  fuzz::WriteBytes(corpus / harness / name, bytes);
  std::printf("%s/%s: %zu bytes\n", harness.c_str(), name.c_str(), bytes.size());
}

// Several files as one input, in the harness's section order.
std::string Sections(const std::vector<std::string>& files) {
  std::string joined;
  for (size_t i = 0; i < files.size(); ++i) {
    if (i > 0) joined += fuzz::kSectionSeparator;
    joined += files[i];
  }
  return joined;
}

void RawSeeds(const fs::path& corpus) {
  RawImage raw;
  raw.mosaic = ImageU16(kMinDngSide + 2, kMinDngSide, 1);
  for (int y = 0; y < raw.height(); ++y) {
    for (int x = 0; x < raw.width(); ++x) raw.mosaic(x, y) = static_cast<uint16_t>(64 + 37 * x + 101 * y);
  }
  raw.black_level = {64, 64, 64, 64};
  raw.white_level = 4095;
  DngMetadata metadata;
  metadata.serial = "0001";
  metadata.software = "scanbench fuzz seed";
  metadata.exposure_time_s = 1.0 / 60;
  metadata.iso = 100;
  metadata.f_number = 8;
  metadata.capture_time = "2024:05:01 12:00:00";
  metadata.camera_from_xyz_d65 = Eigen::Matrix3d::Identity() * 0.8;
  metadata.as_shot_neutral = Eigen::Vector3d(0.5, 1.0, 0.7);
  metadata.forward_matrix_d50 = Eigen::Matrix3d::Identity();
  const std::vector<uint8_t> dng = EncodeDng(raw, metadata);
  Seed(corpus, "raw_decode", "tiny.dng", std::string(dng.begin(), dng.end()));
  raw.cfa = CfaPattern::kBGGR;
  const std::vector<uint8_t> plain = EncodeDng(raw);
  Seed(corpus, "raw_decode", "tiny_bggr_plain.dng", std::string(plain.begin(), plain.end()));
}

void SessionSeeds(const fs::path& corpus, const fs::path& source_dir) {
  Session session = testing_util::MakeTestSession(3);
  session.rig = LoadRigDescriptionFile((source_dir / "data/bench/d5100_10led_rig.json").string());
  session.rig.leds.resize(3);
  session.camera.width = session.rig.camera.intrinsics.width;
  session.camera.height = session.rig.camera.intrinsics.height;
  Seed(corpus, "session_json", "capturing.json", SessionToJson(session));
  session.frames.push_back(testing_util::MakeFrameRecord(FrameKind::kDark, -1));
  for (int k = 0; k < 3; ++k) session.frames.push_back(testing_util::MakeFrameRecord(FrameKind::kLed, k));
  for (FrameRecord& frame : session.frames) {
    frame.sha256 = std::string(64, 'a');
    frame.width = session.camera.width;
    frame.height = session.camera.height;
  }
  session.capture_complete = true;
  Seed(corpus, "session_json", "complete.json", SessionToJson(session));
  SessionFromJson(SessionToJson(session), "complete.json");  // the seeds must be sessions the parser accepts

  Seed(corpus, "rig_json", "d5100_10led_rig.json", ReadFile(source_dir / "data/bench/d5100_10led_rig.json"));
  Seed(corpus, "rig_json", "awkward_numbers.json", RigDescriptionToJson(testing_util::MakeTestRig(2)));
}

void CalibrationSeeds(const fs::path& corpus) {
  const Session session = testing_util::MakeTestSession(1);
  CalibrationSet set;
  set.created = "2024-05-01T10:00:00.000Z";
  set.software_version = "scanbench 0.1.0";
  set.camera = {session.camera.make, session.camera.model, session.camera.serial, session.camera.lens,
                session.camera.width, session.camera.height};
  TargetCaptureRecord target;
  target.session = "/bench/targets/white_sheet";
  target.kind = "white_sheet";
  target.captured = "2024-05-01T09:00:00Z";
  target.manifest_sha256 = std::string(64, 'a');
  target.target_sha256 = std::string(64, 'b');
  target.frame_sha256 = {std::string(64, 'c')};
  LightsSection lights;
  lights.date = "2024-05-01T10:10:00Z";
  lights.targets = {target};
  lights.sheets = {WhiteSheetTarget()};
  LightCalibrationSummary& s = lights.summary;
  s.termination = Termination::kSuccess;
  s.cell_px = 16;
  s.selected = LightCalibrationSummary::Choice::kPerPixel;
  s.selection_reason = "seed";
  LedModelFit fit;
  fit.usable = true;
  fit.led = session.rig.leds[0];
  fit.termination = "converged";
  s.model = {fit};
  LedPerPixelFit per_pixel;
  per_pixel.iterations = 1;
  per_pixel.converged = true;
  per_pixel.direction_change_deg = {0.5};
  per_pixel.intensity_change = {0.01};
  s.per_pixel = {per_pixel};
  LightFieldGrid grid;
  grid.width = session.camera.width;
  grid.height = session.camera.height;
  grid.origin_x = grid.origin_y = 7.5;
  grid.step = 16;
  grid.nodes_x = 2;
  grid.nodes_y = 2;
  std::vector<float> dirs(grid.num_nodes() * 3, 0.1f), intensities(dirs.size(), 0.25f);
  for (size_t i = 2; i < dirs.size(); i += 3) dirs[i] = 0.9f;
  s.per_pixel_field.emplace(grid, 1, dirs, intensities);
  set.lights = lights;

  const fs::path folder = fuzz::FreshFolder("calibration_seed");
  WriteCalibrationSet(folder, set);
  LoadCalibrationSet(folder);  // the seed must be a set the loader accepts
  Seed(corpus, "calibration_set", "one_led_field",
       Sections({ReadFile(folder / "calibration.json"), ReadFile(folder / "lights/led_00_direction.exr"),
                 ReadFile(folder / "lights/led_00_intensity.exr")}));
}

std::string Png(const fs::path& folder, const ImageU16& image) {
  WritePng(folder / "image.png", image, OverwritePolicy::kReplace);
  return ReadFile(folder / "image.png");
}
std::string Png(const fs::path& folder, const ImageU8& image) {
  WritePng(folder / "image.png", image, OverwritePolicy::kReplace);
  return ReadFile(folder / "image.png");
}

void DatasetSeeds(const fs::path& corpus) {
  const fs::path folder = fuzz::FreshFolder("dataset_seed");
  ImageU8 mask(4, 4, 1, 255);
  mask(0, 0) = 0;
  std::vector<std::string> images;
  for (int k = 0; k < 3; ++k) {
    ImageU16 image(4, 4, 3, static_cast<uint16_t>(1000 + 5000 * k));
    images.push_back(Png(folder, image));
  }
  // The order of dataset_folder_fuzz.cc's kFiles.
  const std::string filenames = "001.png\n002.png\n003.png\n";
  const std::string intensities = "1 1 1\n0.9 1 1.1\n1 1 1\n";
  Seed(corpus, "dataset_folder", "diligent_3_lights",
       Sections({filenames, intensities, "0 0 1\n0.5 0 0.866\n0 0.5 0.866\n", "", "", "", "", Png(folder, mask),
                 images[0], images[1], images[2]}));
  Seed(corpus, "dataset_folder", "near_field_3_leds",
       Sections({filenames, intensities, "", "-50 0 0\n50 0 0\n0 50 0\n", "1.5\n",
                 "500 0 2\n0 500 2\n0 0 1\n", "300\n", Png(folder, mask), images[0], images[1], images[2]}));
}

void ResultMapSeeds(const fs::path& corpus) {
  const fs::path folder = fuzz::FreshFolder("result_seed");
  ImageF confidence(4, 4, 3, 0.5f);
  WriteExr(folder / "confidence.exr", confidence, OverwritePolicy::kRefuse, ConfidenceChannelNames());
  Seed(corpus, "result_map", "confidence.exr", ReadFile(folder / "confidence.exr"));
  ImageF normal(4, 4, 3, 0.0f);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 4; ++x) normal(x, y, 2) = 1.0f;
  }
  WriteExr(folder / "normal.exr", normal, OverwritePolicy::kRefuse);
  Seed(corpus, "result_map", "normal.exr", ReadFile(folder / "normal.exr"));
  ImageF specular(4, 4, 2, 0.04f);
  WriteExr(folder / "specular.exr", specular, OverwritePolicy::kRefuse, {"specular_f0", "roughness_alpha"});
  Seed(corpus, "result_map", "specular.exr", ReadFile(folder / "specular.exr"));
  ImageU8 mask(4, 4, 1, 255);
  mask(1, 1) = 0;
  Seed(corpus, "result_map", "solved_mask.png", Png(folder, mask));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_seeds <corpus folder, e.g. tests/fuzz/corpus>\n");
    return 2;
  }
  const fs::path corpus = argv[1];
  RawSeeds(corpus);
  SessionSeeds(corpus, SCANBENCH_SOURCE_DIR);
  CalibrationSeeds(corpus);
  DatasetSeeds(corpus);
  ResultMapSeeds(corpus);
  return 0;
}
