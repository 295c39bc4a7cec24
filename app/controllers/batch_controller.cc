#include "app/controllers/batch_controller.h"

#include <glob.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

#include "core/format.h"
#include "app/io/file_util.h"
#include "app/session/session.h"
#include "core/field_error.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;

// <prefix>.csv, <prefix>.json: the prefix's name is extended, not its extension replaced.
fs::path SummaryFile(const fs::path& prefix, const char* extension) { return prefix.string() + extension; }

bool IsSessionFolder(const fs::path& path) {
  std::error_code error;
  return fs::is_regular_file(path / "session.json", error);
}

bool HasGlobCharacters(const std::string& text) { return text.find_first_of("*?[") != std::string::npos; }

std::vector<fs::path> ExpandGlob(const std::string& pattern) {
  glob_t matches{};
  const int code = ::glob(pattern.c_str(), 0, nullptr, &matches);
  std::vector<fs::path> paths;
  if (code == 0) {
    for (size_t i = 0; i < matches.gl_pathc; ++i) paths.emplace_back(matches.gl_pathv[i]);
  }
  ::globfree(&matches);
  if (code != 0 && code != GLOB_NOMATCH) {
    throw std::runtime_error("batch input '" + pattern + "': the pattern could not be expanded (glob error " +
                             std::to_string(code) + ")");
  }
  return paths;
}

// A session folder itself, or the session folders directly inside a folder.
std::vector<fs::path> SessionsAt(const fs::path& path) {
  if (IsSessionFolder(path)) return {path};
  std::vector<fs::path> sessions;
  std::error_code error;
  if (fs::is_directory(path, error)) {
    for (const fs::directory_entry& entry : fs::directory_iterator(path)) {
      if (entry.is_directory() && IsSessionFolder(entry.path())) sessions.push_back(entry.path());
    }
  }
  return sessions;
}

// One input: an existing path taken literally, else a glob pattern.
std::vector<fs::path> SessionsOfInput(const std::string& input, const std::string& where) {
  if (input.empty()) throw std::invalid_argument(where + ": empty batch input");
  std::error_code error;
  if (fs::exists(input, error) || !HasGlobCharacters(input)) {
    if (!fs::exists(input, error)) throw std::runtime_error(where + "'" + input + "': no such file or folder");
    std::vector<fs::path> sessions = SessionsAt(input);
    if (sessions.empty()) {
      throw std::runtime_error(where + "'" + input +
                               "': not a session folder (no session.json) and no session folder directly inside it");
    }
    return sessions;
  }
  std::vector<fs::path> sessions;
  for (const fs::path& match : ExpandGlob(input)) {
    for (fs::path& session : SessionsAt(match)) sessions.push_back(std::move(session));
  }
  if (sessions.empty()) throw std::runtime_error(where + "pattern '" + input + "' matches no session folder");
  return sessions;
}

std::string Trim(const std::string& text) {
  const size_t first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return "";
  const size_t last = text.find_last_not_of(" \t\r\n");
  return text.substr(first, last - first + 1);
}

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

// Where a SolveController's stage lies in its whole run (rough shares of a solve's time).
double SolveFraction(const std::string& stage, double fraction) {
  struct Share {
    const char* stage;
    double begin, end;
  };
  static constexpr Share kShares[] = {
      {"load session", 0.0, 0.15}, {"decode RAW", 0.15, 0.6}, {"solve", 0.6, 0.9}, {"write maps", 0.9, 1.0}};
  for (const Share& share : kShares) {
    if (stage == share.stage) return share.begin + (share.end - share.begin) * std::clamp(fraction, 0.0, 1.0);
  }
  return -1;  // an unknown stage keeps the last value
}

