#include "app/session/session.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <set>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/io/file_util.h"
#include "tests/app/session/session_test_util.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using testing_util::ErrorMessageOf;
using testing_util::ExpectFieldError;
using testing_util::ExpectSameSession;
using testing_util::FakeRawBytes;
using testing_util::MakeFrameRecord;
using testing_util::MakeTestSession;
using testing_util::ReadText;
using testing_util::TemporaryFolder;
using testing_util::WriteText;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::StartsWith;
using Json = nlohmann::ordered_json;

std::set<std::string> FolderEntries(const fs::path& folder) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder)) names.insert(entry.path().filename().string());
  return names;
}

// ---------------------------------------------------------------------------
// Pure JSON, no files

TEST(SessionJsonTest, RoundTripKeepsEveryField) {
  Session session = MakeTestSession();
  FrameRecord dark = MakeFrameRecord(FrameKind::kDark, -1);
  dark.sha256 = std::string(64, 'a');
  session.frames.push_back(dark);
  FrameRecord led = MakeFrameRecord(FrameKind::kLed, 1);
  led.sha256 = std::string(64, 'b');
  led.exposure_time_s = 1.0 / 3.0;
  session.frames.push_back(led);
  GroundTruthFiles truth;
  truth.normal_file = "ground_truth/normal.exr";
  truth.albedo_file = "ground_truth/albedo.exr";
  truth.height_file = "ground_truth/height.exr";
  truth.mask_file = "ground_truth/mask.png";
  truth.normal_sha256 = truth.albedo_sha256 = truth.height_sha256 = truth.mask_sha256 = std::string(64, 'c');
  truth.mm_per_pixel = 0.1 / 3.0;
  session.ground_truth = truth;
  session.simulation = SimulatedSceneRecord{"twill", "satin", "20240611", 2.4, 1.0 / 3.0, "1554628252", false, true, 25.0};

  const std::string text = SessionToJson(session);
  const Session loaded = SessionFromJson(text, "mem");
  ExpectSameSession(session, loaded);
}

TEST(SessionJsonTest, ResumedSimulationMustMatchTheRecordedScene) {
  Session session = MakeTestSession();
  const SimulatedSceneRecord satin{"twill", "satin", "7", 2.4, 3.0, "9", true, true};
  EXPECT_THAT([&] { CheckResumedSimulation("s/session.json", session, satin); },
              ::testing::ThrowsMessage<SessionError>(HasSubstr("s/session.json: simulation: not recorded")));
  session.simulation = satin;
  EXPECT_NO_THROW(CheckResumedSimulation("s/session.json", session, satin));
  SimulatedSceneRecord other = satin;
  other.material = "lambert";
  EXPECT_THAT([&] { CheckResumedSimulation("s/session.json", session, other); },
              ::testing::ThrowsMessage<SessionError>(
                  HasSubstr("s/session.json: simulation.material: recorded 'satin' but requested 'lambert'")));
  other = satin;
  other.fold_amplitude_mm = 25;  // issue #15: a draped sample's frames do not continue a flat one's
  EXPECT_THAT([&] { CheckResumedSimulation("s/session.json", session, other); },
              ::testing::ThrowsMessage<SessionError>(
                  HasSubstr("s/session.json: simulation.fold_amplitude_mm: recorded '2.5' but requested '25'")));
  other = satin;
  other.cast_shadows = false;
  EXPECT_THAT([&] { CheckResumedSimulation("s/session.json", session, other); },
              ::testing::ThrowsMessage<SessionError>(HasSubstr("simulation.cast_shadows: recorded 'true'")));
  other = satin;
  other.weft_pitch_mm = 1.5;
  EXPECT_THAT([&] { CheckResumedSimulation("s/session.json", session, other); },
              ::testing::ThrowsMessage<SessionError>(HasSubstr("simulation.weft_pitch_mm: recorded '3' but requested '1.5'")));
}

