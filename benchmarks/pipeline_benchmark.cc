// The whole pipeline at full size in one run (issue #14 item 5): the floor
// (LibRaw unpacking the session's frames plus a write of as many bytes as the
// solve's result folder holds), `solve`, `export`, and the capture-to-result
// latency of a simulated capture, each as a ratio to the floor, with each
// stage's peak RSS, against the targets. Figures, never pass/fail.
//
//   build/benchmarks/pipeline_benchmark                       # 16 MP: 4928x3264, 10 LEDs, 2 threads
//   build/benchmarks/pipeline_benchmark --session s16 --json pipeline.json
//   build/benchmarks/pipeline_benchmark --width 160 --height 106   # a smoke run (the ctest)
//
// Rendering a 16 MP session takes minutes: --session reuses a finished
// simulated (or captured) session; the run then adds a result and an export
// folder to it and removes both at the end (--keep leaves them).
//
// Every measured stage runs in a child process (this binary re-executed with
// --child), so the peak RSS wait4 reports is that stage's alone. The children
// run with `--threads` threads and, when that is fewer than the machine has,
// pinned to that many CPUs (stages whose options say "0 = all cores" then
// share them).
//
// The latency line captures a new session on the simulated bench (the LED
// firmware in simavr, the simulated camera; as `scanbench capture --rig sim`,
// without the exposure check) and measures from the moment the last frame is
// journalled to the moment a result folder is written, twice: with the solve
// after the capture ("sequential", as `scanbench capture` then `scanbench
// solve`), and through LiveSolveController, which decodes each frame as it is
// journalled and solves after the last ("solve-while-capture", as `scanbench
// capture --solve`).
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "app/cli/run_controller.h"
#include "app/controllers/capture_controller.h"
#include "app/controllers/live_solve.h"
#include "app/controllers/export_controller.h"
#include "app/controllers/simulate_controller.h"
#include "app/controllers/solve_controller.h"
#include "app/devices/camera/simulated_camera.h"
#include "app/devices/serial_light_controller.h"
#include "app/devices/simulated_led_board.h"
#include "app/io/file_util.h"
#include "app/io/raw_decoder.h"
#include "app/session/session.h"
#include "core/format.h"
#include "core/memory.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// The "Done when" targets.
constexpr double kSolveTargetRatio = 2.0;
constexpr double kSolveTargetPeakBytes = 1.0e9;
constexpr double kExportTargetRatio = 4.0;
constexpr double kExportTargetPeakBytes = 1.5e9;
constexpr double kLatencyTargetSeconds = 3.0;
constexpr double kResultFolderTargetBytes = 200e6;

struct Args {
  int width = 4928;   // pixels, full Nikon D5100
  int height = 3264;
  int threads = 2;
  fs::path session;   // reuse this session instead of simulating one
  fs::path json_file;
  fs::path work_dir;  // where the temporary folder goes; "" = the system's temp folder
  bool keep = false;
  // Only the two capture-to-result stages (no floor, solve or export; no
  // session needed, --width/--height or --session's size).
  bool latency_only = false;
  // The live row with LiveSolveOptions::develop_ahead (every LED frame
  // developed whole as it lands: 18 bytes a pixel a frame held).
  bool develop_ahead = false;
  // Child stages (internal).
  std::string child;
  fs::path child_out;
  fs::path result;
};

// ---------------------------------------------------------------------------
// Children: one stage each, its figures into a JSON file for the parent.

void PinToCpus(int threads) {
  cpu_set_t allowed;
  if (sched_getaffinity(0, sizeof(allowed), &allowed) != 0 || CPU_COUNT(&allowed) <= threads) return;
  cpu_set_t pinned;
  CPU_ZERO(&pinned);
  int taken = 0;
  for (int cpu = 0; cpu < CPU_SETSIZE && taken < threads; ++cpu) {
    if (CPU_ISSET(cpu, &allowed)) {
      CPU_SET(cpu, &pinned);
      ++taken;
    }
  }
  sched_setaffinity(0, sizeof(pinned), &pinned);
}

json Timings(const std::vector<StageTiming>& timings) {
  json stages = json::array();
  for (const StageTiming& t : timings) stages.push_back({{"stage", t.stage}, {"seconds", t.seconds}});
  return stages;
}

// Regular files under `folder`, relative path -> bytes.
std::vector<std::pair<fs::path, uintmax_t>> FilesUnder(const fs::path& folder) {
  std::vector<std::pair<fs::path, uintmax_t>> files;
  for (const auto& entry : fs::recursive_directory_iterator(folder)) {
    if (entry.is_regular_file()) files.emplace_back(fs::relative(entry.path(), folder), entry.file_size());
  }
  std::sort(files.begin(), files.end());
  return files;
}

