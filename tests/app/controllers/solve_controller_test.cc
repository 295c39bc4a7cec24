// The solve job (`scanbench solve`, SolveController) on small simulated
// sessions: what a result folder holds and what its report says, a new
// folder per solve, nothing left behind by a cancel at any stage or a bad
// frame, and every route of the bands (SolveRouting: streamed, spilled until
// the depth refinement's decision, or both) writing the same bytes, on a flat
// sample and on a draped one whose depth refinement re-solves.
#include "app/controllers/solve_controller.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <set>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/controllers/simulate_controller.h"
#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/session/session.h"
#include "pipeline/banded_solve.h"
#include "tests/util/solved_session.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using testing::ReadJsonFile;
using testing::TemporaryFolder;

constexpr int kWidth = 192, kHeight = 160;  // two bands of the solve (128 rows, then 32)

// Two sessions, each simulated once per process when first asked for: the
// default twill (folds of 2.5 mm: the table plane kept) and one draped in
// folds of 25 mm (the depth refinement re-solves).
class SolveControllerTest : public ::testing::Test {
 protected:
  static void TearDownTestSuite() {
    delete sessions_;
    sessions_ = nullptr;
  }

  // A copy of session "flat" or "draped", so that each test's results and changes are its own.
  fs::path CopyOf(const std::string& name, const std::string& copy_name = {}) const {
    if (sessions_ == nullptr) sessions_ = new TemporaryFolder();
    const fs::path simulated = *sessions_ / name;
    if (!fs::exists(simulated)) {
      testing::SimulateFoldedSession(simulated, kWidth, kHeight, name == "draped" ? 25.0 : 2.5);
    }
    const fs::path copy = folder_ / (copy_name.empty() ? name : copy_name);
    fs::copy(simulated, copy, fs::copy_options::recursive);
    return copy;
  }

  static SolveSummary Solve(const fs::path& session_dir, const SolveOptions& options = {}) {
    SolveController solve(session_dir, options);
    solve.Run();
    return solve.summary();
  }

  // Every entry of <session>/results, hidden ones (staging folders) too.
  static std::vector<std::string> ResultEntries(const fs::path& session_dir) {
    std::vector<std::string> names;
    std::error_code ignored;
    if (!fs::exists(session_dir / "results", ignored)) return names;
    for (const auto& entry : fs::directory_iterator(session_dir / "results")) {
      names.push_back(entry.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
  }

  TemporaryFolder folder_;
  static TemporaryFolder* sessions_;
};

TemporaryFolder* SolveControllerTest::sessions_ = nullptr;  // made by the first CopyOf

std::string FileBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::set<std::string> FileNames(const fs::path& folder) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder)) names.insert(entry.path().filename().string());
  return names;
}

// An EXR's bytes with the value of its capDate attribute (the second it was
// written: "YYYY:MM:DD HH:MM:SS") blanked, so that two writes of the same
// pixels compare equal byte for byte.
std::string ExrBytesWithoutDate(const fs::path& path) {
  std::string bytes = FileBytes(path);
  const std::string name("capDate\0string\0", 15);
  const size_t found = bytes.find(name);
  if (found != std::string::npos) {
    const size_t value = found + name.size() + 4;  // after the attribute's 4-byte size
    uint32_t size = 0;
    std::memcpy(&size, bytes.data() + found + name.size(), sizeof(size));
    if (value + size <= bytes.size()) std::fill_n(bytes.begin() + value, size, '#');
  }
  return bytes;
}