TEST(SessionJsonTest, WritesDocumentedLayout) {
  Session session = MakeTestSession();
  FrameRecord dark = MakeFrameRecord(FrameKind::kDark, -1);
  dark.sha256 = std::string(64, 'a');
  session.frames.push_back(dark);
  FrameRecord led = MakeFrameRecord(FrameKind::kLed, 2);
  led.sha256 = std::string(64, 'b');
  session.frames.push_back(led);
  const Json json = Json::parse(SessionToJson(session));
  EXPECT_EQ(json.begin().key(), "schema_version");  // the first thing a reader needs
  EXPECT_EQ(json["schema_version"], kSessionSchemaVersion);
  EXPECT_EQ(json["capture"]["complete"], false);
  EXPECT_EQ(json["camera"]["settings"]["width"], 6000);
  EXPECT_TRUE(json["rig"]["leds"].is_array());
  EXPECT_FALSE(json.contains("ground_truth"));
  EXPECT_EQ(json["frames"][0]["kind"], "dark");
  EXPECT_FALSE(json["frames"][0].contains("led_index"));
  EXPECT_EQ(json["frames"][1]["kind"], "led");
  EXPECT_EQ(json["frames"][1]["led_index"], 2);
  EXPECT_EQ(json["frames"][1]["file"], "frames/led_02.dng");
}

TEST(SessionJsonTest, DarkFrameAcceptsNullLedIndex) {
  Session session = MakeTestSession();
  FrameRecord dark = MakeFrameRecord(FrameKind::kDark, -1);
  dark.sha256 = std::string(64, 'a');
  session.frames.push_back(dark);
  Json json = Json::parse(SessionToJson(session));
  json["frames"][0]["led_index"] = nullptr;
  EXPECT_EQ(SessionFromJson(json.dump(), "mem").frames[0].led_index, -1);
}

TEST(SessionJsonTest, MissingCaptureBlockMeansComplete) {
  Json json = Json::parse(SessionToJson(MakeTestSession()));
  json.erase("capture");
  // Complete but without frames: the completeness rule must now fire.
  ExpectFieldError(ErrorMessageOf([&] { SessionFromJson(json.dump(), "mem"); }), "mem", "frames", "no dark frame");
}

TEST(SessionJsonTest, CheckRejectsBadCreatedTime) {
  Session session = MakeTestSession();
  session.created = "2024-05-01 12:34";
  ExpectFieldError(ErrorMessageOf([&] { CheckSession(session, "mem"); }), "mem", "created",
                   "\"2024-05-01 12:34\" must be an ISO 8601 UTC time");
}

TEST(SessionJsonTest, CheckRejectsATimeTheClockCannotHold) {
  // Found by fuzzing (tests/fuzz/corpus/session_json/regression-year-4048): a
  // year past 2262 overflowed the conversion to system_clock's nanoseconds.
  Session session = MakeTestSession();
  session.created = "4048-05-01T12:34:56.789Z";
  ExpectFieldError(ErrorMessageOf([&] { CheckSession(session, "mem"); }), "mem", "created",
                   "\"4048-05-01T12:34:56.789Z\" must be an ISO 8601 UTC time like 2024-05-01T12:34:56Z (outside "
                   "1677-09-22 to 2262-04-11, the times the system clock holds)");
  session.created = "0001-01-01T00:00:00Z";
  ExpectFieldError(ErrorMessageOf([&] { CheckSession(session, "mem"); }), "mem", "created", "outside 1677-09-22");
  session.created = "2262-04-10T00:00:00Z";
  EXPECT_NO_THROW(CheckSession(session, "mem"));
}

TEST(SessionJsonTest, CheckRejectsEmptySampleName) {
  Session session = MakeTestSession();
  session.sample_name.clear();
  ExpectFieldError(ErrorMessageOf([&] { CheckSession(session, "mem"); }), "mem", "sample_name", "must not be empty");
}

TEST(SessionJsonTest, FormatsUtcTimestamp) {
  // 2024-05-01T12:34:56Z is 1714566896 s after the epoch.
  const auto time = std::chrono::system_clock::time_point(std::chrono::seconds(1714566896)) +
                    std::chrono::milliseconds(789);
  EXPECT_EQ(FormatUtcTimestamp(time), "2024-05-01T12:34:56.789Z");
}

// ---------------------------------------------------------------------------
// A complete session on disk: frames[0] dark, frames[1..3] LEDs 0..2.

class SessionFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = folder_.path() / "denim-0042";
    CreateSessionFolder(root_);
    session_ = MakeTestSession();
    WriteSessionManifest(root_, session_);
    AddFrame(root_, session_, MakeFrameRecord(FrameKind::kDark, -1), FakeRawBytes(100));
    for (int led = 0; led < static_cast<int>(session_.rig.leds.size()); ++led) {
      AddFrame(root_, session_, MakeFrameRecord(FrameKind::kLed, led), FakeRawBytes(led));
    }
    session_.capture_complete = true;
    WriteSessionManifest(root_, session_);
    pristine_manifest_ = ReadText(root_ / "session.json");
  }

  std::string Manifest() const { return (root_ / "session.json").string(); }

  // Loads after `corrupt` has edited session.json; returns the error message.
  std::string LoadErrorAfter(const std::function<void(Json&)>& corrupt, const SessionLoadOptions& options = {}) {
    Json json = Json::parse(pristine_manifest_);
    corrupt(json);
    WriteText(root_ / "session.json", json.dump(2));
    return ErrorMessageOf([&] { LoadSession(root_, options); });
  }

  TemporaryFolder folder_;
  fs::path root_;
  Session session_;
  std::string pristine_manifest_;
};

TEST_F(SessionFolderTest, WriteThenLoadGivesIdenticalSession) {
  ExpectSameSession(session_, LoadSession(root_));
}

TEST_F(SessionFolderTest, RoundTripWithGroundTruth) {
  fs::create_directories(root_ / "ground_truth");
  GroundTruthFiles truth;
  truth.normal_file = "ground_truth/normal.exr";
  truth.albedo_file = "ground_truth/albedo.exr";
  truth.height_file = "ground_truth/height.exr";
  truth.mask_file = "ground_truth/mask.png";
  WriteText(root_ / truth.normal_file, "normal");
  WriteText(root_ / truth.albedo_file, "albedo");
  WriteText(root_ / truth.height_file, "height");
  WriteText(root_ / truth.mask_file, "mask");
  truth.normal_sha256 = Sha256HexOfFile(root_ / truth.normal_file);
  truth.albedo_sha256 = Sha256HexOfFile(root_ / truth.albedo_file);
  truth.height_sha256 = Sha256HexOfFile(root_ / truth.height_file);
  truth.mask_sha256 = Sha256HexOfFile(root_ / truth.mask_file);
  truth.mm_per_pixel = 0.025;
  session_.ground_truth = truth;
  WriteSessionManifest(root_, session_);
  ExpectSameSession(session_, LoadSession(root_));

  WriteText(root_ / truth.mask_file, "mask, edited");
  ExpectFieldError(ErrorMessageOf([&] { LoadSession(root_); }), Manifest(), "ground_truth.mask.sha256",
                   "mismatch: file ground_truth/mask.png has " + Sha256HexOfFile(root_ / truth.mask_file));
}

TEST_F(SessionFolderTest, FindsFrames) {
  const Session session = LoadSession(root_);
  ASSERT_NE(FindDarkFrame(session), nullptr);
  EXPECT_EQ(FindDarkFrame(session)->file, "frames/dark.dng");
  ASSERT_NE(FindLedFrame(session, 2), nullptr);
  EXPECT_EQ(FindLedFrame(session, 2)->file, "frames/led_02.dng");
  EXPECT_EQ(FindLedFrame(session, 3), nullptr);
  EXPECT_EQ(FindDarkFrame(MakeTestSession()), nullptr);
}

TEST_F(SessionFolderTest, RejectsMissingManifest) {
  fs::remove(root_ / "session.json");
  const std::string message = ErrorMessageOf([&] { LoadSession(root_); });
  EXPECT_THAT(message, StartsWith(Manifest() + ": does not exist"));
}

TEST_F(SessionFolderTest, RejectsBadJsonNamingLineAndColumn) {
  std::string text = ReadText(root_ / "session.json");
  // Drop the comma after the schema version (line 2).
  text.replace(text.find("\"schema_version\": 1,"), 20, "\"schema_version\": 1");
  WriteText(root_ / "session.json", text);
  const std::string message = ErrorMessageOf([&] { LoadSession(root_); });
  // nlohmann stops after the unexpected token, the "sample_name" key on line 3.
  EXPECT_THAT(message, StartsWith(Manifest() + ": line 3, column 15: parse error: syntax error")) << message;
  EXPECT_THAT(message, HasSubstr("expected '}'"));
}

TEST_F(SessionFolderTest, RejectsEmptyManifest) {
  WriteText(root_ / "session.json", "");
  EXPECT_THAT(ErrorMessageOf([&] { LoadSession(root_); }), StartsWith(Manifest() + ": line 1, column 1: parse error"));
}