uintmax_t BytesUnder(const fs::path& folder) {
  uintmax_t total = 0;
  for (const auto& [path, bytes] : FilesUnder(folder)) total += bytes;
  return total;
}

// User + system CPU seconds of this process so far, all threads.
double ProcessCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) { return double(t.tv_sec) + 1e-6 * double(t.tv_usec); };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

// This process's resident and peak resident bytes (/proc/self/status VmRSS,
// VmHWM); 0 where not readable.
std::pair<double, double> ResidentBytes() {
  std::ifstream status("/proc/self/status");
  std::string line;
  double rss = 0, peak = 0;
  while (std::getline(status, line)) {
    const auto kib = [&] { return 1024.0 * std::atof(line.c_str() + line.find(':') + 1); };
    if (line.rfind("VmRSS:", 0) == 0) rss = kib();
    if (line.rfind("VmHWM:", 0) == 0) peak = kib();
  }
  return {rss, peak};
}

void CheckRun(int code, const std::string& what) {
  if (code != kExitSuccess) throw std::runtime_error(what + " failed (exit code " + std::to_string(code) + ")");
}

SolveOptions BenchSolveOptions(int threads) {
  SolveOptions options;  // the default method and develop options, as `scanbench solve`
  options.solver.num_threads = threads;
  return options;
}

json ChildSimulate(const Args& args) {
  SimulateOptions options;
  options.rig.width = args.width;
  options.rig.height = args.height;
  options.rig.num_threads = args.threads;
  SimulateController simulate(args.session, options);
  CheckRun(RunController(simulate), "simulate " + args.session.string());
  return {{"seconds", simulate.summary().seconds}, {"frames", simulate.summary().frames_written}};
}

json ChildFloorDecode(const Args& args) {
  SessionLoadOptions load;
  load.verify_checksums = false;  // the floor is the unpack alone
  const Session session = LoadSession(args.session, load);
  // Every file of the session (frames, ground truth) is read once untimed
  // first, as a session just captured or simulated is in the page cache: the
  // floor and the solve after it then both read from memory (a cold first read
  // made the floor 8.4 s instead of about 2 s, and the solve's load stage 3.4 s).
  for (auto it = fs::recursive_directory_iterator(args.session); it != fs::recursive_directory_iterator(); ++it) {
    const std::string name = it->path().filename().string();
    if (it.depth() == 0 && it->is_directory() && (name == "results" || name == "exports")) {
      it.disable_recursion_pending();  // earlier runs' outputs are not the solve's inputs
    } else if (it->is_regular_file()) {
      (void)ReadFileBytes(it->path());
    }
  }
  double seconds = 0;
  uintmax_t file_bytes = 0, raw_bytes = 0;
  for (size_t i = 0; i < session.frames.size(); ++i) {
    const fs::path path = args.session / session.frames[i].file;
    std::fprintf(stderr, "floor: LibRaw unpack %zu/%zu %s\n", i + 1, session.frames.size(), path.c_str());
    const auto start = std::chrono::steady_clock::now();
    const RawImage raw = DecodeRawFile(path);  // read + LibRaw unpack + the visible mosaic, as unprocessed_raw
    seconds += SecondsSince(start);
    file_bytes += fs::file_size(path);
    raw_bytes += uintmax_t(raw.width()) * raw.height() * sizeof(uint16_t);
  }
  return {{"seconds", seconds},
          {"frames", session.frames.size()},
          {"file_bytes", file_bytes},
          {"raw_plane_bytes", raw_bytes}};
}

json ChildSolve(const Args& args) {
  SolveController solve(args.session, BenchSolveOptions(args.threads));
  const auto start = std::chrono::steady_clock::now();
  CheckRun(RunController(solve), "solve " + args.session.string());
  const double wall = SecondsSince(start);
  const SolveSummary& summary = solve.summary();
  json out = {{"seconds", wall},
              {"stages", Timings(summary.timings)},
              {"method", summary.solver.method},
              {"result_dir", summary.result_dir.string()},
              {"bytes_written", BytesUnder(summary.result_dir)},
              {"map_bytes", summary.TotalBytesWritten()},
              {"exr_encoding", summary.exr_encoding}};
  if (summary.normal_error_deg) out["normal_mean_error_deg"] = summary.normal_error_deg->mean;
  return out;
}

