// scanbench import on files the simulated camera wrote, renamed as a camera
// card names them: the imported session solves exactly as the original, and
// every refusal names the file at fault.
#include "app/controllers/import_controller.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <random>

#include "app/controllers/simulate_controller.h"
#include "app/controllers/solve_controller.h"
#include "app/io/dng_writer.h"
#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "app/io/raw_decoder.h"
#include "app/session/session.h"
#include "app/sim/sensor_color.h"
#include "core/cancellation.h"
#include "tests/app/io/test_dng_util.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::TemporaryFolder;

constexpr int kNumLeds = 10;

// One simulated session per test binary: rendering is the slow part.
const fs::path& OriginalSession() {
  static TemporaryFolder* folder = new TemporaryFolder();  // lives to the end of the process
  static const fs::path session_dir = [] {
    const fs::path dir = *folder / "original";
    SimulateOptions options;
    options.rig.width = 240;
    options.rig.height = 160;
    SimulateController(dir, options).Run();
    return dir;
  }();
  return session_dir;
}

const Session& Original() {
  static const Session session = LoadSession(OriginalSession());
  return session;
}

// The original's frame files in capture order: dark, LED 0, 1, ...
std::vector<fs::path> CaptureOrderFiles() {
  std::vector<fs::path> files = {OriginalSession() / FindDarkFrame(Original())->file};
  for (int k = 0; k < kNumLeds; ++k) files.push_back(OriginalSession() / FindLedFrame(Original(), k)->file);
  return files;
}

std::string CardName(int number) {
  char name[32];
  std::snprintf(name, sizeof(name), "DSC_%04d.dng", number);
  return name;
}

// The original's frames copied to `card` as DSC_0001.dng (dark) ...
// DSC_0011.dng, written in a shuffled order so that the folder's own order
// says nothing.
std::vector<fs::path> WriteCard(const fs::path& card) {
  fs::create_directories(card);
  const std::vector<fs::path> originals = CaptureOrderFiles();
  std::vector<int> order(originals.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::shuffle(order.begin(), order.end(), std::mt19937(15));
  std::vector<fs::path> card_files(originals.size());
  for (int i : order) {
    card_files[i] = card / CardName(i + 1);
    fs::copy_file(originals[i], card_files[i]);
  }
  return card_files;
}

RigDescription Rig() { return Original().rig; }

ImportOptions Options() {
  ImportOptions options;
  options.sample_name = "imported twill";
  return options;
}

ImageF SolvedNormals(const fs::path& session_dir) {
  SolveController solve(session_dir, SolveOptions());
  solve.Run();
  return ReadImageFloat(solve.summary().result_dir / "normal.exr");
}

void ExpectSameImage(const ImageF& expected, const ImageF& actual) {
  ASSERT_EQ(actual.width(), expected.width());
  ASSERT_EQ(actual.height(), expected.height());
  ASSERT_EQ(actual.channels(), expected.channels());
  size_t differing = 0;
  for (size_t i = 0; i < expected.size(); ++i) differing += actual.data()[i] != expected.data()[i];
  EXPECT_EQ(differing, 0u) << "of " << expected.size() << " values";
}

// Every file under `folder` with its SHA-256 and size: the source must not change.
std::map<std::string, std::string> Snapshot(const fs::path& folder) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::recursive_directory_iterator(folder)) {
    if (entry.is_regular_file()) files[entry.path().string()] = Sha256HexOfFile(entry.path());
  }
  return files;
}

// Runs an import expected to fail; returns its message.
std::string Refusal(const fs::path& card, const fs::path& session, const ImportOptions& options = Options()) {
  ImportController import(card, session, Rig(), options);
  try {
    import.Run();
  } catch (const std::exception& error) {
    EXPECT_FALSE(fs::exists(session / "session.json")) << "a refused import writes nothing";
    return error.what();
  }
  ADD_FAILURE() << "the import was not refused";
  return "";
}