// Two result folders hold the same files with the same bytes (the EXRs but
// for their dates), and reports that agree but for the timings, dates and
// the folders' names.
void ExpectSameResult(const fs::path& a, const fs::path& b) {
  ASSERT_EQ(FileNames(a), FileNames(b));
  for (const std::string& name : FileNames(a)) {
    if (name == "report.json" || name == "summary.txt") continue;
    const bool exr = fs::path(name).extension() == ".exr";
    EXPECT_TRUE(exr ? ExrBytesWithoutDate(a / name) == ExrBytesWithoutDate(b / name)
                    : FileBytes(a / name) == FileBytes(b / name))
        << name << " differs";
  }
  nlohmann::json report_a = ReadJsonFile(a / "report.json"), report_b = ReadJsonFile(b / "report.json");
  for (nlohmann::json* report : {&report_a, &report_b}) {
    for (const char* key : {"created", "run_id", "timings_s"}) report->erase(key);
    (*report)["result"].erase("message");  // the solve's time
    (*report)["depth_refinement"].erase("seconds");
    (*report)["depth_refinement"].erase("message");
    for (nlohmann::json& iteration : (*report)["depth_refinement"]["iterations"]) iteration.erase("seconds");
  }
  EXPECT_EQ(report_a, report_b);
}

// The result folder: the maps, the error map against the ground truth, the
// reports; report.json names each file and says what was solved and how well.
TEST_F(SolveControllerTest, ResultFolderHoldsTheMapsAndAReportThatDescribesThem) {
  const fs::path session_dir = CopyOf("flat");
  SolveOptions options;
  const SolveSummary summary = Solve(session_dir, options);
  const fs::path result = summary.result_dir;
  EXPECT_EQ(result.parent_path(), session_dir / "results");
  EXPECT_THAT(ResultEntries(session_dir), ElementsAre(result.filename().string())) << "no staging folder is left";
  EXPECT_THAT(result.filename().string(), ::testing::EndsWith("-adaptive"));
  EXPECT_EQ(FileNames(result),
            (std::set<std::string>{"albedo.exr", "albedo_srgb.png", "angular_error_deg.exr", "confidence.exr",
                                   "normal.exr", "normal.png", "report.json", "solved_mask.png", "specular.exr",
                                   "status.png", "summary.txt"}));
  const ImageF normals = ReadImageFloat(result / "normal.exr");
  EXPECT_EQ(normals.width(), kWidth);
  EXPECT_EQ(normals.height(), kHeight);
  EXPECT_EQ(ReadImageFileInfo(result / "normal.exr").bits_per_sample, 16);  // half by default
  // The 16-bit PNG encodes the same normals: (n + 1) / 2, from the float
  // normals; the EXR's half holds them within 2^-12 (at 0.5 .. 1).
  const ImageU16 encoded = ReadImageU16(result / "normal.png");
  EXPECT_NEAR(encoded(96, 80, 2) / 65535.0 * 2 - 1, normals(96, 80, 2), 1.0 / 4096 + 1e-5);

  const nlohmann::json report = ReadJsonFile(result / "report.json");
  EXPECT_EQ(report.at("schema"), "scanbench.solve_report/1");
  EXPECT_EQ(report.at("run_id"), result.filename().string());
  EXPECT_EQ(report.at("inputs_fingerprint"), SolveInputsFingerprint(LoadSession(session_dir), options));
  EXPECT_EQ(report.at("session").at("width"), kWidth);
  EXPECT_EQ(report.at("session").at("height"), kHeight);
  EXPECT_EQ(report.at("session").at("leds"), 10);
  EXPECT_EQ(report.at("session").at("sample_name"), "simulated twill");
  // Every file is listed under its kind, and counted but for the two reports.
  std::set<std::string> listed;
  for (const auto& [kind, file] : report.at("outputs").items()) listed.insert(file.get<std::string>());
  EXPECT_EQ(listed, FileNames(result));
  const nlohmann::json& files = report.at("bytes_written").at("files");
  EXPECT_EQ(files.size(), FileNames(result).size() - 2);
  uintmax_t total = 0;
  for (const auto& [name, bytes] : files.items()) {
    EXPECT_EQ(bytes.get<uintmax_t>(), fs::file_size(result / name)) << name;
    total += fs::file_size(result / name);
  }
  EXPECT_EQ(report.at("bytes_written").at("total").get<uintmax_t>(), total);
  EXPECT_EQ(summary.TotalBytesWritten(), total);
  EXPECT_EQ(report.at("bytes_written").at("exr_encoding"), "half, piz");
  EXPECT_THAT(FileBytes(result / "summary.txt"), HasSubstr("bytes written (half, piz EXR): albedo.exr "));
  EXPECT_THAT(FileBytes(result / "summary.txt"), HasSubstr(" total " + std::to_string(total) + " ("));
  // Every pixel has a status; the sample is solved.
  size_t pixels = 0;
  for (const auto& [status, count] : report.at("result").at("pixels_by_status").items()) pixels += count.get<size_t>();
  EXPECT_EQ(pixels, size_t(kWidth) * kHeight);
  EXPECT_EQ(report.at("result").at("termination"), "success");
  const nlohmann::json& truth = report.at("ground_truth");
  EXPECT_EQ(truth.at("normal_angular_error_deg").at("mean").get<double>(), summary.normal_error_deg->mean);
  EXPECT_EQ(truth.at("normal_angular_error_deg").at("pixels").get<size_t>(), summary.normal_error_deg->num_pixels);
  EXPECT_GT(summary.normal_error_deg->num_pixels, size_t(kWidth) * kHeight / 4);
  EXPECT_LT(summary.normal_error_deg->mean, 3.0);
  EXPECT_EQ(truth.at("unsolved_on_sample"), summary.unsolved_on_sample);
  EXPECT_EQ(report.at("depth_refinement").at("refined"), false);
  // One time per stage, listed in order in summary.txt.
  std::vector<std::string> stages;
  for (const StageTiming& timing : summary.timings) stages.push_back(timing.stage);
  EXPECT_THAT(stages, ElementsAre("load", "decode", "light_field", "solve", "depth_refine", "color", "evaluate",
                                  "write_maps"));
  for (const std::string& stage : stages) EXPECT_TRUE(report.at("timings_s").contains(stage)) << stage;
  EXPECT_EQ(FileBytes(result / "summary.txt"), summary.FullReport());
}