// Writes as many bytes as `args.result` holds, file for file, the way results
// are written (temporary name, fsync, rename, folder fsync), then removes them.
json ChildFloorWrite(const Args& args) {
  const auto files = FilesUnder(args.result);
  uintmax_t largest = 0;
  for (const auto& [path, bytes] : files) largest = std::max(largest, bytes);
  // Incompressible bytes, made before the clock starts.
  std::vector<uint8_t> buffer(largest);
  std::mt19937_64 random(14);
  for (size_t i = 0; i + 8 <= buffer.size(); i += 8) {
    const uint64_t word = random();
    std::copy_n(reinterpret_cast<const uint8_t*>(&word), 8, buffer.data() + i);
  }
  const fs::path scratch = args.child_out.parent_path() / "floor_write";
  fs::create_directories(scratch);
  uintmax_t total = 0;
  const auto start = std::chrono::steady_clock::now();
  for (const auto& [path, bytes] : files) {
    const fs::path target = scratch / path.filename();  // flat: the folders' creation is not the floor
    WriteFileAtomic(target, std::span<const uint8_t>(buffer.data(), bytes), OverwritePolicy::kReplace);
    total += bytes;
  }
  const double seconds = SecondsSince(start);
  fs::remove_all(scratch);
  return {{"seconds", seconds}, {"bytes", total}, {"files", files.size()}};
}

json ChildExport(const Args& args) {
  ExportOptions options;  // the default preset
  options.occlusion.num_threads = args.threads;
  ExportController exporter(args.result, options);
  const auto start = std::chrono::steady_clock::now();
  CheckRun(RunController(exporter), "export " + args.result.string());
  const double wall = SecondsSince(start);
  const ExportSummary& summary = exporter.summary();
  return {{"seconds", wall},
          {"stages", Timings(summary.stage_seconds)},
          {"preset", summary.preset},
          {"export_dir", summary.export_dir.string()},
          {"bytes_written", BytesUnder(summary.export_dir)}};
}

// live: through LiveSolveController (capture --solve); else the capture, then a solve.
json ChildLatency(const Args& args, bool live) {
  SimulatedRigOptions rig_options;
  rig_options.width = args.width;
  rig_options.height = args.height;
  rig_options.num_threads = args.threads;
  const TextileSceneOptions scene;
  CaptureOptions options;
  options.sample_name = "pipeline benchmark";
  options.check_exposure = false;  // before the first frame: no part of the latency
  options.simulation = SimulatedSceneOf(rig_options, scene);
  const auto rig = std::make_shared<SimulatedRig>(rig_options, TextileScene(scene),
                                                  MakeDefaultSimulatedRig(args.width, args.height));
  SimulatedLedBoard board;
  SerialLightController lights(board.port_path());
  SimulatedCamera camera(rig, [&board] { return board.SingleLitLed(); });
  LiveSolveOptions live_options;
  live_options.capture = options;
  live_options.solve = BenchSolveOptions(args.threads);
  live_options.develop_ahead = args.develop_ahead;
  CaptureController capture(args.session, rig->rig(), &camera, &lights, options);
  LiveSolveController live_solve(args.session, rig->rig(), &camera, &lights, live_options);
  BaseController& controller = live ? static_cast<BaseController&>(live_solve) : capture;
  // The capture reports "capture" at 1 right after it journals the last frame
  // (and switches the LEDs off).
  std::optional<fs::file_time_type> last_frame;
  double last_frame_cpu = 0;
  std::pair<double, double> last_frame_rss{0, 0};  // resident, peak so far
  const auto capture_start = std::chrono::steady_clock::now();
  std::optional<double> capture_seconds;
  CheckRun(RunController(controller,
                         [&](const ProgressReport& report) {
                           if (report.stage == "capture" && report.fraction >= 1 && !last_frame) {
                             last_frame = fs::file_time_type::clock::now();
                             last_frame_cpu = ProcessCpuSeconds();
                             last_frame_rss = ResidentBytes();
                             capture_seconds = SecondsSince(capture_start);
                           }
                         }),
           std::string(live ? "capture --solve" : "capture") + " --rig sim " + args.session.string());
  if (!last_frame) throw std::runtime_error("capture " + args.session.string() + " never reported its last frame");
  fs::file_time_type result_written;
  double solve_seconds = 0;
  fs::path result;
  int frames = 0;
  std::vector<StageTiming> sequential_timings;
  if (live) {
    result = live_solve.summary().solve.result_dir;
    result_written = fs::last_write_time(result / "report.json");
    solve_seconds = live_solve.summary().solve.TotalSeconds();
    frames = live_solve.summary().capture.frames_captured;
  } else {
    SolveController solve(args.session, BenchSolveOptions(args.threads));
    const auto start = std::chrono::steady_clock::now();
    CheckRun(RunController(solve), "solve " + args.session.string());
    solve_seconds = SecondsSince(start);
    result_written = fs::file_time_type::clock::now();
    result = solve.summary().result_dir;
    frames = capture.summary().frames_captured;
    sequential_timings = solve.summary().timings;
  }
  const double latency = std::chrono::duration<double>(result_written - *last_frame).count();
  // The process's CPU time from the last frame to the result: the live
  // solve's own figure (from the journalling of the last frame), else from
  // the capture's last progress report. Both include the simulated LED
  // board's thread (simavr, about 0.06 CPU-s a second), which a real bench
  // does not have.
  double cpu = ProcessCpuSeconds() - last_frame_cpu;
  json developed = nullptr;  // LED frames developed while capturing (live only)
  json points_held = nullptr;  // the table points made while capturing (live only)
  json decoded = nullptr;  // frames decoded while capturing (live only)
  json until_solve = nullptr;  // last frame -> the solve's start (live only)
  json stages = json::array();  // the solve's own stages after the last frame
  if (live) {
    cpu = live_solve.summary().cpu_seconds_after_last_frame;
    developed = live_solve.summary().frames_developed_live;
    decoded = live_solve.summary().frames_decoded_live;
    until_solve = live_solve.summary().seconds_until_solve;
    points_held = live_solve.summary().surface_points_held;
    stages = Timings(live_solve.summary().solve.timings);
  } else {
    stages = Timings(sequential_timings);
  }
  return {{"seconds", latency},
          {"cpu_seconds_after_last_frame", cpu},
          {"solve_stages", stages},
          // The process at the last frame (the simulated rig, the frames
          // decoded so far): what the peak RSS beyond it is the solve's.
          {"rss_at_last_frame_bytes", last_frame_rss.first},
          {"peak_rss_at_last_frame_bytes", last_frame_rss.second},
          {"frames_decoded_live", decoded},
          {"seconds_until_solve", until_solve},
          {"frames_developed_live", developed},
          {"surface_points_held", points_held},
          {"mode", live ? "solve-while-capture" : "sequential"},
          {"capture_seconds", *capture_seconds},
          {"frames", frames},
          {"solve_seconds", solve_seconds},
          {"result_dir", result.string()}};
}

