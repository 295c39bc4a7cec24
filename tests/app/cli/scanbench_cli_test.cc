#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <sstream>

#include <filesystem>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "app/session/session.h"
#include "solver/photometric_methods.h"
#include "tests/util/command_runner.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

size_t CountResults(const fs::path& session_dir) {
  size_t count = 0;
  for (const auto& entry : fs::directory_iterator(session_dir / "results")) count += entry.is_directory();
  return count;
}

TEST(ScanbenchCliTest, HelpListsTheCommands) {
  const CommandResult result = RunScanbench("--help");
  EXPECT_EQ(result.exit_code, 0);
  for (const char* command : {"demo", "simulate", "solve"}) EXPECT_THAT(result.output, HasSubstr(command));
  EXPECT_EQ(RunScanbench("solve --help").exit_code, 0);
  EXPECT_NE(RunScanbench("").exit_code, 0) << "a command is required";
}

// --method's help is the method table: every method on a line of its own with
// its description, in every command that takes the solver's options; an
// unknown name is refused with the table's names. (Wide enough that no
// description wraps: cli_words_test.cc checks the wrapping.)
TEST(ScanbenchCliTest, MethodHelpListsEveryMethodWithItsDescription) {
  for (const std::string command : {"solve", "solve-dataset", "batch", "capture"}) {
    const CommandResult help = RunShell("COLUMNS=400 " + CliCommand(command + " --help"));
    ASSERT_EQ(help.exit_code, 0) << command;
    EXPECT_THAT(help.output, HasSubstr("Solver method (default adaptive):")) << command;
    for (const PhotometricMethodRow& method : PhotometricMethods()) {
      const size_t at = help.output.find(method.description);
      ASSERT_NE(at, std::string::npos) << command << " --help lacks " << method.name << "'s description";
      const size_t line_start = help.output.rfind('\n', at) + 1;
      EXPECT_THAT(help.output.substr(line_start, at - line_start),
                  ::testing::MatchesRegex(" *" + std::string(method.name) + "  +"))
          << command << " --help: " << method.name << " is not on its description's line";
    }
  }
  testing::TemporaryFolder folder;
  const CommandResult unknown = RunScanbench("solve " + Quoted(folder.path()) + " --method svd");
  EXPECT_NE(unknown.exit_code, 0);
  EXPECT_THAT(unknown.output, HasSubstr("'svd' is not one of adaptive, jacobi_svd"));
}

TEST(ScanbenchCliTest, DemoScansThenResolvesBesideTheFirstResult) {
  testing::TemporaryFolder folder;
  const std::string arguments = "demo --width 320 --height 212 --output " + Quoted(folder / "demo");
  const CommandResult first = RunScanbench(arguments);
  ASSERT_EQ(first.exit_code, 0) << first.output;
  EXPECT_THAT(first.output, HasSubstr("normal angular error vs ground truth"));
  EXPECT_THAT(first.output, HasSubstr("solve            100%")) << "progress is shown";
  const fs::path session_dir = folder / "demo" / "session";
  EXPECT_TRUE(LoadSession(session_dir).capture_complete);
  EXPECT_EQ(CountResults(session_dir), 1u);

  const CommandResult second = RunScanbench(arguments);
  ASSERT_EQ(second.exit_code, 0) << second.output;
  EXPECT_THAT(second.output, HasSubstr("Re-solving the existing demo session"));
  EXPECT_EQ(CountResults(session_dir), 2u);
}

// Issue #12: the sample and the camera colour from the command line.
TEST(ScanbenchCliTest, SimulatesAColorCheckerWithEitherCameraColor) {
  testing::TemporaryFolder folder;
  const CommandResult chart = RunScanbench("simulate " + Quoted(folder / "chart") +
                                           " --width 160 --height 106 --sample colorchecker --camera-color srgb-primaries");
  ASSERT_EQ(chart.exit_code, 0) << chart.output;
  const Session session = LoadSession(folder / "chart");
  EXPECT_EQ(session.sample_name, "simulated ColorChecker Classic");
  EXPECT_EQ(session.camera.model, "Simulated D5100 (sRGB primaries)");
  const CommandResult bad = RunScanbench("simulate " + Quoted(folder / "x") + " --camera-color canon");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_THAT(bad.output, HasSubstr("--camera-color"));
  const CommandResult help = RunScanbench("calibrate simulate-targets --help");
  EXPECT_THAT(help.output, HasSubstr("--camera-color"));
  EXPECT_THAT(help.output, HasSubstr("--no-color-chart"));
}