// The figures of an existing result, for a skipped session; a report without
// them (an older version's) leaves them unknown rather than failing the session.
void FillFromReport(const fs::path& report_file, BatchSessionResult& result) {
  std::ifstream in(report_file);
  const nlohmann::json report = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (report.is_discarded()) return;
  try {
    result.pixels = report.at("result").at("pixels").get<size_t>();
    result.pixels_solved = report.at("result").at("pixels_by_status").at("solved").get<size_t>();
    if (report.contains("ground_truth")) {
      result.normal_error_mean_deg = report.at("ground_truth").at("normal_angular_error_deg").at("mean").get<double>();
    }
  } catch (const nlohmann::json::exception&) {
  }
}

}  // namespace

void BatchOptions::Check() const {
  solve.Check();
  if (jobs < 1 || jobs > 256) throw FieldError("BatchOptions", "jobs", jobs, "must be in [1, 256]");
  if (threads_per_solve < 0 || threads_per_solve > 256) {
    throw FieldError("BatchOptions", "threads_per_solve", threads_per_solve, "must be in [0, 256] (0 = automatic)");
  }
  if (shard_count < 1 || shard_count > 1000000) {
    throw FieldError("BatchOptions", "shard_count", shard_count, "must be in [1, 1000000]");
  }
  if (shard_index < 1 || shard_index > shard_count) {
    throw FieldError("BatchOptions", "shard_index", shard_index,
                     "must be in [1, shard_count = " + std::to_string(shard_count) + "] (1-based)");
  }
}

const char* BatchStatusName(BatchSessionResult::Status status) {
  switch (status) {
    case BatchSessionResult::Status::kPending: return "pending";
    case BatchSessionResult::Status::kSolved: return "solved";
    case BatchSessionResult::Status::kSkipped: return "skipped";
    case BatchSessionResult::Status::kFailed: return "failed";
    case BatchSessionResult::Status::kCancelled: return "cancelled";
  }
  return "unknown";
}

std::string BatchSummary::Csv() const {
  std::string csv =
      "session,status,seconds,pixels_solved,pixels,normal_error_mean_deg,result_dir,inputs_fingerprint,message\r\n";
  for (const BatchSessionResult& session : sessions) {
    const bool has_pixels = session.pixels > 0;
    const std::vector<std::string> fields = {
        session.session_dir.string(),
        BatchStatusName(session.status),
        Fixed(session.seconds, 3),
        has_pixels ? std::to_string(session.pixels_solved) : "",
        has_pixels ? std::to_string(session.pixels) : "",
        session.normal_error_mean_deg ? Fixed(*session.normal_error_mean_deg, 4) : "",
        session.result_dir.string(),
        session.inputs_fingerprint,
        session.message};
    for (size_t i = 0; i < fields.size(); ++i) {
      if (i > 0) csv += ',';
      csv += CsvField(fields[i]);
    }
    csv += "\r\n";
  }
  return csv;
}

std::string BatchSummary::Json() const {
  nlohmann::json json;
  json["schema"] = "scanbench.batch_summary/1";
  json["software_version"] = "scanbench " SCANBENCH_VERSION;
  json["created"] = FormatUtcTimestamp(std::chrono::system_clock::now());
  json["shard"] = {{"index", shard_index}, {"count", shard_count}, {"sessions_before_shard", sessions_before_shard}};
  json["jobs"] = jobs;
  json["threads_per_solve"] = threads_per_solve;
  json["totals"] = {{"sessions", sessions.size()}, {"solved", solved},   {"skipped", skipped},
                    {"failed", failed},            {"cancelled", cancelled}, {"seconds", seconds}};
  nlohmann::json list = nlohmann::json::array();
  for (const BatchSessionResult& session : sessions) {
    nlohmann::json entry = {{"session", session.session_dir.string()},
                            {"status", BatchStatusName(session.status)},
                            {"seconds", session.seconds},
                            {"result_dir", session.result_dir.empty() ? nlohmann::json() : nlohmann::json(session.result_dir.string())},
                            {"inputs_fingerprint", session.inputs_fingerprint},
                            {"message", session.message}};
    if (session.pixels > 0) {
      entry["pixels"] = session.pixels;
      entry["pixels_solved"] = session.pixels_solved;
    }
    if (session.normal_error_mean_deg) entry["normal_error_mean_deg"] = *session.normal_error_mean_deg;
    list.push_back(std::move(entry));
  }
  json["sessions"] = std::move(list);
  return json.dump(2) + "\n";
}