int RunChild(const Args& args) {
  PinToCpus(args.threads);
  json out;
  if (args.child == "simulate") {
    out = ChildSimulate(args);
  } else if (args.child == "floor-decode") {
    out = ChildFloorDecode(args);
  } else if (args.child == "solve") {
    out = ChildSolve(args);
  } else if (args.child == "floor-write") {
    out = ChildFloorWrite(args);
  } else if (args.child == "export") {
    out = ChildExport(args);
  } else if (args.child == "latency") {
    out = ChildLatency(args, false);
  } else if (args.child == "latency-live") {
    out = ChildLatency(args, true);
  } else {
    throw std::invalid_argument("--child: unknown stage '" + args.child + "'");
  }
  WriteFileAtomic(args.child_out, out.dump(2), OverwritePolicy::kReplace);
  return 0;
}

// ---------------------------------------------------------------------------
// The parent: runs each stage as a child, collects, prints.

volatile std::sig_atomic_t g_interrupted = 0;
void OnInterrupt(int) { g_interrupted = 1; }

struct StageRun {
  json figures;
  double peak_rss_bytes = 0;
};

// Re-executes this binary for one stage; Ctrl-C reaches the child (same
// process group), which stops cleanly, and then ends this run.
StageRun RunStage(const Args& args, const fs::path& work, const std::string& stage,
                  const std::vector<std::string>& extra) {
  const fs::path out = work / (stage + ".json");
  std::vector<std::string> argv = {"/proc/self/exe", "--child", stage, "--child-out", out.string(),
                                   "--threads", std::to_string(args.threads), "--width", std::to_string(args.width),
                                   "--height", std::to_string(args.height)};
  if (args.develop_ahead) argv.push_back("--develop-ahead");
  argv.insert(argv.end(), extra.begin(), extra.end());
  std::vector<char*> c_argv;
  for (std::string& a : argv) c_argv.push_back(a.data());
  c_argv.push_back(nullptr);
  std::fprintf(stderr, "pipeline_benchmark: %s\n", stage.c_str());
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("fork for stage " + stage + " failed");
  if (pid == 0) {
    signal(SIGINT, SIG_DFL);
    execv(c_argv[0], c_argv.data());
    _exit(127);
  }
  int status = 0;
  rusage usage{};
  while (wait4(pid, &status, 0, &usage) < 0) {
    if (errno != EINTR) throw std::runtime_error("wait4 for stage " + stage + " failed");
  }
  if (g_interrupted) throw Cancelled("pipeline benchmark, stage " + stage);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    throw std::runtime_error("stage " + stage + " failed (" +
                             (WIFEXITED(status) ? "exit code " + std::to_string(WEXITSTATUS(status))
                                                : "signal " + std::to_string(WTERMSIG(status))) +
                             "); its messages are above");
  }
  std::ifstream in(out);
  StageRun run;
  run.figures = json::parse(in);
  run.peak_rss_bytes = double(usage.ru_maxrss) * 1024;  // Linux: KiB
  return run;
}