TEST_F(SessionFolderTest, RejectsNewerSchemaVersion) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["schema_version"] = 2; }), Manifest(), "schema_version",
                   "2 is newer than this scanbench reads (1)");
}

TEST_F(SessionFolderTest, RejectsOlderSchemaVersion) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["schema_version"] = 0; }), Manifest(), "schema_version",
                   "0 is older than this scanbench reads (1)");
}

TEST_F(SessionFolderTest, RejectsMissingSchemaVersion) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json.erase("schema_version"); }), Manifest(), "schema_version",
                   "missing required field");
}

TEST_F(SessionFolderTest, RejectsMissingRequiredField) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][2].erase("sha256"); }), Manifest(),
                   "frames[2].sha256", "missing required field");
}

TEST_F(SessionFolderTest, RejectsWrongType) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["camera"]["settings"]["width"] = "6000"; }), Manifest(),
                   "camera.settings.width", "\"6000\" must be an integer");
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][1]["width"] = 6000.5; }), Manifest(),
                   "frames[1].width", "6000.5 must be an integer");
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["rig"]["leds"][0]["mu"] = "high"; }), Manifest(),
                   "rig.leds[0].mu", "\"high\" must be a number");
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"] = Json::object(); }), Manifest(), "frames",
                   "{} must be an array");
}

TEST_F(SessionFolderTest, RejectsUnknownField) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["groundtruth"] = Json::object(); }), Manifest(),
                   "groundtruth", "unknown field");
}

TEST_F(SessionFolderTest, RejectsUnknownFrameKind) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][0]["kind"] = "flat"; }), Manifest(),
                   "frames[0].kind", "\"flat\" must be \"dark\" or \"led\"");
}

TEST_F(SessionFolderTest, RejectsMissingFrameFile) {
  fs::remove(root_ / "frames/led_01.dng");
  ExpectFieldError(ErrorMessageOf([&] { LoadSession(root_); }), Manifest(), "frames[2].file",
                   "\"frames/led_01.dng\" does not exist in the session folder");
  // Existence is checked even without checksums.
  ExpectFieldError(ErrorMessageOf([&] { LoadSession(root_, {.verify_checksums = false}); }), Manifest(),
                   "frames[2].file", "does not exist");
}

TEST_F(SessionFolderTest, RejectsChecksumMismatch) {
  const fs::path frame = root_ / "frames/led_02.dng";
  fs::permissions(frame, fs::perms::owner_write, fs::perm_options::add);
  WriteText(frame, "bit rot");
  const std::string actual = Sha256HexOfFile(frame);
  ExpectFieldError(ErrorMessageOf([&] { LoadSession(root_); }), Manifest(), "frames[3].sha256",
                   "\"" + session_.frames[3].sha256 + "\" mismatch: file frames/led_02.dng has " + actual);
}

TEST_F(SessionFolderTest, SkipsChecksumsWhenAsked) {
  WriteText(root_ / "frames/led_02.dng", "bit rot");
  EXPECT_NO_THROW(LoadSession(root_, {.verify_checksums = false}));
}

TEST_F(SessionFolderTest, RejectsMalformedChecksum) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][1]["sha256"] = "ABC"; }), Manifest(),
                   "frames[1].sha256", "\"ABC\" must be 64 lower-case hex digits");
}

TEST_F(SessionFolderTest, RejectsTwoFramesForOneLed) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][3]["led_index"] = 0; }), Manifest(),
                   "frames[3].led_index", "0 is already captured by frames[1]");
}

TEST_F(SessionFolderTest, RejectsDuplicateLedIdInRig) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["rig"]["leds"][2]["id"] = 1; }), Manifest(),
                   "rig.leds[2].id", "1 is already used by rig.leds[1]");
}

TEST_F(SessionFolderTest, RejectsLedIndexOutOfRange) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][3]["led_index"] = 3; }), Manifest(),
                   "frames[3].led_index", "3 is out of range: rig.leds has 3 entries");
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][3]["led_index"] = -1; }), Manifest(),
                   "frames[3].led_index", "-1 is out of range");
}

TEST_F(SessionFolderTest, RejectsLedIndexOnDarkFrame) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][0]["led_index"] = 0; }), Manifest(),
                   "frames[0].led_index", "0 must be absent or null for a dark frame");
}