// A frame re-encoded as another camera (or setting) would have written it.
void Reencode(const fs::path& from, const fs::path& to, const std::function<void(RawImage&, DngMetadata&)>& edit) {
  const DecodedRaw decoded = DecodeRawFileWithInfo(from);
  RawImage raw = decoded.image;
  DngMetadata metadata;
  metadata.model = decoded.model;
  metadata.serial = decoded.serial;
  metadata.exposure_time_s = decoded.exposure_time_s;
  metadata.iso = decoded.iso;
  metadata.f_number = decoded.f_number;
  metadata.camera_from_xyz_d65 = SimulatedCameraFromXyzD65(SensorColorModel::kNikonD5100);
  metadata.as_shot_neutral = SimulatedAsShotNeutral(SensorColorModel::kNikonD5100);
  edit(raw, metadata);
  fs::remove(to);
  WriteDng(to, raw, metadata);
}

// ---- the check: the same solve, exactly -------------------------------

TEST(ImportControllerTest, CardNamesInCaptureOrderSolveExactlyAsTheOriginal) {
  TemporaryFolder folder;
  const std::vector<fs::path> card = WriteCard(folder / "card");
  const auto before = Snapshot(folder / "card");
  ImportController import(folder / "card", folder / "imported", Rig(), Options());
  import.Run();
  const ImportSummary& summary = import.summary();
  EXPECT_EQ(summary.frames_copied, kNumLeds + 1);
  EXPECT_EQ(summary.match, "capture order");
  ASSERT_EQ(summary.frames.size(), size_t(kNumLeds + 1));
  EXPECT_EQ(summary.frames[0].frame, "dark");
  EXPECT_EQ(summary.frames[0].source, card[0].string());
  EXPECT_EQ(summary.frames[4].source, card[4].string());

  // What capture would have written, plus where each frame came from.
  const Session session = LoadSession(folder / "imported");
  EXPECT_TRUE(session.capture_complete);
  ASSERT_TRUE(session.import.has_value());
  EXPECT_EQ(session.import->source_folder, (folder / "card").string());
  EXPECT_EQ(session.camera.model, Original().camera.model);
  EXPECT_EQ(session.camera.serial, Original().camera.serial);
  for (int k = 0; k < kNumLeds; ++k) {
    const FrameRecord* frame = FindLedFrame(session, k);
    ASSERT_NE(frame, nullptr);
    EXPECT_EQ(frame->file, FrameFileName(k, ".dng"));
    EXPECT_EQ(frame->sha256, FindLedFrame(Original(), k)->sha256) << "copied byte for byte";
    EXPECT_EQ(frame->source, card[k + 1].string());
  }
  EXPECT_EQ(Snapshot(folder / "card"), before) << "the source folder is never changed";

  ExpectSameImage(SolvedNormals(OriginalSession()), SolvedNormals(folder / "imported"));
}

// Foreign names that say nothing, re-encoded with camera clock times: the
// capture time alone orders them.
TEST(ImportControllerTest, CaptureTimeOrdersShuffledNamesAndSolvesExactly) {
  TemporaryFolder folder;
  fs::create_directories(folder / "card");
  const std::vector<fs::path> originals = CaptureOrderFiles();
  std::vector<int> numbers(originals.size());
  for (size_t i = 0; i < numbers.size(); ++i) numbers[i] = static_cast<int>(100 + i);
  std::shuffle(numbers.begin(), numbers.end(), std::mt19937(7));
  for (size_t i = 0; i < originals.size(); ++i) {
    Reencode(originals[i], folder / "card" / ("IMG_" + std::to_string(numbers[i]) + ".dng"),
             [&](RawImage&, DngMetadata& metadata) {
               char time[32];
               std::snprintf(time, sizeof(time), "2026:03:14 15:09:%02d", static_cast<int>(2 * i));
               metadata.capture_time = time;
             });
  }
  ImportController import(folder / "card", folder / "imported", Rig(), Options());
  import.Run();
  for (size_t i = 0; i < originals.size(); ++i) {
    EXPECT_EQ(import.summary().frames[i].source,
              (folder / "card" / ("IMG_" + std::to_string(numbers[i]) + ".dng")).string());
  }
  EXPECT_TRUE(import.summary().warnings.empty());
  const Session session = LoadSession(folder / "imported");
  EXPECT_EQ(FindLedFrame(session, 0)->capture_time, "2026-03-14T15:09:02.000Z");
  ExpectSameImage(SolvedNormals(OriginalSession()), SolvedNormals(folder / "imported"));
}

