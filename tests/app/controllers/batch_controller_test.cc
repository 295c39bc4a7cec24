// scanbench batch (issue #7): many sessions solved through SolveController,
// resumed by inputs fingerprint, one failure reported while the rest finish.
#include "app/controllers/batch_controller.h"

#include <algorithm>
#include <fstream>
#include <iterator>
#include <memory>
#include <set>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "app/controllers/simulate_controller.h"
#include "app/io/file_util.h"
#include "app/session/session.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using testing::TemporaryFolder;
using Status = BatchSessionResult::Status;

// One small simulated session, rendered once and copied for every test.
class BatchControllerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    source_folder_ = new TemporaryFolder;
    SimulateOptions options;
    options.rig.width = 96;
    options.rig.height = 64;
    options.rig.num_threads = 2;
    SimulateController(*source_folder_ / "session", options).Run();
  }
  static void TearDownTestSuite() {
    delete source_folder_;
    source_folder_ = nullptr;
  }

  // count copies named library/s00, s01, ... (sorted = numbered).
  std::vector<fs::path> CopySessions(int count) {
    std::vector<fs::path> sessions;
    for (int i = 0; i < count; ++i) {
      const fs::path copy = folder_ / "library" / ((i < 10 ? "s0" : "s") + std::to_string(i));
      fs::create_directories(copy.parent_path());
      fs::copy(*source_folder_ / "session", copy, fs::copy_options::recursive);
      sessions.push_back(fs::canonical(copy));
    }
    return sessions;
  }

  static BatchOptions SmallBatch() {
    BatchOptions options;
    options.jobs = 2;
    options.threads_per_solve = 1;
    return options;
  }

  static TemporaryFolder* source_folder_;
  TemporaryFolder folder_;
};
TemporaryFolder* BatchControllerTest::source_folder_ = nullptr;

// Every results/ entry, hidden ones (a solve's staging folder) included.
std::vector<fs::path> ResultEntries(const fs::path& session_dir) {
  std::vector<fs::path> entries;
  if (!fs::exists(session_dir / "results")) return entries;
  for (const auto& entry : fs::directory_iterator(session_dir / "results")) entries.push_back(entry.path());
  std::sort(entries.begin(), entries.end());
  return entries;
}