// solve --float32-maps: the full-precision files, larger, the PNGs identical.
TEST_F(SolveControllerTest, Float32MapsAreTheFullPrecisionFiles) {
  const fs::path session_dir = CopyOf("flat");
  const SolveSummary half = Solve(session_dir);
  SolveOptions float32;
  float32.float32_maps = true;
  const SolveSummary full = Solve(session_dir, float32);
  EXPECT_EQ(ReadImageFileInfo(full.result_dir / "normal.exr").bits_per_sample, 32);
  EXPECT_EQ(ReadImageFileInfo(full.result_dir / "confidence.exr").bits_per_sample, 32);
  const ImageF normals = ReadImageFloat(full.result_dir / "normal.exr");
  const ImageU16 encoded = ReadImageU16(full.result_dir / "normal.png");
  EXPECT_NEAR(encoded(96, 80, 2) / 65535.0 * 2 - 1, normals(96, 80, 2), 1e-4);
  EXPECT_EQ(FileBytes(full.result_dir / "normal.png"), FileBytes(half.result_dir / "normal.png"));
  EXPECT_GT(full.TotalBytesWritten(), half.TotalBytesWritten());
  EXPECT_EQ(ReadJsonFile(full.result_dir / "report.json").at("bytes_written").at("exr_encoding"), "float32, zip");
  EXPECT_NE(full.inputs_fingerprint, half.inputs_fingerprint);
}

TEST_F(SolveControllerTest, ASecondSolveWritesANewFolderBesideTheFirst) {
  const fs::path session_dir = CopyOf("flat");
  const SolveSummary first = Solve(session_dir);
  const std::string first_report = FileBytes(first.result_dir / "report.json");
  SolveOptions bilinear;
  bilinear.develop.demosaic = RawDevelopOptions::Demosaic::kBilinear;
  bilinear.run_label = "bilinear";
  const SolveSummary second = Solve(session_dir, bilinear);
  const SolveSummary third = Solve(session_dir, bilinear);
  EXPECT_THAT(second.result_dir.filename().string(), ::testing::EndsWith("-bilinear"));
  EXPECT_NE(second.result_dir, third.result_dir) << "the same label in the same second gets a folder of its own";
  EXPECT_EQ(ResultEntries(session_dir).size(), 3u);
  EXPECT_EQ(FileBytes(first.result_dir / "report.json"), first_report) << "the first result is untouched";
  EXPECT_NE(second.inputs_fingerprint, first.inputs_fingerprint);
  EXPECT_EQ(second.inputs_fingerprint, third.inputs_fingerprint);
}