TEST(ScanbenchCliTest, SimulateTakesAMaterialAndRefusesAnUnknownOneByName) {
  testing::TemporaryFolder folder;
  const CommandResult cloth =
      RunScanbench("simulate " + Quoted(folder / "cloth") + " --width 160 --height 106 --material cloth");
  ASSERT_EQ(cloth.exit_code, 0) << cloth.output;
  EXPECT_EQ(LoadSession(folder / "cloth").sample_name, "simulated cloth twill");
  const CommandResult bad = RunScanbench("simulate " + Quoted(folder / "x") + " --material velvet");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_THAT(bad.output, HasSubstr("--material"));
  EXPECT_THAT(bad.output, HasSubstr("velvet"));
  EXPECT_THAT(RunScanbench("capture --help").output, HasSubstr("--material"));
  EXPECT_THAT(RunScanbench("demo --help").output, HasSubstr("--material"));
}

// Issue #14: capture --solve on the simulated bench writes the session and
// its result in one run; the solve's options apply.
TEST(ScanbenchCliTest, CaptureWithSolveWritesTheResult) {
  testing::TemporaryFolder folder;
  const fs::path session_dir = folder / "live";
  const CommandResult result =
      RunScanbench("capture " + Quoted(session_dir) + " --sample-name live --width 320 --height 212 "
                   "--no-exposure-check --solve --solve-queue 2 --label live");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_THAT(result.output, HasSubstr("11 frames captured"));
  // By default no frame is developed ahead (memory-bounded): the solve's bands develop them all.
  EXPECT_THAT(result.output, HasSubstr("11 decoded while capturing (0 developed)"));
  EXPECT_THAT(result.output, HasSubstr("s after the last frame"));
  EXPECT_TRUE(LoadSession(session_dir).capture_complete);
  ASSERT_EQ(CountResults(session_dir), 1u);
  EXPECT_TRUE(fs::exists(fs::directory_iterator(session_dir / "results")->path() / "normal.exr"));
  // With the development ahead (as many frames as the decoder gets to ahead of the capture).
  const CommandResult developed =
      RunScanbench("capture " + Quoted(folder / "ahead") + " --sample-name ahead --width 320 --height 212 "
                   "--no-exposure-check --solve --solve-develop-ahead --label live");
  ASSERT_EQ(developed.exit_code, 0) << developed.output;
  EXPECT_THAT(developed.output, HasSubstr("11 decoded while capturing ("));
  const CommandResult bad = RunScanbench("capture " + Quoted(folder / "x") + " --sample-name x --solve-queue 0");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_THAT(bad.output, HasSubstr("--solve-queue"));
}

// Issue #36 item 3: `capture` refuses a folder that holds anything, naming
// what is there, and --resume refuses one without an interrupted capture;
// item 8: without a terminal, each stage's progress lines come once, in
// order, and their times (since the job started) never run backwards, also
// when the capture and the live solve report from two threads.
TEST(ScanbenchCliTest, CaptureRefusesAFolderThatIsNotEmptyAndResumeNeedsAnInterruptedOne) {
  testing::TemporaryFolder folder;
  const fs::path other = folder / "other";
  fs::create_directories(other / "frames");
  { std::ofstream(other / "notes.txt") << "x"; }
  const std::string sim = " --sample-name s --width 320 --height 212 --no-exposure-check";
  const CommandResult occupied = RunScanbench("capture " + Quoted(other) + sim);
  EXPECT_EQ(occupied.exit_code, 1) << occupied.output;
  EXPECT_THAT(occupied.output, HasSubstr(other.string() + " is not empty (it holds frames/ and notes.txt)"));
  EXPECT_FALSE(fs::exists(other / "session.json"));
  const CommandResult nothing = RunScanbench("capture " + Quoted(folder / "missing") + sim + " --resume");
  EXPECT_EQ(nothing.exit_code, 1) << nothing.output;
  EXPECT_THAT(nothing.output, HasSubstr("there is no interrupted capture to resume"));
  EXPECT_FALSE(fs::exists(folder / "missing"));

  const fs::path session_dir = folder / "s";
  const CommandResult captured = RunScanbench("capture " + Quoted(session_dir) + sim + " --solve --label live");
  ASSERT_EQ(captured.exit_code, 0) << captured.output;
  std::map<std::string, int> last_percent;
  double last_seconds = 0;
  int lines = 0;
  std::istringstream output(captured.output);
  const std::regex progress_line(R"(^([a-z][a-z ]*?) +(\d{1,3})% +(\d+\.\d)s(  .*)?$)");
  for (std::string line; std::getline(output, line);) {
    std::smatch match;
    if (!std::regex_match(line, match, progress_line)) continue;
    ++lines;
    const int percent = std::stoi(match[2]);
    const double seconds = std::stod(match[3]);
    const auto [at, first] = last_percent.try_emplace(match[1], percent);
    if (!first) EXPECT_GT(percent, at->second) << "repeated or backwards: " << line;
    at->second = percent;
    EXPECT_GE(seconds, last_seconds) << "time runs backwards: " << line;
    last_seconds = seconds;
  }
  EXPECT_GE(lines, 8) << captured.output;
  EXPECT_TRUE(last_percent.count("capture")) << captured.output;

  const CommandResult again = RunScanbench("capture " + Quoted(session_dir) + sim);
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_THAT(again.output, HasSubstr("holds a complete session of 's' (11 of 11 frames)"));
  const CommandResult resume = RunScanbench("capture " + Quoted(session_dir) + sim + " --resume");
  EXPECT_EQ(resume.exit_code, 1);
  EXPECT_THAT(resume.output, HasSubstr("nothing to resume"));
  EXPECT_THAT(RunScanbench("capture --help").output, HasSubstr("--resume"));
}