std::string Cell(double value, int digits, int width) {
  std::string text = Fixed(value, digits);
  return std::string(std::max<int>(0, width - int(text.size())), ' ') + text;
}
std::string Gb(double bytes) { return Fixed(bytes / 1e9, 2) + " GB"; }
std::string Mb(double bytes) { return Fixed(bytes / 1e6, 1) + " MB"; }

void PrintRow(const std::string& name, const std::string& seconds, const std::string& ratio, const std::string& rss,
              const std::string& target, const std::string& met) {
  char line[512];
  std::snprintf(line, sizeof(line), "%-46s %10s %8s %9s  %-24s %s", name.c_str(), seconds.c_str(), ratio.c_str(),
                rss.c_str(), target.c_str(), met.c_str());
  std::string text = line;
  text.erase(text.find_last_not_of(' ') + 1);
  std::printf("%s\n", text.c_str());
}

// One measured figure against its targets, as a table row and a JSON object.
// A stage that may fail without ending the run: its figures or its error.
struct StageOutcome {
  std::optional<StageRun> run;
  std::string error;
};

StageOutcome TryStage(const Args& args, const fs::path& work, const std::string& stage,
                      const std::vector<std::string>& extra) {
  StageOutcome outcome;
  try {
    outcome.run = RunStage(args, work, stage, extra);
  } catch (const Cancelled&) {
    throw;
  } catch (const std::exception& error) {
    outcome.error = error.what();
  }
  return outcome;
}

// floor_s: nullopt when the floor was not measured (--latency-only): no ratio.
json Figure(const std::string& name, const StageRun& run, std::optional<double> floor_s,
            std::optional<double> target_ratio, std::optional<double> target_seconds,
            std::optional<double> target_peak) {
  const double seconds = run.figures.at("seconds").get<double>();
  const double ratio = floor_s ? seconds / *floor_s : 0;
  bool met = true;
  std::string target;
  if (target_ratio) {
    met = met && ratio <= *target_ratio;
    target += "<= " + Fixed(*target_ratio, 1) + "x";
  }
  if (target_seconds) {
    met = met && seconds <= *target_seconds;
    target += "<= " + Fixed(*target_seconds, 1) + " s";
  }
  if (target_peak) {
    met = met && run.peak_rss_bytes <= *target_peak;
    target += ", <= " + Gb(*target_peak);
  }
  PrintRow(name, Cell(seconds, 2, 10), floor_s ? Cell(ratio, 2, 8) : "", Gb(run.peak_rss_bytes), target,
           met ? "yes" : "no");
  json figure = run.figures;
  figure["ratio_to_floor"] = floor_s ? json(ratio) : json(nullptr);
  figure["peak_rss_bytes"] = run.peak_rss_bytes;
  json targets = json::object();
  if (target_ratio) targets["ratio_to_floor"] = *target_ratio;
  if (target_seconds) targets["seconds"] = *target_seconds;
  if (target_peak) targets["peak_rss_bytes"] = *target_peak;
  figure["target"] = targets;
  figure["target_met"] = met;
  return figure;
}

void PrintStages(const json& stages) {
  for (const json& stage : stages) {
    PrintRow("  " + stage.at("stage").get<std::string>(), Cell(stage.at("seconds").get<double>(), 2, 10), "", "",
             "", "");
  }
}

using LatencyOutcomes = std::vector<std::pair<std::string, StageOutcome>>;

// The capture-to-result stages, sequential first, then the live path the
// target is for: a new session captured on the simulated bench each.
LatencyOutcomes RunLatencies(const Args& args, const fs::path& work) {
  // The capture stages run the simavr LED board in real time, which a busy
  // machine can make miss its timing: their failure is reported beside the
  // figures of the other stages rather than losing them.
  LatencyOutcomes outcomes;
  outcomes.emplace_back("latency_sequential",
                        TryStage(args, work, "latency", {"--session", (work / "capture_session").string()}));
  outcomes.emplace_back("latency",
                        TryStage(args, work, "latency-live", {"--session", (work / "live_capture_session").string()}));
  return outcomes;
}