std::string BatchSummary::Table() const {
  std::ostringstream out;
  out << std::left << std::setw(10) << "status" << std::right << std::setw(9) << "seconds" << std::setw(22)
      << "solved / pixels" << std::setw(11) << "error deg" << "  session\n";
  for (const BatchSessionResult& session : sessions) {
    const std::string pixels =
        session.pixels > 0 ? std::to_string(session.pixels_solved) + " / " + std::to_string(session.pixels) : "-";
    out << std::left << std::setw(10) << BatchStatusName(session.status) << std::right << std::setw(9)
        << Fixed(session.seconds, 2) << std::setw(22) << pixels << std::setw(11)
        << (session.normal_error_mean_deg ? Fixed(*session.normal_error_mean_deg, 3) : "-") << "  "
        << session.session_dir.string();
    if (!session.result_dir.empty()) out << " -> results/" << session.result_dir.filename().string();
    if (session.status == BatchSessionResult::Status::kFailed ||
        session.status == BatchSessionResult::Status::kCancelled) {
      out << "\n" << std::string(10, ' ') << session.message;
    }
    out << "\n";
  }
  out << sessions.size() << " sessions";
  if (shard_count > 1) out << " (shard " << shard_index << "/" << shard_count << " of " << sessions_before_shard << ")";
  out << ": " << solved << " solved, " << skipped << " skipped, " << failed << " failed, " << cancelled
      << " cancelled in " << Fixed(seconds, 1) << " s (jobs " << jobs << ", threads per solve " << threads_per_solve
      << ")\n";
  if (!csv_file.empty()) out << "summary: " << csv_file.string() << ", " << json_file.string() << "\n";
  return out.str();
}

std::vector<fs::path> ResolveBatchSessions(const std::vector<std::string>& inputs,
                                           const std::vector<fs::path>& list_files) {
  std::vector<fs::path> found;
  for (const std::string& input : inputs) {
    for (fs::path& session : SessionsOfInput(input, "")) found.push_back(std::move(session));
  }
  for (const fs::path& list_file : list_files) {
    std::ifstream in(list_file);
    if (!in) throw std::runtime_error(list_file.string() + ": cannot read the list file");
    const fs::path base = fs::absolute(list_file).parent_path();
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
      const std::string entry = Trim(line);
      if (entry.empty() || entry.front() == '#') continue;
      const fs::path path = fs::path(entry).is_absolute() ? fs::path(entry) : base / entry;
      const std::string where = list_file.string() + ": line " + std::to_string(number) + ": ";
      for (fs::path& session : SessionsOfInput(path.string(), where)) found.push_back(std::move(session));
    }
  }
  std::set<fs::path> unique;  // canonical: the same folder reached by two names is one session
  for (const fs::path& session : found) unique.insert(fs::canonical(session));
  return {unique.begin(), unique.end()};
}

std::vector<fs::path> SelectShard(const std::vector<fs::path>& sessions, int shard_index, int shard_count) {
  SCANBENCH_REQUIRE_GE("shard", "count", shard_count, 1);
  if (shard_index < 1 || shard_index > shard_count) {
    throw FieldError("shard", "index", shard_index, "must be in [1, " + std::to_string(shard_count) + "] (1-based)");
  }
  std::vector<fs::path> selected;
  for (size_t i = static_cast<size_t>(shard_index - 1); i < sessions.size(); i += static_cast<size_t>(shard_count)) {
    selected.push_back(sessions[i]);
  }
  return selected;
}