TEST(ImportControllerTest, PatternAndListMatchFramesToLeds) {
  TemporaryFolder folder;
  const std::vector<fs::path> originals = CaptureOrderFiles();
  fs::create_directories(folder / "pattern");
  fs::copy_file(originals[0], folder / "pattern" / "black.dng");
  // 1-digit and 2-digit numbers, written backwards.
  for (int k = kNumLeds - 1; k >= 0; --k) {
    fs::copy_file(originals[k + 1], folder / "pattern" / ("shot-led" + std::to_string(k) + "-x.dng"));
  }
  fs::copy_file(originals[3], folder / "pattern" / "notes-extra.dng");  // matches nothing: not used
  ImportOptions options = Options();
  options.pattern = "shot-led{led}-x";
  options.dark_file = "black.dng";
  ImportController by_pattern(folder / "pattern", folder / "from_pattern", Rig(), options);
  by_pattern.Run();
  EXPECT_EQ(by_pattern.summary().ignored, std::vector<std::string>{"notes-extra.dng"});
  const Session from_pattern = LoadSession(folder / "from_pattern");
  for (int k = 0; k < kNumLeds; ++k)
    EXPECT_EQ(FindLedFrame(from_pattern, k)->sha256, FindLedFrame(Original(), k)->sha256);
  EXPECT_EQ(from_pattern.import->match, "pattern 'shot-led{led}-x'");

  // A list naming the files of a card in any order, the dark frame by path.
  const std::vector<fs::path> card = WriteCard(folder / "card");
  {
    std::ofstream list(folder / "frames.txt");
    list << "# LED index, file\n";
    for (int k = kNumLeds - 1; k >= 0; --k) list << k << " " << card[k + 1].filename().string() << "\n";
    list << "dark " << card[0].string() << "  # by path\n";
  }
  options = Options();
  options.list_file = folder / "frames.txt";
  ImportController by_list(folder / "card", folder / "from_list", Rig(), options);
  by_list.Run();
  const Session from_list = LoadSession(folder / "from_list");
  EXPECT_EQ(FindDarkFrame(from_list)->sha256, FindDarkFrame(Original())->sha256);
  for (int k = 0; k < kNumLeds; ++k) EXPECT_EQ(FindLedFrame(from_list, k)->sha256, FindLedFrame(Original(), k)->sha256);
}

// ---- refusals, each naming the file ----------------------------------------------

TEST(ImportControllerTest, RefusesMixedCameras) {
  TemporaryFolder folder;
  const std::vector<fs::path> card = WriteCard(folder / "card");
  Reencode(card[5], card[5], [](RawImage&, DngMetadata& metadata) { metadata.model = "Other camera"; });
  const std::string message = Refusal(folder / "card", folder / "session");
  EXPECT_THAT(message, HasSubstr(card[5].string() + ": mixed cameras"));
  EXPECT_THAT(message, HasSubstr("Other camera"));
}

TEST(ImportControllerTest, RefusesMixedSizes) {
  TemporaryFolder folder;
  const std::vector<fs::path> card = WriteCard(folder / "card");
  Reencode(card[7], card[7], [](RawImage& raw, DngMetadata&) {
    ImageU16 smaller(raw.width() - 2, raw.height(), 1);
    for (int y = 0; y < smaller.height(); ++y) {
      for (int x = 0; x < smaller.width(); ++x) smaller(x, y) = raw.mosaic(x, y);
    }
    raw.mosaic = smaller;
  });
  EXPECT_THAT(Refusal(folder / "card", folder / "session"),
              HasSubstr(card[7].string() + ": mixed sizes: 238x160 but " + card[0].string()));
}

