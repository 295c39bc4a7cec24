// batch: re-solve many sessions (issue #7); docs/batch.md.
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "app/cli/command_util.h"
#include "app/cli/commands.h"
#include "app/cli/run_controller.h"
#include "app/controllers/batch_controller.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

struct BatchState {
  std::vector<std::string> inputs;
  std::vector<fs::path> list_files;
  std::string shard;
  BatchOptions options;
};

int Batch(BatchState& state) {
  if (state.inputs.empty() && state.list_files.empty()) {
    throw std::invalid_argument("batch: give session folders, glob patterns or --list FILE");
  }
  if (!state.shard.empty()) {
    std::tie(state.options.shard_index, state.options.shard_count) = ParseShard(state.shard);
  }
  // --threads is per solve here: the solver's own option feeds the batch's.
  state.options.threads_per_solve = state.options.solve.solver.num_threads;
  state.options.Check();  // before the inputs are searched: option errors first
  const std::vector<fs::path> sessions = ResolveBatchSessions(state.inputs, state.list_files);
  if (state.options.summary_prefix.empty()) {
    state.options.summary_prefix = DefaultBatchSummaryPrefix(sessions, std::chrono::system_clock::now());
  }

  BatchController batch(sessions, state.options);
  const int code = RunController(batch);
  const BatchSummary& summary = batch.summary();
  if (!summary.sessions.empty()) std::cout << summary.Table();
  if (code != kExitSuccess) return code;  // cancelled (130) or the batch itself failed (1)
  return summary.failed > 0 ? kExitFailure : kExitSuccess;
}

}  // namespace

void RegisterBatchCommands(CLI::App& app, int* exit_code) {
  auto state = std::make_shared<BatchState>();
  CLI::App* command = app.add_subcommand(
      "batch",
      "Re-solve many sessions, a few at a time. A session that already has a result for the same inputs "
      "(frames, rig, calibration set, solver options, version) is skipped unless --force; a failing session is "
      "reported and the others finish. Exit code 0 when every session was solved or skipped, 1 if any failed, "
      "130 when cancelled. See docs/batch.md.");
  command->add_option("sessions", state->inputs,
                      "Session folders, folders holding session folders (one level), or glob patterns (quote them: "
                      "the program expands them)");
  command->add_option("--list", state->list_files,
                      "File with one session folder or pattern per line (# comments; relative to the file's folder)")
      ->check(CLI::ExistingFile);
  AddSolveOptions(*command, state->options.solve);
  command->get_option("--threads")->description("Solver threads of each session (0 = hardware threads / jobs)");
  SetsField(command->add_option("--jobs,-j", state->options.jobs,
                                "Sessions solved at the same time (a full-resolution solve holds about 2 GB)"),
            "BatchOptions.jobs")
      ->capture_default_str();
  command->add_flag("--force", state->options.force,
                    "Solve again into a new result folder even when a result for the same inputs exists");
  SetsField(
      command->add_option("--shard", state->shard,
                          "k/N: solve only shard k (1-based) of N of the sorted sessions, e.g. $SLURM_ARRAY_TASK_ID/8"),
      {"BatchOptions.shard_index", "BatchOptions.shard_count", "shard.index", "shard.count"});
  command->add_option("--summary", state->options.summary_prefix,
                      "Write the summary to PREFIX.csv and PREFIX.json (default batch-reports/batch-<UTC time> in the "
                      "folder holding the sessions); never overwritten");
  command->callback([state, exit_code] { Guarded(exit_code, [&] { return Batch(*state); }); });
}

}  // namespace scanbench