// Their rows and JSON; false when one failed.
bool ReportLatencies(const LatencyOutcomes& latencies, std::optional<double> floor_s, json* report) {
  bool all_ran = true;
  for (const auto& [key, outcome] : latencies) {
    if (!outcome.run) {
      all_ran = false;
      PrintRow("capture-to-result (" + key + ")", "failed", "", "", "", "");
      (*report)[key] = {{"failed", outcome.error}};
      continue;
    }
    const StageRun& run = *outcome.run;
    (*report)[key] = Figure("capture-to-result (" + run.figures.at("mode").get<std::string>() + ")", run, floor_s,
                            std::nullopt, kLatencyTargetSeconds, std::nullopt);
    PrintRow("  capture of " + std::to_string(run.figures.at("frames").get<int>()) + " frames",
             Cell(run.figures.at("capture_seconds").get<double>(), 2, 10), "", "", "", "");
    PrintRow("  CPU after the last frame (s): " + Fixed(run.figures.at("cpu_seconds_after_last_frame").get<double>(), 2),
             "", "", "", "", "");
    PrintRow("  RSS at the last frame " + Gb(run.figures.at("rss_at_last_frame_bytes").get<double>()) +
                 " (peak so far " + Gb(run.figures.at("peak_rss_at_last_frame_bytes").get<double>()) + ")",
             "", "", "", "", "");
    PrintStages(run.figures.at("solve_stages"));
  }
  for (const auto& [key, outcome] : latencies) {
    if (!outcome.run) std::printf("%s: %s\n", key.c_str(), outcome.error.c_str());
  }
  return all_ran;
}

// The 1, 5 and 15 minute load averages; zeros when the system gives none.
std::array<double, 3> LoadAverage() {
  std::array<double, 3> load{};
  if (getloadavg(load.data(), 3) != 3) load = {};
  return load;
}

// --latency-only: the two capture-to-result stages alone.
int RunLatencyOnly(const Args& args, const fs::path& work) {
  const std::array<double, 3> load_start = LoadAverage();
  const LatencyOutcomes latencies = RunLatencies(args, work);
  const std::array<double, 3> load_end = LoadAverage();
  std::printf("Capture-to-result at %dx%d, %d threads (no floor, solve or export: --latency-only)\n", args.width,
              args.height, args.threads);
  std::printf("Load average at the start %s, at the end %s (1 min), on %ld CPUs\n", Fixed(load_start[0], 2).c_str(),
              Fixed(load_end[0], 2).c_str(), sysconf(_SC_NPROCESSORS_ONLN));
  PrintRow("figure", "seconds", "x floor", "peak RSS", "target", "met");
  json report = {{"schema", "scanbench.pipeline_benchmark"},
                 {"schema_version", 1},
                 {"latency_only", true},
                 {"width", args.width},
                 {"height", args.height},
                 {"threads", args.threads},
                 {"cpus", sysconf(_SC_NPROCESSORS_ONLN)},
                 {"load_average_1min", {{"start", load_start[0]}, {"end", load_end[0]}}}};
  const bool all_ran = ReportLatencies(latencies, std::nullopt, &report);
  std::fflush(stdout);
  if (!args.json_file.empty()) WriteFileAtomic(args.json_file, report.dump(2) + "\n", OverwritePolicy::kReplace);
  return all_ran ? 0 : 1;
}

void CheckArgs(const Args& args) {
  if (args.width < 16 || args.height < 16) {
    throw std::invalid_argument("--width/--height: " + std::to_string(args.width) + "x" + std::to_string(args.height) +
                                " must be at least 16 pixels each");
  }
  if (args.threads < 1) throw std::invalid_argument("--threads: " + std::to_string(args.threads) + " must be >= 1");
}