TEST(ImportControllerTest, RefusesMixedOrientations) {
  TemporaryFolder folder;
  const std::vector<fs::path> card = WriteCard(folder / "card");
  std::vector<uint8_t> bytes = ReadFileBytes(card[2]);
  testing::PatchIfd0Value(bytes, 274, 6);  // Orientation: camera turned 90 deg clockwise
  fs::remove(card[2]);
  WriteFileAtomic(card[2], bytes, OverwritePolicy::kRefuse);
  EXPECT_THAT(Refusal(folder / "card", folder / "session"), HasSubstr(card[2].string() + ": mixed orientations"));
}

TEST(ImportControllerTest, RefusesDifferingIso) {
  TemporaryFolder folder;
  const std::vector<fs::path> card = WriteCard(folder / "card");
  Reencode(card[9], card[9], [](RawImage&, DngMetadata& metadata) { metadata.iso = 400; });
  EXPECT_THAT(Refusal(folder / "card", folder / "session"),
              HasSubstr(card[9].string() + ": differing ISO: 400 but " + card[0].string()));
}

TEST(ImportControllerTest, RefusesAMissingLed) {
  TemporaryFolder folder;
  const std::vector<fs::path> card = WriteCard(folder / "card");
  fs::remove(card.back());
  EXPECT_THAT(Refusal(folder / "card", folder / "session"), HasSubstr("missing LED 9"));

  ImportOptions options = Options();
  options.pattern = "DSC_{led}";  // DSC_0001 -> LED 1 ...; nothing gives LED 0
  options.dark_file = card[0].filename();
  const std::string message = Refusal(folder / "card", folder / "session", options);
  EXPECT_THAT(message, HasSubstr("missing LED 0"));
  EXPECT_THAT(message, HasSubstr("matches the pattern 'DSC_{led}'"));
}

TEST(ImportControllerTest, RefusesDuplicates) {
  TemporaryFolder folder;
  const std::vector<fs::path> card = WriteCard(folder / "card");
  // Two names for LED 3 under the pattern.
  fs::create_directories(folder / "pattern");
  for (int k = 0; k < kNumLeds; ++k)
    fs::copy_file(card[k + 1], folder / "pattern" / ("led_" + std::to_string(k) + ".dng"));
  fs::copy_file(card[0], folder / "pattern" / "dark.dng");
  fs::copy_file(card[4], folder / "pattern" / "led_03.dng");
  ImportOptions options = Options();
  options.pattern = "led_{led}";
  const std::string by_name = Refusal(folder / "pattern", folder / "session", options);
  EXPECT_THAT(by_name, HasSubstr("duplicate: LED 3"));
  EXPECT_THAT(by_name, AnyOf(HasSubstr((folder / "pattern" / "led_03.dng").string()),
                             HasSubstr((folder / "pattern" / "led_3.dng").string())));

  // The same bytes under two names in capture order.
  fs::remove(card[8]);
  fs::copy_file(card[3], card[8]);
  EXPECT_THAT(Refusal(folder / "card", folder / "session"),
              HasSubstr(card[8].string() + ": duplicate: the same bytes as " + card[3].string()));
}