// Issue #13: the Bayer-domain option solves per raw pixel and says so in the
// summary, report.json and the inputs fingerprint (batch must not skip it);
// the default blends the demosaiced and Bayer-domain normals, which the
// Bayer-domain option does not.
TEST_F(SolveControllerTest, BayerDomainSolveIsItsOwnResult) {
  const fs::path session_dir = CopyOf("flat");
  const SolveSummary demosaiced = Solve(session_dir);
  SolveOptions options;
  options.bayer_domain = true;
  options.run_label = "bayer";
  const SolveSummary bayer = Solve(session_dir, options);
  EXPECT_TRUE(bayer.solver.bayer_domain);
  EXPECT_FALSE(demosaiced.solver.bayer_domain);
  ASSERT_TRUE(bayer.normal_error_deg.has_value());
  EXPECT_LE(bayer.normal_error_deg->mean, 3.0);
  EXPECT_NE(bayer.inputs_fingerprint, demosaiced.inputs_fingerprint);
  const nlohmann::json report = ReadJsonFile(bayer.result_dir / "report.json");
  EXPECT_EQ(report.at("develop").at("bayer_domain"), true);
  EXPECT_EQ(report.at("develop").at("bayer_blend"), false);
  EXPECT_EQ(bayer.solver.pixels_bayer_blended, 0u);
  EXPECT_GT(demosaiced.solver.pixels_bayer_blended, 0u);
  EXPECT_EQ(ReadJsonFile(demosaiced.result_dir / "report.json").at("develop").at("bayer_blend"), true);
}

// The routes of the bands (SolveRouting): straight to the files without a
// depth refinement, spilled until its decision, or streamed meanwhile.
struct Route {
  const char* name;
  bool depth_refinement;
  bool stream_first_pass;
};
constexpr Route kRoutes[] = {{"streamed", false, false}, {"spilled", true, false}, {"streamed and spilled", true, true}};

SolveOptions OptionsOf(const Route& route) {
  SolveOptions options;
  options.depth.enabled = route.depth_refinement;
  options.stream_first_pass = route.stream_first_pass;
  return options;
}

// A stop requested at the start of any stage (and in the middle of the solve
// and of the depth refinement's re-solves) ends the solve with Cancelled and
// leaves neither a result folder nor a staging folder, whatever the route.
TEST_F(SolveControllerTest, ACancelAtAnyStageLeavesNothingBehind) {
  const std::vector<std::pair<std::string, double>> stops = {
      {"load session", 0.0}, {"decode RAW", 0.0},   {"solve", 0.0},     {"solve", 0.5},
      {"depth refine", 0.0}, {"depth refine", 0.3}, {"write maps", 0.0}};
  for (const std::string sample : {"flat", "draped"}) {
    const fs::path session_dir = CopyOf(sample);
    for (const Route& route : kRoutes) {
      for (const auto& [stage, fraction] : stops) {
        const bool before_the_routes = stage == "load session" || stage == "decode RAW";
        if (before_the_routes && (sample != "flat" || &route != &kRoutes[0])) continue;  // one route is enough
        const bool resolves = sample == "draped" && route.depth_refinement;
        if (stage == "depth refine" && fraction > 0 && !resolves) continue;  // no re-solve to stop
        SCOPED_TRACE(sample + ", " + route.name + ", stop at " + stage + " " + std::to_string(fraction));
        SolveController solve(session_dir, OptionsOf(route));
        bool stopped = false;
        solve.SetProgressCallback([&](const ProgressReport& report) {
          if (!stopped && report.stage == stage && report.fraction >= fraction && report.fraction < 1) {
            solve.RequestStop();
            stopped = true;
          }
        });
        EXPECT_THROW(solve.Run(), Cancelled);
        EXPECT_TRUE(stopped);
        EXPECT_THAT(ResultEntries(session_dir), IsEmpty());
      }
    }
  }
}