// Issue #13: the default writes a specular map from its lobe fit; --no-lobe
// restores the Lambertian robust pass and writes none.
TEST(ScanbenchCliTest, SolveWritesASpecularMapUnlessTheLobeIsTurnedOff) {
  testing::TemporaryFolder folder;
  const fs::path session_dir = folder / "satin";
  const CommandResult simulated =
      RunScanbench("simulate " + Quoted(session_dir) + " --width 320 --height 212 --material satin");
  ASSERT_EQ(simulated.exit_code, 0) << simulated.output;
  const auto newest_result = [&] {
    fs::path newest;
    for (const auto& entry : fs::directory_iterator(session_dir / "results")) {
      if (entry.is_directory() && entry.path().filename() > newest.filename()) newest = entry.path();
    }
    return newest;
  };
  const CommandResult with_lobe = RunScanbench("solve " + Quoted(session_dir) + " --label lobe");
  ASSERT_EQ(with_lobe.exit_code, 0) << with_lobe.output;
  EXPECT_THAT(with_lobe.output, HasSubstr("specular map:"));
  EXPECT_TRUE(fs::is_regular_file(newest_result() / "specular.exr"));
  const CommandResult without = RunScanbench("solve " + Quoted(session_dir) + " --no-lobe --label nolobe");
  ASSERT_EQ(without.exit_code, 0) << without.output;
  EXPECT_THAT(without.output, Not(HasSubstr("specular map:")));
  const fs::path plain = newest_result();
  EXPECT_THAT(plain.filename().string(), HasSubstr("nolobe"));
  EXPECT_FALSE(fs::exists(plain / "specular.exr"));
  EXPECT_THAT(ReadText(plain / "report.json"), HasSubstr("\"adaptive_lobe\": false"));
}

// simulate-dataset writes a near-field folder; solve-dataset refines its
// depth, with solve's --depth-* options, unless --no-depth-refine (issue #33).
TEST(ScanbenchCliTest, SimulateDatasetThenSolveDatasetRefinesTheDepth) {
  testing::TemporaryFolder folder;
  const fs::path dataset = folder / "draped";
  const CommandResult simulated = RunScanbench("simulate-dataset " + Quoted(dataset) +
                                               " --width 160 --height 120 --fold-amplitude 24 --render-threads 1");
  ASSERT_EQ(simulated.exit_code, 0) << simulated.output;
  EXPECT_THAT(simulated.output, HasSubstr("160x120, 10 LEDs"));
  EXPECT_TRUE(fs::is_regular_file(dataset / "light_positions.txt"));
  const CommandResult refused = RunScanbench("simulate-dataset " + Quoted(dataset));
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_THAT(refused.output, HasSubstr("already exists"));

  const CommandResult help = RunScanbench("solve-dataset --help");
  for (const char* option : {"--depth-iterations", "--depth-tolerance", "--depth-min-range",
                             "--depth-anchor-percentile", "--depth-shadow-edge", "--no-depth-refine",
                             "--no-depth-anchor-fit"}) {
    EXPECT_THAT(help.output, HasSubstr(option));
  }
  const CommandResult refined = RunScanbench("solve-dataset " + Quoted(dataset) + " --threads 1 --depth-iterations 2 --output " +
                                             Quoted(folder / "refined"));
  ASSERT_EQ(refined.exit_code, 0) << refined.output;
  EXPECT_THAT(refined.output, HasSubstr("Depth refinement: success"));
  EXPECT_THAT(ReadText(folder / "refined" / "report.json"), HasSubstr("\"max_iterations\": 2"));
  const CommandResult plane = RunScanbench("solve-dataset " + Quoted(dataset) + " --threads 1 --no-depth-refine --output " +
                                           Quoted(folder / "plane"));
  ASSERT_EQ(plane.exit_code, 0) << plane.output;
  EXPECT_THAT(plane.output, HasSubstr("stopped: disabled"));
}