std::pair<int, int> ParseShard(const std::string& text) {
  const size_t slash = text.find('/');
  auto number = [&](const std::string& part) {
    if (part.empty() || part.size() > 7 || part.find_first_not_of("0123456789") != std::string::npos) {
      throw std::invalid_argument("--shard '" + text + "' must be k/N with whole numbers 1 <= k <= N, e.g. 3/8");
    }
    return std::stoi(part);
  };
  if (slash == std::string::npos) number("");
  const int index = number(text.substr(0, slash));
  const int count = number(text.substr(slash + 1));
  if (count < 1 || index < 1 || index > count) {
    throw std::invalid_argument("--shard '" + text + "' must be k/N with 1 <= k <= N (k is 1-based), e.g. 3/8");
  }
  return {index, count};
}

std::optional<fs::path> FindResultWithFingerprint(const fs::path& session_dir, const std::string& fingerprint) {
  std::optional<fs::path> newest;
  for (const fs::path& result : ListResultFolders(session_dir)) {
    std::ifstream in(result / "report.json");
    if (!in) continue;
    const nlohmann::json report = nlohmann::json::parse(in, nullptr, /*allow_exceptions=*/false);
    if (report.is_discarded() || !report.is_object()) continue;
    const auto found = report.find("inputs_fingerprint");
    if (found == report.end() || !found->is_string() || found->get<std::string>() != fingerprint) continue;
    if (!newest || result.filename() > newest->filename()) newest = result;
  }
  return newest;
}

fs::path DefaultBatchSummaryPrefix(const std::vector<fs::path>& sessions,
                                   std::chrono::system_clock::time_point now) {
  if (sessions.empty()) throw std::invalid_argument("batch summary: no sessions to place the summary beside");
  // The deepest folder that holds every session.
  fs::path common = fs::absolute(sessions.front()).lexically_normal().parent_path();
  for (const fs::path& session : sessions) {
    const fs::path parent = fs::absolute(session).lexically_normal().parent_path();
    fs::path shared;
    for (auto a = common.begin(), b = parent.begin(); a != common.end() && b != parent.end() && *a == *b; ++a, ++b) {
      shared /= *a;
    }
    common = shared;
  }
  const fs::path folder = common / "batch-reports";
  fs::create_directories(folder);
  const std::string stamp = FormatUtcTimestamp(now);  // 2024-05-01T12:34:56.789Z
  std::string compact;
  for (char c : stamp.substr(0, 19)) {
    if (c != '-' && c != ':') compact += c;
  }
  const std::string base = "batch-" + compact + "Z";
  for (int n = 1;; ++n) {
    const fs::path prefix = folder / (n == 1 ? base : base + "-" + std::to_string(n));
    if (!fs::exists(prefix.string() + ".csv") && !fs::exists(prefix.string() + ".json")) return prefix;
  }
}

namespace {

// Refused before any work, not after hours of solving: a missing folder, an
// existing file.
void CheckSummaryFilesAreFree(const fs::path& prefix) {
  const fs::path folder = fs::absolute(prefix).parent_path();
  if (!fs::is_directory(folder)) {
    throw std::runtime_error(folder.string() + ": the summary's folder does not exist (--summary " + prefix.string() +
                             ")");
  }
  for (const fs::path& file : {SummaryFile(prefix, ".csv"), SummaryFile(prefix, ".json")}) {
    if (fs::exists(file)) throw std::runtime_error(file.string() + ": exists; a batch summary is never overwritten");
  }
}

// Whether the session still needs a solve: false when it already has a
// result for the same inputs (then it is recorded as skipped) or cannot even
// be read (failed).
bool NeedsSolve(const BatchOptions& options, BatchSessionResult& result) {
  const auto start = Clock::now();
  bool needs_solve = false;
  try {
    SessionLoadOptions quick;
    quick.verify_checksums = false;  // the solve re-hashes; the fingerprint uses the recorded checksums
    const Session session = LoadSession(result.session_dir, quick);
    result.inputs_fingerprint = SolveInputsFingerprint(session, options.solve);
    const std::optional<fs::path> existing =
        options.force ? std::nullopt : FindResultWithFingerprint(result.session_dir, result.inputs_fingerprint);
    if (existing) {
      result.status = BatchSessionResult::Status::kSkipped;
      result.result_dir = *existing;
      result.message = "a result for the same inputs exists";
      FillFromReport(*existing / "report.json", result);
    } else {
      needs_solve = true;
    }
  } catch (const std::exception& error) {
    result.status = BatchSessionResult::Status::kFailed;
    result.message = error.what();
  }
  result.seconds = SecondsSince(start);
  return needs_solve;
}

// The solves that run now: their progress, and where a stop is passed on.
class RunningSolves {
 public:
  explicit RunningSolves(size_t num_sessions) : fractions_(num_sessions, 0.0) {}