// Every route writes the same bytes: on the flat sample the first pass is
// the result (written as solved, or replayed from the spill); on the draped
// one the re-solve is (and a first pass streamed meanwhile is dropped).
TEST_F(SolveControllerTest, EveryRouteWritesTheSameBytes) {
  for (const char* sample : {"flat", "draped"}) {
    SCOPED_TRACE(sample);
    const fs::path session_dir = CopyOf(sample);
    SolveOptions options = OptionsOf(kRoutes[1]);
    const SolveSummary spilled = Solve(session_dir, options);
    EXPECT_EQ(spilled.depth.refined, std::string(sample) == "draped") << spilled.depth.BriefReport();
    options.stream_first_pass = true;
    const SolveSummary streamed = Solve(session_dir, options);
    EXPECT_EQ(streamed.inputs_fingerprint, spilled.inputs_fingerprint) << "stream_first_pass is not an input";
    ExpectSameResult(spilled.result_dir, streamed.result_dir);
    EXPECT_EQ(ResultEntries(session_dir).size(), 2u) << "nothing of a dropped first pass is left";
  }
  // Without the depth refinement the flat sample's bands go straight to the
  // files: the same result as the spilled first pass kept on the table plane.
  const fs::path session_dir = CopyOf("flat", "flat without depth refinement");
  const SolveSummary spilled = Solve(session_dir, OptionsOf(kRoutes[1]));
  SolveOptions streamed_options = OptionsOf(kRoutes[0]);
  const SolveSummary streamed = Solve(session_dir, streamed_options);
  for (const char* name : {"normal.png", "albedo_srgb.png", "status.png", "solved_mask.png"}) {
    EXPECT_TRUE(FileBytes(spilled.result_dir / name) == FileBytes(streamed.result_dir / name)) << name;
  }
  EXPECT_EQ(ReadJsonFile(streamed.result_dir / "report.json").at("depth_refinement").at("refined"), false);
}

// The learned method's own expected error (issue #33) is a file of the
// result, the same through the streamed and the spilled route; a solve
// that does not run the network has no such file.
TEST_F(SolveControllerTest, TheLearnedMethodWritesItsExpectedErrorOnEveryRoute) {
  const fs::path session_dir = CopyOf("flat");
  SolveOptions options = OptionsOf(kRoutes[0]);
  options.solver.method = PhotometricSolverOptions::Method::kLearned;
  const SolveSummary streamed = Solve(session_dir, options);
  options = OptionsOf(kRoutes[1]);
  options.solver.method = PhotometricSolverOptions::Method::kLearned;
  const SolveSummary spilled = Solve(session_dir, options);
  for (const SolveSummary* summary : {&streamed, &spilled}) {
    const fs::path map = summary->result_dir / "learned_error_deg.exr";
    ASSERT_TRUE(fs::exists(map)) << summary->result_dir;
    EXPECT_EQ(ReadJsonFile(summary->result_dir / "report.json").at("outputs").at("learned_error_deg"),
              "learned_error_deg.exr");
    const ImageF error = ReadImageFloat(map);
    const ImageU8 solved = ReadImageU8(summary->result_dir / "solved_mask.png");
    size_t solved_pixels = 0;
    double sum = 0;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        ASSERT_TRUE(std::isfinite(error(x, y)));
        if (solved(x, y) == 0) continue;
        ++solved_pixels;
        sum += error(x, y);
        EXPECT_GT(error(x, y), 0.0f) << "pixel " << x << ", " << y << ": every solved normal is the network's";
      }
    }
    ASSERT_GT(solved_pixels, 0u);
    // The network's floor on well-lit pixels is about a degree; its claim must be of that order.
    EXPECT_GT(sum / solved_pixels, 0.2);
    EXPECT_LT(sum / solved_pixels, 10.0);
  }
  EXPECT_TRUE(ExrBytesWithoutDate(streamed.result_dir / "learned_error_deg.exr") ==
              ExrBytesWithoutDate(spilled.result_dir / "learned_error_deg.exr"));
  const SolveSummary adaptive = Solve(session_dir, OptionsOf(kRoutes[0]));
  EXPECT_FALSE(fs::exists(adaptive.result_dir / "learned_error_deg.exr"));
}