// --sheen turns the velvet sheen pass on; the Bayer blend is on unless
// --no-bayer-blend (issue #13).
TEST(ScanbenchCliTest, SolveSheenAndBayerBlendFlags) {
  testing::TemporaryFolder folder;
  // A small cloth session solved three times: plain, with --sheen, without the blend.
  const fs::path session_dir = folder / "cloth";
  std::string plain_output;
  for (const std::string& command : {"simulate " + Quoted(session_dir) + " --width 320 --height 212 --material cloth",
                                     "solve " + Quoted(session_dir) + " --label plain",
                                     "solve " + Quoted(session_dir) + " --sheen --label sheen",
                                     "solve " + Quoted(session_dir) + " --no-bayer-blend --label noblend"}) {
    const CommandResult result = RunScanbench(command);
    ASSERT_EQ(result.exit_code, 0) << command << ": " << result.output;
    if (command.find("plain") != std::string::npos) plain_output = result.output;
  }
  EXPECT_THAT(plain_output, HasSubstr("blended with the Bayer-domain normal"));
  int results = 0;
  for (const auto& entry : fs::directory_iterator(session_dir / "results")) {
    const std::string name = entry.path().filename().string();
    const bool with_sheen = name.find("sheen") != std::string::npos;
    const bool without_blend = name.find("noblend") != std::string::npos;
    const std::string report = ReadText(entry.path() / "report.json");
    EXPECT_THAT(report, HasSubstr(with_sheen ? "\"adaptive_sheen\": true" : "\"adaptive_sheen\": false")) << name;
    EXPECT_THAT(report, HasSubstr(without_blend ? "\"bayer_blend\": false" : "\"bayer_blend\": true")) << name;
    ++results;
  }
  EXPECT_EQ(results, 3);
}

TEST(ScanbenchCliTest, FailuresExitNonZeroNamingTheProblem) {
  testing::TemporaryFolder folder;
  const CommandResult not_a_session = RunScanbench("solve " + Quoted(folder.path()));
  EXPECT_EQ(not_a_session.exit_code, 1);
  EXPECT_THAT(not_a_session.output, HasSubstr("session.json"));

  const CommandResult bad_width = RunScanbench("simulate " + Quoted(folder / "s") + " --width 1");
  EXPECT_EQ(bad_width.exit_code, 1);
  EXPECT_THAT(bad_width.output, HasSubstr("width"));

  EXPECT_NE(RunScanbench("solve /nonexistent/session").exit_code, 0);
}

TEST(ScanbenchCliTest, InterruptCancelsAndTheRerunResumes) {
  testing::TemporaryFolder folder;
  const fs::path session_dir = folder / "s";
  const fs::path log = folder / "log.txt";
  // Ctrl-C as soon as the first frame is on disk.
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execl(SCANBENCH_CLI, SCANBENCH_CLI, "simulate", session_dir.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  for (int i = 0; i < 6000 && !fs::exists(session_dir / "frames" / "dark.dng"); ++i) ::usleep(10000);
  ::kill(pid, SIGINT);
  int status = 0;
  ::waitpid(pid, &status, 0);
  const std::string output = ReadText(log);
  ASSERT_TRUE(WIFEXITED(status)) << output;
  ASSERT_EQ(WEXITSTATUS(status), 130) << output;
  EXPECT_THAT(output, HasSubstr("cancelled"));
  EXPECT_THAT(output, Not(HasSubstr("error")));
  const Session partial = LoadSession(session_dir);
  EXPECT_FALSE(partial.capture_complete);
  EXPECT_GE(partial.frames.size(), 1u);
  EXPECT_LT(partial.frames.size(), 11u);

  const CommandResult resumed = RunScanbench("simulate " + Quoted(session_dir));
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  EXPECT_THAT(resumed.output, HasSubstr(std::to_string(partial.frames.size()) + " already there"));
  EXPECT_TRUE(LoadSession(session_dir).capture_complete);
}

}  // namespace
}  // namespace scanbench