// A new folder for the run's files under --work-dir (or the system's temporary folder).
fs::path MakeWorkFolder(const Args& args) {
  const fs::path temp_root = args.work_dir.empty() ? fs::temp_directory_path() : args.work_dir;
  std::string pattern = (temp_root / "pipeline_benchmark.XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error(temp_root.string() + ": cannot create a temporary folder");
  return pattern;
}

// The run's session: --session (complete; the run takes its size and lists
// in *made_in_session the folders the solve and the export add to it), or
// one simulated into `work`. Returns the simulation's seconds, 0 when reused.
double PrepareSession(Args* args, const fs::path& work, std::vector<fs::path>* made_in_session) {
  if (args->session.empty()) {
    args->session = work / "session";
    return RunStage(*args, work, "simulate", {"--session", args->session.string()}).figures.at("seconds").get<double>();
  }
  SessionLoadOptions load;
  load.verify_checksums = false;
  const Session session = LoadSession(args->session, load);
  if (!session.capture_complete) {
    throw std::invalid_argument("--session " + args->session.string() + ": the capture is not complete");
  }
  args->width = session.camera.width;
  args->height = session.camera.height;
  // Folders the solve and the export create go again with what is in them.
  for (const char* folder : {"results", "exports"}) {
    if (!fs::exists(args->session / folder)) made_in_session->push_back(args->session / folder);
  }
  return 0;
}

// The stages of a full run, each in a child process of its own.
struct PipelineRuns {
  StageRun decode, solve, write, exported;
  LatencyOutcomes latencies;
};

PipelineRuns RunPipeline(const Args& args, const fs::path& work, bool reused,
                         std::vector<fs::path>* made_in_session) {
  const std::vector<std::string> on_session = {"--session", args.session.string()};
  PipelineRuns runs;
  runs.decode = RunStage(args, work, "floor-decode", on_session);
  runs.solve = RunStage(args, work, "solve", on_session);
  const fs::path result_dir = runs.solve.figures.at("result_dir").get<std::string>();
  if (reused) made_in_session->push_back(result_dir);
  runs.write = RunStage(args, work, "floor-write", {"--result", result_dir.string()});
  runs.exported = RunStage(args, work, "export", {"--result", result_dir.string()});
  const fs::path export_dir = runs.exported.figures.at("export_dir").get<std::string>();
  if (reused) made_in_session->push_back(export_dir);
  runs.latencies = RunLatencies(args, work);
  return runs;
}

// The figures of a full run, printed as rows and returned as the report's
// JSON; *all_ran is false when a latency stage failed.
json ReportPipeline(const Args& args, const Session& session, bool reused, double simulate_seconds,
                    const std::array<double, 3>& load_start, const PipelineRuns& runs, bool* all_ran) {
  const double floor_s = runs.decode.figures.at("seconds").get<double>() + runs.write.figures.at("seconds").get<double>();
  const double result_bytes = runs.solve.figures.at("bytes_written").get<double>();
  const double frame_bytes = runs.decode.figures.at("file_bytes").get<double>();
  const int frames = runs.decode.figures.at("frames").get<int>();

  // Other work on the machine slows every figure: its load is part of the record.
  const std::array<double, 3> load_end = LoadAverage();
  std::printf("Pipeline at %dx%d, %d LEDs, %d frames (%s), %d threads; session %s\n", args.width, args.height,
              int(session.rig.leds.size()), frames, Mb(frame_bytes).c_str(), args.threads,
              reused ? ("reused: " + args.session.string()).c_str()
                     : ("simulated in this run in " + Fixed(simulate_seconds, 1) + " s").c_str());
  std::printf("Load average at the start %s, at the end %s (1 min), on %ld CPUs\n", Fixed(load_start[0], 2).c_str(),
              Fixed(load_end[0], 2).c_str(), sysconf(_SC_NPROCESSORS_ONLN));
  PrintRow("figure", "seconds", "x floor", "peak RSS", "target", "met");
  json report = {{"schema", "scanbench.pipeline_benchmark"},
                 {"schema_version", 1},
                 {"width", args.width},
                 {"height", args.height},
                 {"leds", session.rig.leds.size()},
                 {"frames", frames},
                 {"frame_bytes", frame_bytes},
                 {"threads", args.threads},
                 {"cpus", sysconf(_SC_NPROCESSORS_ONLN)},
                 {"load_average_1min", {{"start", load_start[0]}, {"end", load_end[0]}}},
                 {"session", {{"path", args.session.string()}, {"reused", reused}, {"simulate_seconds", simulate_seconds}}}};
  PrintRow("floor: LibRaw unpack of " + std::to_string(frames) + " frames",
           Cell(runs.decode.figures.at("seconds").get<double>(), 2, 10), "", Gb(runs.decode.peak_rss_bytes), "", "");
  PrintRow("floor: write " + Mb(result_bytes) + " (fsynced)", Cell(runs.write.figures.at("seconds").get<double>(), 2, 10),
           "", Gb(runs.write.peak_rss_bytes), "", "");
  PrintRow("floor", Cell(floor_s, 2, 10), Cell(1, 2, 8), "", "", "");
  report["floor"] = {{"seconds", floor_s},
                     {"decode", runs.decode.figures},
                     {"write", runs.write.figures}};
  report["floor"]["decode"]["peak_rss_bytes"] = runs.decode.peak_rss_bytes;
  report["floor"]["write"]["peak_rss_bytes"] = runs.write.peak_rss_bytes;

  report["solve"] = Figure("solve (" + runs.solve.figures.at("method").get<std::string>() + ")", runs.solve, floor_s,
                           kSolveTargetRatio, std::nullopt, kSolveTargetPeakBytes);
  PrintStages(runs.solve.figures.at("stages"));
  const bool folder_met = result_bytes <= kResultFolderTargetBytes;
  PrintRow("  result folder " + Mb(result_bytes), "", "", "", "<= " + Mb(kResultFolderTargetBytes),
           folder_met ? "yes" : "no");
  report["solve"]["target"]["bytes_written"] = kResultFolderTargetBytes;
  report["solve"]["bytes_written_met"] = folder_met;
  if (runs.solve.figures.contains("normal_mean_error_deg")) {
    PrintRow("  normal error, mean " + Fixed(runs.solve.figures.at("normal_mean_error_deg").get<double>(), 3) + " deg",
             "", "", "", "", "");
  }

  report["export"] = Figure("export (" + runs.exported.figures.at("preset").get<std::string>() + ")", runs.exported, floor_s,
                            kExportTargetRatio, std::nullopt, kExportTargetPeakBytes);
  PrintStages(runs.exported.figures.at("stages"));
  PrintRow("  export folder " + Mb(runs.exported.figures.at("bytes_written").get<double>()), "", "", "", "", "");

  *all_ran = ReportLatencies(runs.latencies, floor_s, &report);
  return report;
}

int RunParent(Args args) {
  CheckArgs(args);
  const fs::path work = MakeWorkFolder(args);
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);

  std::vector<fs::path> made_in_session;  // what this run added to a reused session
  auto clean_up = [&] {
    if (args.keep) {
      std::fprintf(stderr, "pipeline_benchmark: kept %s\n", work.c_str());
      return;
    }
    for (const fs::path& path : made_in_session) fs::remove_all(path);
    fs::remove_all(work);
  };
  try {
    if (args.latency_only) {
      if (!args.session.empty()) {  // only its size
        SessionLoadOptions load;
        load.verify_checksums = false;
        const Session session = LoadSession(args.session, load);
        args.width = session.camera.width;
        args.height = session.camera.height;
      }
      const int code = RunLatencyOnly(args, work);
      clean_up();
      return code;
    }
    const std::array<double, 3> load_start = LoadAverage();
    const bool reused = !args.session.empty();
    const double simulate_seconds = PrepareSession(&args, work, &made_in_session);
    SessionLoadOptions load;
    load.verify_checksums = false;
    const Session session = LoadSession(args.session, load);
    const PipelineRuns runs = RunPipeline(args, work, reused, &made_in_session);
    bool all_ran = false;
    const json report = ReportPipeline(args, session, reused, simulate_seconds, load_start, runs, &all_ran);
    std::fflush(stdout);
    if (!args.json_file.empty()) WriteFileAtomic(args.json_file, report.dump(2) + "\n", OverwritePolicy::kReplace);
    clean_up();
    return all_ran ? 0 : 1;
  } catch (...) {
    clean_up();
    throw;
  }
}

}  // namespace
}  // namespace scanbench