TEST(ImportControllerTest, RefusesJpegs) {
  TemporaryFolder folder;
  const std::vector<fs::path> card = WriteCard(folder / "card");
  const std::vector<uint8_t> jpeg = {0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x10, 'J', 'F', 'I', 'F', 0x00};
  // RAW + JPEG shooting leaves one beside every RAW.
  WriteFileAtomic(folder / "card" / "DSC_0012.JPG", jpeg, OverwritePolicy::kRefuse);
  EXPECT_THAT(Refusal(folder / "card", folder / "session"),
              HasSubstr((folder / "card" / "DSC_0012.JPG").string() + ": is a JPEG, not a RAW file"));
  // A JPEG under a RAW's name is found by its bytes.
  fs::remove(folder / "card" / "DSC_0012.JPG");
  fs::remove(card[6]);
  WriteFileAtomic(card[6], jpeg, OverwritePolicy::kRefuse);
  EXPECT_THAT(Refusal(folder / "card", folder / "session"), HasSubstr(card[6].string() + ": is a JPEG"));
}

TEST(ImportControllerTest, RefusesANonBayerFile) {
  TemporaryFolder folder;
  const std::vector<fs::path> card = WriteCard(folder / "card");
  testing::TestDngOptions linear;
  linear.photometric = 34892;  // LinearRaw: already demosaiced
  linear.samples_per_pixel = 3;
  linear.cfa_pattern.clear();
  fs::remove(card[10]);
  WriteFileAtomic(card[10], testing::MakeTestDng(linear), OverwritePolicy::kRefuse);
  const std::string message = Refusal(folder / "card", folder / "session");
  EXPECT_THAT(message, HasSubstr(card[10].string() + ": "));
  EXPECT_THAT(message, HasSubstr("not a Bayer CFA mosaic"));
}

TEST(ImportControllerTest, RefusesASessionInsideTheRawFolder) {
  TemporaryFolder folder;
  WriteCard(folder / "card");
  EXPECT_THAT(Refusal(folder / "card", folder / "card" / "session"), HasSubstr("must lie outside the RAW folder"));
}

// ---- exposure: a warning, and the solve compensates ------------------------------

// LED 4 taken at half the exposure: its signal above the dark frame halves
// (the light's share; the dark frame's level stays, as for a bench whose dark
// frame holds only the sensor's offset).
void HalveExposure(const fs::path& file, const fs::path& dark_file) {
  const RawImage dark = DecodeRawFile(dark_file);
  Reencode(file, file, [&](RawImage& raw, DngMetadata& metadata) {
    for (int y = 0; y < raw.height(); ++y) {
      for (int x = 0; x < raw.width(); ++x) {
        const int offset = dark.mosaic(x, y);
        raw.mosaic(x, y) = static_cast<uint16_t>(offset + std::lround(0.5 * (raw.mosaic(x, y) - offset)));
      }
    }
    metadata.exposure_time_s *= 0.5;
  });
}

double MeanAngleDeg(const ImageF& a, const ImageF& b) {
  double sum = 0;
  size_t n = 0;
  for (size_t i = 0; i < a.num_pixels(); ++i) {
    const float* p = a.data() + 3 * i;
    const float* q = b.data() + 3 * i;
    // atan2(|p x q|, p . q): exact near 0, where acos of a dot product of
    // half-float (not exactly unit) normals would read ~1 deg for equal ones.
    const double dot = p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
    const double cx = p[1] * q[2] - p[2] * q[1], cy = p[2] * q[0] - p[0] * q[2], cz = p[0] * q[1] - p[1] * q[0];
    sum += std::atan2(std::sqrt(cx * cx + cy * cy + cz * cz), dot) * 180 / 3.14159265358979;
    ++n;
  }
  return sum / n;
}