TEST_F(SessionFolderTest, RejectsMissingDarkFrameWhenComplete) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"].erase(0); }), Manifest(), "frames",
                   "no dark frame, but capture.complete is true");
}

TEST_F(SessionFolderTest, RejectsTwoDarkFrames) {
  ExpectFieldError(LoadErrorAfter([](Json& json) {
                     json["frames"][2]["kind"] = "dark";
                     json["frames"][2].erase("led_index");
                   }),
                   Manifest(), "frames[2].kind", "\"dark\" is a second dark frame (the first is frames[0])");
}

TEST_F(SessionFolderTest, RejectsLedWithoutFrameWhenComplete) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"].erase(2); }), Manifest(), "frames",
                   "no frame for rig.leds[1] (id 1), but capture.complete is true");
}

TEST_F(SessionFolderTest, AcceptsIncompleteJournal) {
  const Session session = [&] {
    Json json = Json::parse(ReadText(root_ / "session.json"));
    json["capture"]["complete"] = false;
    json["frames"].erase(2);
    json["frames"].erase(0);
    WriteText(root_ / "session.json", json.dump(2));
    return LoadSession(root_);
  }();
  EXPECT_FALSE(session.capture_complete);
  EXPECT_EQ(FindDarkFrame(session), nullptr);
  EXPECT_EQ(FindLedFrame(session, 1), nullptr);
  EXPECT_NE(FindLedFrame(session, 2), nullptr);
}

TEST_F(SessionFolderTest, RejectsFrameSizeDifferentFromOthers) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][2]["height"] = 3999; }), Manifest(),
                   "frames[2].height", "3999 differs from camera.settings.height 4000");
}

TEST_F(SessionFolderTest, RejectsFrameSizeDifferentFromCameraSettings) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["camera"]["settings"]["width"] = 5000; }), Manifest(),
                   "frames[0].width", "6000 differs from camera.settings.width 5000");
}

TEST_F(SessionFolderTest, RejectsAbsoluteFramePath) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][1]["file"] = "/etc/passwd"; }), Manifest(),
                   "frames[1].file", "\"/etc/passwd\" must be relative to the session folder");
}

TEST_F(SessionFolderTest, RejectsFramePathLeavingSessionFolder) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][1]["file"] = "frames/../../other/led_00.dng"; }),
                   Manifest(), "frames[1].file", "must not leave the session folder");
}

TEST_F(SessionFolderTest, RejectsTwoFramesSharingAFile) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][2]["file"] = "frames/./led_00.dng"; }), Manifest(),
                   "frames[2].file", "is already used by frames[1]");
}

TEST_F(SessionFolderTest, RejectsNonFiniteRigNumber) {
  // JSON has no inf or nan; the only way to write one is a number that
  // overflows a double, which the parser reports where it stands.
  Json json = Json::parse(pristine_manifest_);
  json["rig"]["leds"][1]["position_in_table_mm"][2] = 123456.5;
  std::string text = json.dump(2);
  const size_t offset = text.find("123456.5");
  text.replace(offset, 8, "-1e400");
  WriteText(root_ / "session.json", text);
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + offset, '\n'));
  const int column = static_cast<int>(offset - text.rfind('\n', offset));
  EXPECT_THAT(ErrorMessageOf([&] { LoadSession(root_); }),
              StartsWith(Manifest() + ": line " + std::to_string(line) + ", column " + std::to_string(column) +
                         ": number overflow parsing '-1e400' (numbers must be finite doubles)"));
  // A NaN from code never reaches the disk: RefusesToWriteInvalidSessionAndKeepsOldManifest.
}

TEST_F(SessionFolderTest, RejectsNegativeMu) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["rig"]["leds"][1]["mu"] = -0.5; }), Manifest(),
                   "rig.leds[1].mu", "-0.5 must be finite and >= 0");
}

TEST_F(SessionFolderTest, RejectsZeroLedAxis) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["rig"]["leds"][0]["axis_in_table"] = {0, 0, 0}; }),
                   Manifest(), "rig.leds[0].axis_in_table", "[0,0,0] must be a non-zero direction");
}

TEST_F(SessionFolderTest, RejectsNegativeIntensity) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["rig"]["leds"][2]["rgb_intensity"][1] = -0.01; }),
                   Manifest(), "rig.leds[2].rgb_intensity", "[0.30000000000000004, -0.01, 0.30000000000000004] must be finite and >= 0");
}