  // A stop of the batch that came while `solve` was being set up is passed on at once.
  void Start(size_t index, SolveController* solve, const BaseController& batch) {
    std::lock_guard<std::mutex> lock(mutex_);
    running_[index] = solve;
    if (batch.IsStopRequested()) solve->RequestStop();
  }
  void SetFraction(size_t index, double fraction) {
    std::lock_guard<std::mutex> lock(mutex_);
    fractions_[index] = fraction;
  }
  void Finish(size_t index) {
    std::lock_guard<std::mutex> lock(mutex_);
    running_.erase(index);
    fractions_[index] = 1.0;
    ++finished_;
  }
  void StopAll() {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto& [index, solve] : running_) solve->RequestStop();
  }
  // The fraction of `indices` done (finished count whole, running ones by
  // their own progress) and how many finished.
  std::pair<double, size_t> Progress(const std::vector<size_t>& indices) const {
    std::lock_guard<std::mutex> lock(mutex_);
    double done = 0;
    for (size_t index : indices) done += fractions_[index];
    return {done / static_cast<double>(indices.size()), finished_};
  }

 private:
  mutable std::mutex mutex_;
  std::map<size_t, SolveController*> running_;
  std::vector<double> fractions_;
  size_t finished_ = 0;
};

// One session through SolveController; its outcome goes into `result`, never
// thrown.
void SolveOneSession(const SolveOptions& options, size_t index, const BaseController& batch, RunningSolves& running,
                     BatchSessionResult& result) {
  const auto start = Clock::now();
  SolveController solve(result.session_dir, options);
  solve.SetProgressCallback([&running, index](const ProgressReport& report) {
    const double overall = SolveFraction(report.stage, report.fraction);
    if (overall >= 0) running.SetFraction(index, overall);
  });
  running.Start(index, &solve, batch);
  try {
    solve.Run();
    const SolveSummary& solved = solve.summary();
    result.status = BatchSessionResult::Status::kSolved;
    result.result_dir = solved.result_dir;
    result.inputs_fingerprint = solved.inputs_fingerprint;
    result.pixels = solved.solver.num_pixels;
    result.pixels_solved = solved.solver.num_solved();
    if (solved.normal_error_deg) result.normal_error_mean_deg = solved.normal_error_deg->mean;
    result.message = solved.solver.BriefReport();
    for (const std::string& warning : solved.warnings) result.message += "; warning: " + warning;
  } catch (const Cancelled& cancelled) {
    result.status = BatchSessionResult::Status::kCancelled;
    result.message = std::string(cancelled.what()) + "; no result folder was written";
  } catch (const std::exception& error) {
    result.status = BatchSessionResult::Status::kFailed;
    result.message = error.what();
  }
  result.seconds = SecondsSince(start);
  running.Finish(index);
}

// Sessions never started count as cancelled; the totals.
void CountOutcomes(BatchSummary& summary) {
  for (BatchSessionResult& result : summary.sessions) {
    if (result.status == BatchSessionResult::Status::kPending) {
      result.status = BatchSessionResult::Status::kCancelled;
      result.message = "not started: the batch was cancelled";
    }
    switch (result.status) {
      case BatchSessionResult::Status::kSolved: ++summary.solved; break;
      case BatchSessionResult::Status::kSkipped: ++summary.skipped; break;
      case BatchSessionResult::Status::kFailed: ++summary.failed; break;
      default: ++summary.cancelled; break;
    }
  }
}

}  // namespace