int main(int argc, char** argv) {
  // As the CLI does, so that each stage's peak RSS is the one `scanbench` has.
  scanbench::ReturnFreedImagesToTheSystem();
  scanbench::Args args;
  CLI::App app{"The pipeline at full size: floor, solve, export, capture-to-result latency, peak RSS"};
  app.add_option("--width", args.width, "Image width in pixels (ignored with --session)")->capture_default_str();
  app.add_option("--height", args.height, "Image height in pixels (ignored with --session)")->capture_default_str();
  app.add_option("--threads", args.threads, "Threads of every stage")->capture_default_str();
  app.add_option("--session", args.session, "Reuse this complete session instead of simulating one");
  app.add_option("--json", args.json_file, "Also write the figures as JSON here");
  app.add_option("--work-dir", args.work_dir, "Folder for the temporary files (default: the system's temp folder)");
  app.add_flag("--keep", args.keep, "Keep the temporary folder and what the run added to --session");
  app.add_flag("--latency-only", args.latency_only,
               "Only the two capture-to-result stages (sequential and solve-while-capture), no floor, solve or "
               "export; at --width x --height, or --session's size");
  app.add_flag("--develop-ahead", args.develop_ahead,
               "The solve-while-capture row with every LED frame developed as it lands (capture "
               "--solve-develop-ahead: 18 bytes a pixel a frame held, 2.9 GB at 16 MP)");
  app.add_option("--child", args.child)->group("");  // internal: run one stage
  app.add_option("--child-out", args.child_out)->group("");
  app.add_option("--result", args.result)->group("");
  CLI11_PARSE(app, argc, argv);
  try {
    return args.child.empty() ? scanbench::RunParent(args) : scanbench::RunChild(args);
  } catch (const scanbench::Cancelled& cancelled) {
    std::fprintf(stderr, "pipeline_benchmark: %s\n", cancelled.what());
    return scanbench::kExitCancelled;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "pipeline_benchmark: error: %s\n", error.what());
    return 1;
  }
}