TEST(ImportControllerTest, DifferingExposureWarnsAndTheSolveCompensates) {
  TemporaryFolder folder;
  const std::vector<fs::path> card = WriteCard(folder / "card");
  HalveExposure(card[5], card[0]);  // LED 4
  ImportController import(folder / "card", folder / "imported", Rig(), Options());
  import.Run();
  ASSERT_EQ(import.summary().warnings.size(), 2u);  // "no capture time" and LED 4's exposure
  EXPECT_THAT(import.summary().warnings[1], HasSubstr(card[5].string() + " (led_04): exposure 0.05 s differs"));
  const Session session = LoadSession(folder / "imported");
  EXPECT_DOUBLE_EQ(FrameExposureScale(session, *FindLedFrame(session, 4)), 2.0);
  EXPECT_EQ(FrameExposureScale(session, *FindLedFrame(session, 3)), 1.0);

  SolveController solve(folder / "imported", SolveOptions());
  solve.Run();
  EXPECT_THAT(solve.summary().warnings, ::testing::Contains(HasSubstr("frames/led_04.dng: exposed 0.05")));
  const ImageF original = SolvedNormals(OriginalSession());
  const ImageF compensated = ReadImageFloat(solve.summary().result_dir / "normal.exr");

  // The same frames recorded as if all had one exposure: LED 4 reads half as bright.
  Session uncompensated = session;
  for (FrameRecord& frame : uncompensated.frames) frame.exposure_time_s = session.camera.exposure_time_s;
  fs::copy(folder / "imported", folder / "uncompensated", fs::copy_options::recursive);
  fs::remove_all(folder / "uncompensated" / "results");
  fs::create_directories(folder / "uncompensated" / "results");
  WriteSessionManifest(folder / "uncompensated", uncompensated);
  const ImageF wrong = SolvedNormals(folder / "uncompensated");

  const double compensated_deg = MeanAngleDeg(original, compensated);
  const double wrong_deg = MeanAngleDeg(original, wrong);
  std::cout << "mean normal difference from the original: compensated " << compensated_deg << " deg, uncompensated "
            << wrong_deg << " deg\n";
  EXPECT_LT(compensated_deg, 0.05) << "only the halved frame's rounding differs";
  EXPECT_GT(wrong_deg, 10 * compensated_deg);
  EXPECT_GT(wrong_deg, 0.5);
}

// ---- interruption ------------------------------------------------------------

TEST(ImportControllerTest, AnInterruptedImportResumesAndLeavesTheSourceAlone) {
  TemporaryFolder folder;
  WriteCard(folder / "card");
  const auto before = Snapshot(folder / "card");
  ImportController first(folder / "card", folder / "imported", Rig(), Options());
  int copies = 0;
  first.SetProgressCallback([&](const ProgressReport& report) {
    if (report.stage == "copy" && !report.detail.empty() && ++copies == 4) first.RequestStop();
  });
  EXPECT_THROW(first.Run(), Cancelled);
  const Session partial = LoadSession(folder / "imported");
  EXPECT_FALSE(partial.capture_complete);
  EXPECT_EQ(partial.frames.size(), 4u);

  // Another folder cannot continue it.
  WriteCard(folder / "other");
  try {
    ImportController(folder / "other", folder / "imported", Rig(), Options()).Run();
    ADD_FAILURE() << "resumed from another folder";
  } catch (const SessionError& error) {
    EXPECT_THAT(error.what(), HasSubstr("not an interrupted import of " + (folder / "other").string()));
  }

  ImportController second(folder / "card", folder / "imported", Rig(), Options());
  second.Run();
  EXPECT_EQ(second.summary().frames_resumed, 4);
  EXPECT_EQ(second.summary().frames_copied, kNumLeds + 1 - 4);
  EXPECT_TRUE(LoadSession(folder / "imported").capture_complete);
  EXPECT_EQ(Snapshot(folder / "card"), before);

  // A complete session is not imported into again.
  try {
    ImportController(folder / "card", folder / "imported", Rig(), Options()).Run();
    ADD_FAILURE() << "imported into a complete session";
  } catch (const SessionError& error) {
    EXPECT_THAT(error.what(), HasSubstr("the session is complete"));
  }
}

TEST(ImportControllerTest, OptionsAreChecked) {
  ImportOptions options = Options();
  options.pattern = "led_";
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options.pattern = "led_{led}";
  options.list_file = "list.txt";
  EXPECT_THROW(options.Check(), std::invalid_argument);
  options = Options();
  options.sample_name.clear();
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