TEST_F(SessionFolderTest, RejectsInvalidIntrinsics) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["rig"]["camera"]["intrinsics"]["fx"] = 0; }), Manifest(),
                   "rig.camera.intrinsics", "fx = 0");
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["rig"]["camera"]["intrinsics"]["cx"] = 7000.0; }),
                   Manifest(), "rig.camera.intrinsics", "cx = 7000");
}

TEST_F(SessionFolderTest, RejectsNegativeCameraSetting) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["camera"]["settings"]["iso"] = -100; }), Manifest(),
                   "camera.settings.iso", "-100 must be finite and >= 0");
}

TEST_F(SessionFolderTest, RejectsNonPositiveExposure) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][0]["exposure_time_s"] = 0; }), Manifest(),
                   "frames[0].exposure_time_s", "0 must be finite and > 0");
}

TEST_F(SessionFolderTest, RejectsBadCaptureTime) {
  ExpectFieldError(LoadErrorAfter([](Json& json) { json["frames"][3]["capture_time"] = "2024-05-01T12:35:04"; }),
                   Manifest(), "frames[3].capture_time", "must be an ISO 8601 UTC time");
}

// ---------------------------------------------------------------------------
// Writing

TEST_F(SessionFolderTest, ManifestWriteLeavesNoTemporaryFiles) {
  for (int i = 0; i < 5; ++i) {
    session_.notes = "rewrite " + std::to_string(i);
    WriteSessionManifest(root_, session_);
  }
  EXPECT_EQ(FolderEntries(root_), (std::set<std::string>{"frames", "results", "session.json"}));
  EXPECT_EQ(FolderEntries(root_ / "frames"),
            (std::set<std::string>{"dark.dng", "led_00.dng", "led_01.dng", "led_02.dng"}));
  EXPECT_EQ(LoadSession(root_).notes, "rewrite 4");
}

TEST_F(SessionFolderTest, RefusesToWriteInvalidSessionAndKeepsOldManifest) {
  const std::string before = ReadText(root_ / "session.json");
  Session broken = session_;
  broken.rig.leds[1].mu = std::nan("");
  ExpectFieldError(ErrorMessageOf([&] { WriteSessionManifest(root_, broken); }), Manifest(), "rig.leds[1].mu",
                   "nan must be finite and >= 0");
  EXPECT_EQ(ReadText(root_ / "session.json"), before);
  EXPECT_EQ(FolderEntries(root_), (std::set<std::string>{"frames", "results", "session.json"}));
}

TEST_F(SessionFolderTest, AddFrameRefusesToOverwrite) {
  Session capture = MakeTestSession();  // a second capture aimed at the same folder by mistake
  const std::vector<uint8_t> original = ReadFileBytes(root_ / "frames/led_01.dng");
  const std::string message = ErrorMessageOf(
      [&] { AddFrame(root_, capture, MakeFrameRecord(FrameKind::kLed, 1), FakeRawBytes(42)); });
  ExpectFieldError(message, Manifest(), "frames[0].file",
                   "\"frames/led_01.dng\" already exists with other content and is never overwritten");
  EXPECT_EQ(ReadFileBytes(root_ / "frames/led_01.dng"), original);
  EXPECT_TRUE(capture.frames.empty());
}

TEST_F(SessionFolderTest, AddFrameRejectsRecordBeforeWritingAnything) {
  Session capture = session_;
  capture.capture_complete = false;
  FrameRecord again = MakeFrameRecord(FrameKind::kLed, 1);
  again.file = "frames/led_01_retake.dng";
  ExpectFieldError(ErrorMessageOf([&] { AddFrame(root_, capture, again, FakeRawBytes(7)); }), Manifest(),
                   "frames[4].led_index", "1 is already captured by frames[2]");
  EXPECT_FALSE(fs::exists(root_ / again.file));
  EXPECT_EQ(capture.frames.size(), 4u);

  FrameRecord outside = MakeFrameRecord(FrameKind::kLed, 0);
  outside.file = "led_00.dng";
  Session fresh = MakeTestSession();
  ExpectFieldError(ErrorMessageOf([&] { AddFrame(root_, fresh, outside, FakeRawBytes(7)); }), Manifest(),
                   "frames[0].file", "\"led_00.dng\" must lie in frames/");
  EXPECT_FALSE(fs::exists(root_ / outside.file));
}