// A frame that changed, went missing or is cut short is refused, naming the
// file, before anything is written.
TEST_F(SolveControllerTest, ABadFrameIsRefusedNamingTheFile) {
  const fs::path session_dir = CopyOf("flat");
  const fs::path frame = session_dir / "frames" / "led_03.dng";
  const std::vector<uint8_t> original = ReadFileBytes(frame);
  const auto replace_frame = [&](std::vector<uint8_t> bytes) {
    fs::remove(frame);
    WriteFileAtomic(frame, bytes, OverwritePolicy::kRefuse);
  };
  SolveOptions unverified;
  unverified.verify_checksums = false;

  std::vector<uint8_t> changed = original;
  changed.at(original.size() / 2) ^= 0x5a;
  replace_frame(changed);
  EXPECT_THAT([&] { Solve(session_dir); },
              ::testing::ThrowsMessage<SessionError>(AllOf(HasSubstr("led_03.dng"), HasSubstr("mismatch"))));

  fs::remove(frame);
  for (const SolveOptions& options : {SolveOptions(), unverified}) {
    EXPECT_THAT([&] { Solve(session_dir, options); },
                ::testing::ThrowsMessage<SessionError>(AllOf(HasSubstr("led_03.dng"), HasSubstr("does not exist"))));
  }

  replace_frame(std::vector<uint8_t>(original.begin(), original.begin() + original.size() / 2));
  EXPECT_THAT([&] { Solve(session_dir); }, ::testing::ThrowsMessage<SessionError>(HasSubstr("led_03.dng")));
  EXPECT_THAT([&] { Solve(session_dir, unverified); },
              ::testing::ThrowsMessage<std::runtime_error>(AllOf(HasSubstr("led_03.dng"), HasSubstr("truncated"))));
  EXPECT_THAT(ResultEntries(session_dir), IsEmpty());
}

// A frame a preparation decoded that session.json no longer lists with the
// same checksum (stale) is not used: the solve decodes the file itself.
TEST_F(SolveControllerTest, AStalePreparedFrameIsDecodedAgain) {
  const fs::path session_dir = CopyOf("flat");
  const Session session = LoadSession(session_dir);
  SolveOptions options;
  options.run_label = "plain";
  const SolveSummary plain = Solve(session_dir, options);
  options.run_label = "prepared";
  SolvePreparation prepared(session_dir, session, options);
  const FrameRecord& led = session.frames.at(1);
  FrameRecord stale = led;
  stale.sha256 = std::string(64, '0');
  // Another frame's pixels under this frame's name, as if decoded before the file changed.
  prepared.AddFrame(stale, DecodeSessionFrame(session_dir, session, session.frames.at(2)));
  SolveController solve(session_dir, options);
  solve.UsePreparation(std::move(prepared));
  solve.Run();
  ExpectSameResult(plain.result_dir, solve.summary().result_dir);
}

TEST_F(SolveControllerTest, AnIncompleteSessionIsNotSolved) {
  const fs::path session_dir = folder_ / "interrupted";
  SimulateOptions simulate;
  simulate.rig.width = 96;
  simulate.rig.height = 64;
  SimulateController interrupted(session_dir, simulate);
  interrupted.SetProgressCallback([&](const ProgressReport& report) {
    if (report.stage == "simulate") interrupted.RequestStop();
  });
  EXPECT_THROW(interrupted.Run(), Cancelled);
  EXPECT_THAT([&] { Solve(session_dir); }, ::testing::ThrowsMessage<SessionError>(HasSubstr("capture_complete")));
  EXPECT_THAT(ResultEntries(session_dir), IsEmpty());
}