BatchController::BatchController(std::vector<fs::path> sessions, BatchOptions options)
    : sessions_(std::move(sessions)), options_(std::move(options)) {}

void BatchController::Run() {
  options_.Check();
  const auto batch_start = Clock::now();
  summary_ = BatchSummary();
  if (!options_.summary_prefix.empty()) CheckSummaryFilesAreFree(options_.summary_prefix);
  summary_.sessions_before_shard = sessions_.size();
  summary_.shard_index = options_.shard_index;
  summary_.shard_count = options_.shard_count;
  for (const fs::path& session : SelectShard(sessions_, options_.shard_index, options_.shard_count)) {
    summary_.sessions.emplace_back().session_dir = session;
  }
  SolveSessions(SessionsToSolve());
  CountOutcomes(summary_);
  summary_.seconds = SecondsSince(batch_start);
  if (!options_.summary_prefix.empty()) {
    summary_.csv_file = SummaryFile(options_.summary_prefix, ".csv");
    summary_.json_file = SummaryFile(options_.summary_prefix, ".json");
    WriteFileAtomic(summary_.csv_file, summary_.Csv(), OverwritePolicy::kRefuse);
    WriteFileAtomic(summary_.json_file, summary_.Json(), OverwritePolicy::kRefuse);
  }
  if (summary_.cancelled > 0) throw Cancelled("batch");
}

std::vector<size_t> BatchController::SessionsToSolve() {
  std::vector<BatchSessionResult>& results = summary_.sessions;
  std::vector<size_t> to_solve;
  for (size_t i = 0; i < results.size(); ++i) {
    ReportProgress("check results", double(i) / std::max<size_t>(results.size(), 1),
                   std::to_string(i) + "/" + std::to_string(results.size()));
    if (IsStopRequested()) break;
    if (NeedsSolve(options_, results[i])) to_solve.push_back(i);
  }
  return to_solve;
}

void BatchController::SolveSessions(const std::vector<size_t>& to_solve) {
  const int hardware = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  const int jobs = std::max(1, std::min<int>(options_.jobs, static_cast<int>(to_solve.size())));
  summary_.jobs = jobs;
  summary_.threads_per_solve = options_.threads_per_solve > 0 ? options_.threads_per_solve : std::max(1, hardware / jobs);
  if (to_solve.empty()) return;
  SolveOptions solve_options = options_.solve;
  solve_options.solver.num_threads = summary_.threads_per_solve;

  // `jobs` workers take the next session; this thread reports progress and
  // passes a stop request on to the running solves.
  RunningSolves running(summary_.sessions.size());
  std::atomic<size_t> next{0};
  std::atomic<int> workers_left{jobs};
  const auto solve_start = Clock::now();
  std::vector<std::thread> workers;
  for (int w = 0; w < jobs; ++w) {
    workers.emplace_back([&] {
      for (size_t k = next++; k < to_solve.size() && !IsStopRequested(); k = next++) {
        SolveOneSession(solve_options, to_solve[k], *this, running, summary_.sessions[to_solve[k]]);
      }
      --workers_left;
    });
  }
  while (workers_left > 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const auto [fraction, finished] = running.Progress(to_solve);
    const double elapsed = SecondsSince(solve_start);
    const std::string eta = fraction > 0.01 ? FormatDuration(elapsed * (1 - fraction) / fraction) : "--:--";
    ReportProgress("solve sessions", fraction,
                   std::to_string(finished) + "/" + std::to_string(to_solve.size()) + " done, ETA " + eta);
    if (IsStopRequested()) running.StopAll();  // also one requested from the progress callback just now
  }
  for (std::thread& worker : workers) worker.join();
}

}  // namespace scanbench