TEST(SessionCaptureTest, JournalsEveryFrameAndResumes) {
  TemporaryFolder folder;
  const fs::path root = folder.path() / "s";
  CreateSessionFolder(root);
  Session session = MakeTestSession();
  WriteSessionManifest(root, session);
  AddFrame(root, session, MakeFrameRecord(FrameKind::kDark, -1), FakeRawBytes(100));
  AddFrame(root, session, MakeFrameRecord(FrameKind::kLed, 0), FakeRawBytes(0));

  // The capture process dies here; a new one resumes from the journal.
  Session resumed = LoadSession(root);
  EXPECT_FALSE(resumed.capture_complete);
  ASSERT_EQ(resumed.frames.size(), 2u);
  EXPECT_EQ(resumed.frames[1].sha256, Sha256Hex(FakeRawBytes(0)));

  // Died between writing led_01 and the manifest: the same bytes are adopted.
  WriteFileAtomic(root / "frames/led_01.dng", FakeRawBytes(1), OverwritePolicy::kRefuse);
  AddFrame(root, resumed, MakeFrameRecord(FrameKind::kLed, 1), FakeRawBytes(1));
  AddFrame(root, resumed, MakeFrameRecord(FrameKind::kLed, 2), FakeRawBytes(2));
  resumed.capture_complete = true;
  WriteSessionManifest(root, resumed);
  ExpectSameSession(resumed, LoadSession(root));
}

TEST(SessionCaptureTest, CreateSessionFolderMakesLayoutAndRefusesExistingSession) {
  TemporaryFolder folder;
  const fs::path root = folder.path() / "a" / "b";
  const fs::path made = CreateSessionFolder(root);
  EXPECT_TRUE(made.is_absolute());
  EXPECT_TRUE(fs::is_directory(root / "frames"));
  EXPECT_TRUE(fs::is_directory(root / "results"));
  EXPECT_NO_THROW(CreateSessionFolder(root));  // no session.json yet: harmless
  WriteSessionManifest(root, MakeTestSession());
  EXPECT_THAT(ErrorMessageOf([&] { CreateSessionFolder(root); }),
              StartsWith((root / "session.json").string() + ": already exists"));
}

TEST_F(SessionFolderTest, ReserveResultFolderNeverReusesAFolder) {
  const auto now = std::chrono::system_clock::time_point(std::chrono::seconds(1714566896));
  StagedFolder first = ReserveResultFolder(root_, "default", now);
  EXPECT_EQ(first.final_dir(), root_ / "results" / "20240501T123456Z-default");
  StagedFolder second = ReserveResultFolder(root_, "default", now);
  EXPECT_EQ(second.final_dir(), root_ / "results" / "20240501T123456Z-default-2");
  WriteText(root_ / "results" / "20240501T123456Z-default-3", "a file in the way");
  StagedFolder fourth = ReserveResultFolder(root_, "default", now);
  EXPECT_EQ(fourth.final_dir(), root_ / "results" / "20240501T123456Z-default-4");
  EXPECT_THAT(ListResultFolders(root_), IsEmpty()) << "reserved, not yet results";
  first.Commit();
  fourth.Commit();
  EXPECT_THAT(ListResultFolders(root_), ElementsAre(first.final_dir(), fourth.final_dir()));
  // The real clock works too.
  StagedFolder now_folder = ReserveResultFolder(root_, "default");
  EXPECT_EQ(now_folder.final_dir().parent_path(), root_ / "results");
}

TEST_F(SessionFolderTest, ReserveResultFolderRejectsBadLabelAndNonSession) {
  EXPECT_THAT(ErrorMessageOf([&] { ReserveResultFolder(root_, "../escape"); }),
              HasSubstr("run label \"../escape\" must be 1-64 characters of [A-Za-z0-9._-]"));
  EXPECT_THAT(ErrorMessageOf([&] { ReserveResultFolder(root_, ""); }), HasSubstr("run label \"\""));
  EXPECT_THAT(ErrorMessageOf([&] { ReserveResultFolder(folder_.path(), "default"); }),
              StartsWith((folder_.path() / "session.json").string() + ": does not exist"));
}

}  // namespace
}  // namespace scanbench
