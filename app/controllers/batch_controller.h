// Re-solves many sessions (issue #7, `scanbench batch`): a few at a time, each
// through SolveController; a session that already has a result for the same
// inputs (SolveInputsFingerprint) is skipped unless forced; one that fails is
// reported and the others finish. The summary lists every session and is
// written as CSV and JSON. docs/batch.md is the user's description.
#pragma once

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "app/controllers/base_controller.h"
#include "app/controllers/solve_controller.h"

namespace scanbench {

struct BatchOptions {
  SolveOptions solve;          // applied to every session; its solver.num_threads is replaced by threads_per_solve
  int jobs = 1;                // sessions solved at the same time, [1, 256]; a full-resolution solve holds ~2 GB
  int threads_per_solve = 0;   // solver threads of each session, [0, 256]; 0 = hardware threads / jobs (>= 1)
  bool force = false;          // solve again (into a new result folder) even when a result for the same inputs exists
  int shard_index = 1;         // which shard this run solves, [1, shard_count]
  int shard_count = 1;         // shards the sorted session list is dealt into, [1, 1000000]
  // Writes <prefix>.csv and <prefix>.json at the end (also when cancelled);
  // an existing file is refused before any work. Empty = write none (the CLI
  // defaults it to DefaultBatchSummaryPrefix).
  std::filesystem::path summary_prefix;

  void Check() const;  // throws std::invalid_argument naming the field
};

struct BatchSessionResult {
  enum class Status { kPending, kSolved, kSkipped, kFailed, kCancelled };
  std::filesystem::path session_dir;
  Status status = Status::kPending;
  std::filesystem::path result_dir;    // the new result (solved) or the existing one with the same inputs (skipped)
  std::string message;                 // the error (failed), or what happened
  double seconds = 0;                  // wall time of its solve (or of the check, when skipped)
  std::string inputs_fingerprint;      // "" when the session could not be read
  size_t pixels = 0;                   // pixels of the image
  size_t pixels_solved = 0;
  std::optional<double> normal_error_mean_deg;  // on the sample, when the session has ground truth
};
// "pending", "solved", "skipped", "failed", "cancelled".
const char* BatchStatusName(BatchSessionResult::Status status);

struct BatchSummary {
  std::vector<BatchSessionResult> sessions;  // this shard's, in batch order
  size_t sessions_before_shard = 0;
  int shard_index = 1, shard_count = 1;
  int jobs = 1, threads_per_solve = 1;
  int solved = 0, skipped = 0, failed = 0, cancelled = 0;
  double seconds = 0;                        // wall time of the whole batch
  std::filesystem::path csv_file, json_file;  // written summary files, empty if none

  // Columns: session, status, seconds, pixels_solved, pixels, normal_error_mean_deg,
  // result_dir, inputs_fingerprint, message. RFC 4180 quoting; empty = not known.
  std::string Csv() const;
  // schema "scanbench.batch_summary/1": totals, options, one object per session.
  std::string Json() const;
  std::string Table() const;  // human-readable table with a totals line, for the terminal
};

// The batch's sessions from command-line inputs, sorted by canonical path and
// without duplicates. Each input is a path or a glob(3) pattern (expanded
// here, so quoted patterns work) naming either a session folder (holding
// session.json) or a folder whose direct subfolders holding session.json are
// taken (one level, not deeper). `list_files`: one input per line, blank lines
// and lines starting with '#' ignored, relative inputs resolved against the
// list file's folder. An input that matches no session throws naming it.
std::vector<std::filesystem::path> ResolveBatchSessions(const std::vector<std::string>& inputs,
                                                        const std::vector<std::filesystem::path>& list_files);

// Shard k of n (1-based): the sessions at sorted positions i with i mod n =
// k - 1. Balanced to within one session, the same on every machine given the
// same list; the shards are disjoint and together are the whole list.
std::vector<std::filesystem::path> SelectShard(const std::vector<std::filesystem::path>& sessions, int shard_index,
                                               int shard_count);
// "k/n" -> (k, n); throws std::invalid_argument naming the text and the rule.
std::pair<int, int> ParseShard(const std::string& text);

// A complete result of the session (results/<id>/, staged folders excluded)
// whose report.json has this inputs_fingerprint; the newest by name if several.
std::optional<std::filesystem::path> FindResultWithFingerprint(const std::filesystem::path& session_dir,
                                                               const std::string& fingerprint);

// Where a batch's summary goes by default: <the deepest folder holding every
// session>/batch-reports/batch-<UTC time, e.g. 20261122T110212Z>[-N], a name
// whose .csv and .json are both free; batch-reports/ is created if missing.
// Beside the library, not in whatever folder the command runs in.
std::filesystem::path DefaultBatchSummaryPrefix(const std::vector<std::filesystem::path>& sessions,
                                                std::chrono::system_clock::time_point now);

class BatchController : public BaseController {
 public:
  // `sessions` as ResolveBatchSessions gives them; the shard is taken in Run().
  BatchController(std::vector<std::filesystem::path> sessions, BatchOptions options);

  // A session's failure is recorded in the summary, not thrown. RequestStop()
  // stops the running solves (no partial result folder is left) and starts no
  // new ones; the summary is written, then Cancelled is thrown.
  void Run() override;
  const BatchSummary& summary() const { return summary_; }

 private:
  // The steps of Run() after the options and summary files are checked.
  std::vector<size_t> SessionsToSolve();  // indices into summary_.sessions; the rest skipped or failed
  void SolveSessions(const std::vector<size_t>& to_solve);

  std::vector<std::filesystem::path> sessions_;
  BatchOptions options_;
  BatchSummary summary_;
};

}  // namespace scanbench
