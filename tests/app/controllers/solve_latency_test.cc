// What the live solve (issue #14 item 2) changes in how `scanbench solve`
// runs, never in what it writes: a preparation whose light field holds its
// table points (SolvePreparation::HoldSurfacePoints) and its LED frames
// developed ahead (SolvePreparation::DevelopFrame). The result folder must
// equal the default solve's file for file. (The first pass streamed while it
// is solved, SolveOptions::stream_first_pass: solve_controller_test.cc.)
#include <cstring>
#include <fstream>
#include <iterator>
#include <optional>
#include <set>

#include <gtest/gtest.h>

#include "app/controllers/solve_controller.h"
#include "app/io/image_io.h"
#include "app/session/session.h"
#include "tests/util/solved_session.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using testing::TemporaryFolder;

constexpr int kWidth = 400, kHeight = 264;

fs::path Simulate(const TemporaryFolder& folder, const std::string& name, double fold_amplitude_mm) {
  return testing::SimulateFoldedSession(folder / name, kWidth, kHeight, fold_amplitude_mm);
}

SolveSummary Solve(const fs::path& session_dir, SolveOptions options, std::optional<SolvePreparation> prepared = {}) {
  SolveController solve(session_dir, options);
  if (prepared) solve.UsePreparation(std::move(*prepared));
  solve.Run();
  return solve.summary();
}

std::string FileBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The same files; the EXRs' pixels and the PNGs' bytes equal (the EXRs'
// headers carry the second they were written).
void ExpectSameMaps(const fs::path& a, const fs::path& b) {
  std::set<std::string> names_a, names_b;
  for (const auto& entry : fs::directory_iterator(a)) names_a.insert(entry.path().filename().string());
  for (const auto& entry : fs::directory_iterator(b)) names_b.insert(entry.path().filename().string());
  ASSERT_EQ(names_a, names_b);
  int compared = 0;
  for (const std::string& name : names_a) {
    const std::string ext = fs::path(name).extension().string();
    if (ext == ".exr") {
      const ImageF x = ReadImageFloat(a / name), y = ReadImageFloat(b / name);
      ASSERT_EQ(x.width(), y.width()) << name;
      ASSERT_EQ(x.height(), y.height()) << name;
      ASSERT_EQ(x.channels(), y.channels()) << name;
      EXPECT_EQ(std::memcmp(x.data(), y.data(), x.size() * sizeof(float)), 0) << name << " differs";
      ++compared;
    } else if (ext == ".png") {
      EXPECT_TRUE(FileBytes(a / name) == FileBytes(b / name)) << name << " differs";
      ++compared;
    }
  }
  EXPECT_GE(compared, 8) << "normal, albedo, confidence, specular, error map and the PNGs";
}

void ExpectSameFigures(const SolveSummary& a, const SolveSummary& b) {
  EXPECT_EQ(a.inputs_fingerprint, b.inputs_fingerprint) << "a preparation is not an input of the result";
  EXPECT_EQ(a.solver.pixels_by_status, b.solver.pixels_by_status);
  EXPECT_EQ(a.depth.refined, b.depth.refined);
  EXPECT_EQ(a.depth.iterations.size(), b.depth.iterations.size());
  EXPECT_EQ(a.depth.first_height_range_mm, b.depth.first_height_range_mm);
  ASSERT_TRUE(a.normal_error_deg && b.normal_error_deg);
  EXPECT_EQ(a.normal_error_deg->mean, b.normal_error_deg->mean);
  EXPECT_EQ(a.normal_error_deg->median, b.normal_error_deg->median);
  EXPECT_EQ(a.albedo_color_error->delta_e.mean, b.albedo_color_error->delta_e.mean);
  EXPECT_EQ(a.bytes_written, b.bytes_written);
}

TEST(SolveLatencyTest, PreparationWithHeldPointsAndFramesDevelopedAheadSolvesTheSame) {
  TemporaryFolder folder;
  const fs::path session_dir = Simulate(folder, "flat", 2.5);
  SolveOptions options;
  options.run_label = "on-request";
  const SolveSummary on_request = Solve(session_dir, options);

  const Session session = LoadSession(session_dir);
  options.run_label = "held";
  SolvePreparation prepared(session_dir, session, options);
  EXPECT_FALSE(prepared.holds_surface_points());
  prepared.HoldSurfacePoints(2);
  EXPECT_TRUE(prepared.holds_surface_points());
  int developed = 0;
  for (const FrameRecord& record : session.frames) {
    prepared.AddFrame(record, DecodeSessionFrame(session_dir, session, record));
    developed += prepared.DevelopFrame(session, record);  // the dark frame is first: each LED frame after it
  }
  EXPECT_EQ(developed, static_cast<int>(session.rig.leds.size()));
  EXPECT_EQ(prepared.num_developed_frames(), developed);
  const SolveSummary held = Solve(session_dir, options, std::move(prepared));
  ExpectSameFigures(on_request, held);
  ExpectSameMaps(on_request.result_dir, held.result_dir);
}

}  // namespace
}  // namespace scanbench