void FlipByte(const fs::path& file) {
  std::vector<uint8_t> bytes = ReadFileBytes(file);
  bytes[bytes.size() / 2] ^= 0xFF;
  std::ofstream(file, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(bytes.data()),
                                                                static_cast<std::streamsize>(bytes.size()));
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

const BatchSessionResult& ResultOf(const BatchSummary& summary, const fs::path& session) {
  for (const BatchSessionResult& result : summary.sessions) {
    if (result.session_dir == session) return result;
  }
  throw std::runtime_error("no result for " + session.string());
}

// The done-when: 20 sessions, one corrupt; then a rerun skips the 19.
TEST_F(BatchControllerTest, OneCorruptSessionFailsTheOthersFinishAndARerunSkipsThem) {
  const std::vector<fs::path> sessions = CopySessions(20);
  const fs::path corrupt = sessions[7];
  FlipByte(corrupt / "frames" / "led_03.dng");

  BatchOptions options = SmallBatch();
  options.summary_prefix = folder_ / "first";
  BatchController first(sessions, options);
  first.Run();
  const BatchSummary& summary = first.summary();
  ASSERT_EQ(summary.sessions.size(), 20u);
  EXPECT_EQ(summary.solved, 19);
  EXPECT_EQ(summary.failed, 1);
  EXPECT_EQ(summary.skipped, 0);
  EXPECT_EQ(summary.cancelled, 0);
  const BatchSessionResult& failed = ResultOf(summary, corrupt);
  EXPECT_EQ(failed.status, Status::kFailed);
  EXPECT_THAT(failed.message, HasSubstr("frames/led_03.dng"));
  EXPECT_THAT(failed.message, HasSubstr("mismatch"));
  EXPECT_TRUE(ResultEntries(corrupt).empty()) << "a failed solve leaves nothing behind";

  std::map<fs::path, fs::path> first_results;
  for (const BatchSessionResult& result : summary.sessions) {
    if (result.session_dir == corrupt) continue;
    EXPECT_EQ(result.status, Status::kSolved) << result.session_dir << ": " << result.message;
    ASSERT_EQ(ResultEntries(result.session_dir), std::vector<fs::path>{result.result_dir});
    const nlohmann::json report = nlohmann::json::parse(ReadText(result.result_dir / "report.json"));
    EXPECT_EQ(report["inputs_fingerprint"], result.inputs_fingerprint);
    EXPECT_EQ(result.pixels, 96u * 64u);
    EXPECT_GT(result.pixels_solved, 96u * 64u / 2);
    ASSERT_TRUE(result.normal_error_mean_deg.has_value());
    EXPECT_LT(*result.normal_error_mean_deg, 10.0);
    first_results[result.session_dir] = result.result_dir;
  }
  // The copies are the same capture: the same inputs, the same fingerprint.
  EXPECT_EQ(summary.sessions[0].inputs_fingerprint, summary.sessions[19].inputs_fingerprint);

  // The summary files: a header and one row per session; JSON totals.
  ASSERT_EQ(summary.csv_file, fs::path(folder_ / "first.csv"));
  const std::string csv = ReadText(folder_ / "first.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 21);
  EXPECT_THAT(csv, HasSubstr("session,status,seconds,pixels_solved,pixels,normal_error_mean_deg"));
  EXPECT_THAT(csv, HasSubstr(corrupt.string() + ",failed,"));
  EXPECT_THAT(csv, HasSubstr(sessions[8].string() + ",solved,"));
  const nlohmann::json json = nlohmann::json::parse(ReadText(folder_ / "first.json"));
  EXPECT_EQ(json["schema"], "scanbench.batch_summary/1");
  EXPECT_EQ(json["totals"]["solved"], 19);
  EXPECT_EQ(json["totals"]["failed"], 1);
  ASSERT_EQ(json["sessions"].size(), 20u);
  EXPECT_EQ(json["sessions"][7]["status"], "failed");
  EXPECT_THAT(json["sessions"][7]["message"].get<std::string>(), HasSubstr("led_03.dng"));
  EXPECT_EQ(json["sessions"][8]["pixels"], 96 * 64);
  EXPECT_THAT(summary.Table(), HasSubstr("19 solved, 0 skipped, 1 failed"));

  // Rerun: the 19 are skipped with their existing result, the corrupt one fails again.
  options.summary_prefix = folder_ / "second";
  BatchController second(sessions, options);
  second.Run();
  EXPECT_EQ(second.summary().skipped, 19);
  EXPECT_EQ(second.summary().failed, 1);
  EXPECT_EQ(second.summary().solved, 0);
  for (const auto& [session, result_dir] : first_results) {
    const BatchSessionResult& result = ResultOf(second.summary(), session);
    EXPECT_EQ(result.status, Status::kSkipped);
    EXPECT_EQ(result.result_dir, result_dir);
    EXPECT_EQ(result.pixels, 96u * 64u) << "figures read back from the existing report";
    EXPECT_TRUE(result.normal_error_mean_deg.has_value());
    EXPECT_EQ(ResultEntries(session), std::vector<fs::path>{result_dir}) << "no new result folder";
  }
  EXPECT_TRUE(ResultEntries(corrupt).empty());

  // The summary of a batch is never overwritten: refused before any work.
  EXPECT_THROW(BatchController(sessions, options).Run(), std::runtime_error);
}

TEST_F(BatchControllerTest, ForceAndChangedOptionsSolveAgainBesideTheOldResult) {
  const std::vector<fs::path> sessions = CopySessions(2);
  BatchController(sessions, SmallBatch()).Run();
  std::map<fs::path, fs::path> old_results;
  std::map<fs::path, std::string> old_reports;
  for (const fs::path& session : sessions) {
    ASSERT_EQ(ResultEntries(session).size(), 1u);
    old_results[session] = ResultEntries(session)[0];
    old_reports[session] = Sha256HexOfFile(old_results[session] / "report.json");
  }

  // Another thread count and run label: the same inputs, still skipped.
  BatchOptions other_threads = SmallBatch();
  other_threads.jobs = 1;
  other_threads.threads_per_solve = 2;
  other_threads.solve.run_label = "relabelled";
  BatchController skipped(sessions, other_threads);
  skipped.Run();
  EXPECT_EQ(skipped.summary().skipped, 2);

  // --force: a new folder beside the old, the old untouched.
  BatchOptions force = SmallBatch();
  force.force = true;
  BatchController forced(sessions, force);
  forced.Run();
  EXPECT_EQ(forced.summary().solved, 2);
  for (const fs::path& session : sessions) {
    EXPECT_EQ(ResultEntries(session).size(), 2u);
    EXPECT_EQ(Sha256HexOfFile(old_results[session] / "report.json"), old_reports[session]);
    EXPECT_NE(ResultOf(forced.summary(), session).result_dir, old_results[session]);
  }

  // A changed solver option changes the inputs: solved, not skipped.
  BatchOptions changed = SmallBatch();
  changed.solve.solver.min_sample_value = 0.004;
  BatchController resolved(sessions, changed);
  resolved.Run();
  EXPECT_EQ(resolved.summary().solved, 2);
  EXPECT_NE(resolved.summary().sessions[0].inputs_fingerprint, forced.summary().sessions[0].inputs_fingerprint);
  for (const fs::path& session : sessions) EXPECT_EQ(ResultEntries(session).size(), 3u);
}

TEST_F(BatchControllerTest, CancelStopsTheBatchAndMarksTheRest) {
  const std::vector<fs::path> sessions = CopySessions(8);
  BatchOptions options = SmallBatch();
  options.jobs = 1;
  options.summary_prefix = folder_ / "cancelled";
  BatchController batch(sessions, options);
  // Stop as soon as the solving shows progress: the first session is running then.
  batch.SetProgressCallback([&batch](const ProgressReport& report) {
    if (report.stage == "solve sessions" && report.fraction > 0) batch.RequestStop();
  });
  EXPECT_THROW(batch.Run(), Cancelled);
  const BatchSummary& summary = batch.summary();
  ASSERT_EQ(summary.sessions.size(), 8u);
  EXPECT_GE(summary.cancelled, 1);
  EXPECT_EQ(summary.solved + summary.cancelled, 8);
  EXPECT_EQ(summary.failed, 0);
  for (const BatchSessionResult& result : summary.sessions) {
    const std::vector<fs::path> entries = ResultEntries(result.session_dir);
    if (result.status == Status::kSolved) {
      EXPECT_EQ(entries, std::vector<fs::path>{result.result_dir});
    } else {
      EXPECT_EQ(result.status, Status::kCancelled);
      EXPECT_TRUE(entries.empty()) << "no partial result folder in " << result.session_dir;
      EXPECT_TRUE(result.result_dir.empty());
    }
  }
  // The last session was never started, and the summary still was written.
  EXPECT_EQ(summary.sessions.back().status, Status::kCancelled);
  EXPECT_THAT(summary.sessions.back().message, HasSubstr("not started"));
  const nlohmann::json json = nlohmann::json::parse(ReadText(folder_ / "cancelled.json"));
  EXPECT_EQ(json["totals"]["cancelled"], summary.cancelled);
}

TEST(BatchShardTest, ShardsPartitionTheListStablyAndEvenly) {
  std::vector<fs::path> sessions;
  for (int i = 0; i < 23; ++i) sessions.push_back("/lib/s" + std::to_string(100 + i));
  for (int count = 1; count <= 5; ++count) {
    std::multiset<fs::path> all;
    for (int index = 1; index <= count; ++index) {
      const std::vector<fs::path> shard = SelectShard(sessions, index, count);
      EXPECT_EQ(shard, SelectShard(sessions, index, count)) << "stable";
      EXPECT_LE(shard.size(), 23u / count + 1) << "balanced";
      EXPECT_GE(shard.size(), 23u / count);
      all.insert(shard.begin(), shard.end());
    }
    EXPECT_EQ(all, std::multiset<fs::path>(sessions.begin(), sessions.end())) << "disjoint, together all, N=" << count;
  }
  EXPECT_EQ(SelectShard(sessions, 2, 8), (std::vector<fs::path>{"/lib/s101", "/lib/s109", "/lib/s117"}));

  EXPECT_EQ(ParseShard("3/8"), std::make_pair(3, 8));
  for (const char* bad : {"0/8", "9/8", "3", "a/8", "3/", "-1/8", "1/0"}) {
    EXPECT_THROW(ParseShard(bad), std::invalid_argument) << bad;
  }
  try {
    ParseShard("9/8");
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(), HasSubstr("'9/8'"));
    EXPECT_THAT(error.what(), HasSubstr("1-based"));
  }
  BatchOptions options;
  options.shard_index = 0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
}

TEST_F(BatchControllerTest, InputsArePathsGlobsAndListFilesWithoutDuplicates) {
  const std::vector<fs::path> sessions = CopySessions(3);  // library/s00 s01 s02
  const fs::path library = folder_ / "library";
  fs::create_directories(library / "notes");  // not a session: ignored when a folder or pattern is searched

  // A folder of sessions (one level), a glob, a duplicate by another name.
  EXPECT_EQ(ResolveBatchSessions({library.string()}, {}), sessions);
  EXPECT_EQ(ResolveBatchSessions({(library / "s0[12]").string(), (library / "s01" / ".").string()}, {}),
            (std::vector<fs::path>{sessions[1], sessions[2]}));

  // A list file: comments, blank lines, relative paths against its folder, a pattern.
  const fs::path list = folder_ / "lists" / "lib.txt";
  fs::create_directories(list.parent_path());
  std::ofstream(list) << "# the library\n\n  ../library/s02  \n" << sessions[0].string() << "\n../library/s0*\n";
  EXPECT_EQ(ResolveBatchSessions({}, {list}), sessions);

  // Inputs that match nothing are errors naming them.
  try {
    ResolveBatchSessions({(library / "nothing*").string()}, {});
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& error) {
    EXPECT_THAT(error.what(), HasSubstr("nothing*"));
  }
  EXPECT_THROW(ResolveBatchSessions({(library / "notes").string()}, {}), std::runtime_error);
  EXPECT_THROW(ResolveBatchSessions({(library / "missing").string()}, {}), std::runtime_error);
  std::ofstream(list, std::ios::app) << "missing_session\n";
  try {
    ResolveBatchSessions({}, {list});
    ADD_FAILURE() << "expected an error";
  } catch (const std::runtime_error& error) {
    EXPECT_THAT(error.what(), HasSubstr("lib.txt: line 6"));
    EXPECT_THAT(error.what(), HasSubstr("missing_session"));
  }
}

// The default summary goes beside the library, in a batch-reports/ folder
// created for it, under a name whose .csv and .json are both free.
TEST(BatchSummaryPrefixTest, DefaultIsBesideTheSessionsAndNeverTaken) {
  TemporaryFolder folder;
  const fs::path library = fs::canonical(folder.path()) / "library";
  const std::vector<fs::path> sessions = {library / "a" / "s1", library / "a" / "s2", library / "b" / "s3"};
  const auto time = std::chrono::sys_days(std::chrono::year(2026) / 11 / 22) + std::chrono::hours(11) +
                    std::chrono::minutes(2) + std::chrono::seconds(12);
  const fs::path first = DefaultBatchSummaryPrefix(sessions, time);
  EXPECT_EQ(first, library / "batch-reports" / "batch-20261122T110212Z");
  EXPECT_TRUE(fs::is_directory(library / "batch-reports"));
  std::ofstream(first.string() + ".json") << "{}";
  EXPECT_EQ(DefaultBatchSummaryPrefix(sessions, time), library / "batch-reports" / "batch-20261122T110212Z-2");
  EXPECT_EQ(DefaultBatchSummaryPrefix({library / "a" / "s1"}, time).parent_path(), library / "a" / "batch-reports");
  EXPECT_THROW(DefaultBatchSummaryPrefix({}, time), std::invalid_argument);
}

TEST_F(BatchControllerTest, FingerprintCoversResultInputsOnly) {
  const Session session = LoadSession(*source_folder_ / "session");
  const SolveOptions defaults;
  SolveOptions threads_and_label;
  threads_and_label.solver.num_threads = 7;
  threads_and_label.run_label = "other";
  threads_and_label.verify_checksums = false;
  EXPECT_EQ(SolveInputsFingerprint(session, defaults), SolveInputsFingerprint(session, threads_and_label));
  EXPECT_EQ(SolveInputsFingerprint(session, defaults).size(), 64u);

  SolveOptions method;
  method.solver.method = PhotometricSolverOptions::Method::kQr;
  SolveOptions demosaic;
  demosaic.develop.demosaic = RawDevelopOptions::Demosaic::kBilinear;
  Session other_frame = session;
  other_frame.frames[3].sha256[0] = other_frame.frames[3].sha256[0] == 'a' ? 'b' : 'a';
  Session other_rig = session;
  other_rig.rig.leds[0].position_in_table_mm.x() += 1;
  const std::string fingerprint = SolveInputsFingerprint(session, defaults);
  EXPECT_NE(SolveInputsFingerprint(session, method), fingerprint);
  EXPECT_NE(SolveInputsFingerprint(session, demosaic), fingerprint);
  EXPECT_NE(SolveInputsFingerprint(other_frame, defaults), fingerprint);
  EXPECT_NE(SolveInputsFingerprint(other_rig, defaults), fingerprint);
  SolveOptions no_depth;  // issue #15: the depth-aware re-solves change the result
  no_depth.depth.enabled = false;
  EXPECT_NE(SolveInputsFingerprint(session, no_depth), fingerprint);
  // Issue #13: the Bayer blend, the default, is recorded as 4 since the
  // shared lobe's raw re-solve (3 since the gate, 2 before it, the opt-in
  // blend before that true); without it the text
  // has no key, as the results from before the blend.
  SolveOptions no_blend;
  no_blend.bayer_blend = false;
  EXPECT_NE(SolveInputsFingerprint(session, no_blend), fingerprint);
  EXPECT_THAT(SolveInputsCanonicalText(session, defaults), HasSubstr("\"bayer_blend\":4"));
  EXPECT_THAT(SolveInputsCanonicalText(session, no_blend), ::testing::Not(HasSubstr("bayer_blend")));
  EXPECT_THAT(SolveInputsCanonicalText(session, defaults), HasSubstr(session.frames[3].sha256));
  EXPECT_THAT(SolveInputsCanonicalText(session, defaults), HasSubstr("scanbench " SCANBENCH_VERSION));
}

}  // namespace
}  // namespace scanbench