TEST_F(SolveControllerTest, BadOptionsAreRejectedBeforeWork) {
  const fs::path session_dir = CopyOf("flat");
  SolveOptions options;
  options.run_label = "../escape";
  EXPECT_THAT([&] { Solve(session_dir, options); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("run_label")));
  EXPECT_THAT(ResultEntries(session_dir), IsEmpty());
}

// The session's ground-truth files read band by band
// (SessionGroundTruthEvaluation) give the whole-frame figures of the truth
// read whole (the evaluation itself: tests/pipeline/ground_truth_evaluation_test.cc);
// a mask of another size is refused, naming it.
TEST_F(SolveControllerTest, SessionGroundTruthIsReadBandByBand) {
  const fs::path session_dir = CopyOf("flat");
  const Session session = LoadSession(session_dir);
  const GroundTruthFiles& truth = *session.ground_truth;
  const ImageF truth_normals = ReadImageFloat(session_dir / truth.normal_file);
  const ImageF truth_albedo = ReadImageFloat(session_dir / truth.albedo_file);
  PhotometricSolution solution;  // the truth a little off
  solution.normal_in_table = truth_normals;
  solution.albedo = truth_albedo;
  for (size_t i = 0; i < solution.albedo.size(); ++i) {
    solution.albedo.data()[i] *= 1.0f + 0.01f * (i % 7);
    solution.normal_in_table.data()[i] += 0.002f * (i % 5);
  }
  solution.status = ImageU8(kWidth, kHeight, 1, static_cast<uint8_t>(PixelStatus::kSolved));
  GroundTruthEvaluation from_files = SessionGroundTruthEvaluation(session_dir, truth, kWidth, kHeight);
  for (int y = 0; y < kHeight; y += 32) from_files.AddBand(SolutionRows(solution, y, std::min(32, kHeight - y)), 2);
  const GroundTruthComparison comparison = from_files.Finish(2);

  const ImageU8 stored_mask = ReadImageU8(session_dir / truth.mask_file);
  ImageU8 on_sample(kWidth, kHeight, 1);
  for (size_t i = 0; i < on_sample.num_pixels(); ++i) on_sample.data()[i] = stored_mask.data()[i * stored_mask.channels()] > 127;
  const ErrorStatistics angles = AngularErrorDegrees(solution.normal_in_table, truth_normals, on_sample);
  EXPECT_GT(angles.num_pixels, size_t(kWidth) * kHeight / 4);
  EXPECT_EQ(comparison.normal_error_deg.num_pixels, angles.num_pixels);
  EXPECT_EQ(comparison.normal_error_deg.mean, angles.mean);
  EXPECT_EQ(comparison.normal_error_deg.max, angles.max);
  const ErrorStatistics albedo = AbsoluteError(solution.albedo, truth_albedo, on_sample);
  EXPECT_EQ(comparison.albedo_error.mean, albedo.mean);
  EXPECT_EQ(comparison.albedo_color_error.ReportJson(),
            CompareAlbedoColor(solution.albedo, truth_albedo, on_sample).ReportJson());
  EXPECT_EQ(comparison.unsolved_on_sample, 0u);

  WritePng(session_dir / truth.mask_file, ImageU8(kWidth / 2, kHeight, 1, 255), OverwritePolicy::kReplace);
  EXPECT_THAT([&] { SessionGroundTruthEvaluation(session_dir, truth, kWidth, kHeight); },
              ::testing::ThrowsMessage<std::runtime_error>(
                  AllOf(HasSubstr(truth.mask_file), HasSubstr("96x160, the solution is 192x160"))));
}

}  // namespace
}  // namespace scanbench
