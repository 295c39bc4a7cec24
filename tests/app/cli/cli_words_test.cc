// Issue #36: the command line speaks the user's words. Options errors name the
// option as typed, every parse error exits 1 (README), a misspelt option gets
// a "did you mean", every hint names an option the command has, and --help
// fits the terminal without developer history.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tests/util/command_runner.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

// The binary with a fixed help width (the tests' output is a pipe, not a terminal).
CommandResult RunCli(const std::string& arguments) { return RunShell("COLUMNS=100 " + CliCommand(arguments)); }

// Every command a user can run, as typed after `scanbench`.
const std::vector<std::string>& AllCommands() {
  static const std::vector<std::string> commands = {"",
                                                    "demo",
                                                    "simulate",
                                                    "solve",
                                                    "devices",
                                                    "led",
                                                    "led on",
                                                    "led off",
                                                    "led status",
                                                    "led version",
                                                    "capture",
                                                    "import",
                                                    "bench",
                                                    "bench init",
                                                    "solve-dataset",
                                                    "simulate-dataset",
                                                    "solver-report",
                                                    "training-set",
                                                    "batch",
                                                    "export",
                                                    "camera",
                                                    "camera list",
                                                    "camera info",
                                                    "camera capture",
                                                    "camera preview",
                                                    "calibrate",
                                                    "calibrate camera",
                                                    "calibrate white",
                                                    "calibrate lights",
                                                    "calibrate color",
                                                    "calibrate describe",
                                                    "calibrate simulate-targets",
                                                    "calibrate edge-error",
                                                    "calibrate demo"};
  return commands;
}

// The options `command --help` lists ("--width", "-j", ...).
std::set<std::string> OptionsOf(const std::string& command) {
  const CommandResult help = RunCli(command + " --help");
  EXPECT_EQ(help.exit_code, 0) << command;
  std::set<std::string> options;
  static const std::regex kOption("(^|[ ,])(--?[A-Za-z][A-Za-z0-9-]*)");
  std::istringstream lines(help.output);
  for (std::string line; std::getline(lines, line);) {
    // Only the option column: names start a line (after its indent).
    if (line.rfind("  -", 0) != 0) continue;
    const std::string names = line.substr(0, line.find("  ", 2));
    for (std::sregex_iterator it(names.begin(), names.end(), kOption), end; it != end; ++it) options.insert((*it)[2]);
  }
  return options;
}

// The "--option" words of `text` outside `backticks` (another command quoted in full).
std::vector<std::string> OptionWords(const std::string& text) {
  std::string plain;
  bool quoted = false;
  for (char c : text) {
    if (c == '`')
      quoted = !quoted;
    else if (!quoted)
      plain += c;
  }
  std::vector<std::string> words;
  static const std::regex kWord("(^|[^A-Za-z0-9-])(--[a-z][a-z0-9-]*)");
  for (std::sregex_iterator it(plain.begin(), plain.end(), kWord), end; it != end; ++it) words.push_back((*it)[2]);
  return words;
}

TEST(CliWordsTest, OptionErrorsNameTheOptionAsTyped) {
  testing::TemporaryFolder folder;
  const CommandResult width = RunCli("simulate " + Quoted(folder / "s") + " --width -5");
  EXPECT_EQ(width.exit_code, 1);
  EXPECT_THAT(width.output, HasSubstr("scanbench: error: --width -5: must be > 0"));
  EXPECT_THAT(width.output, Not(HasSubstr("SimulatedRigOptions")));

  const CommandResult jobs = RunCli("batch " + Quoted(folder.path()) + " --jobs 0");
  EXPECT_EQ(jobs.exit_code, 1);
  EXPECT_THAT(jobs.output, HasSubstr("--jobs 0: must be in [1, 256]"));
  EXPECT_THAT(jobs.output, Not(HasSubstr("BatchOptions")));

  // A solver option through the shared solver options, in another command.
  const CommandResult tile = RunCli("solve " + Quoted(folder.path()) + " --tile-size 4");
  EXPECT_EQ(tile.exit_code, 1);
  EXPECT_THAT(tile.output, HasSubstr("--tile-size 4: must lie in [8, 4096]"));

  // A rule that names another field names its option; a default the user did not type says so.
  const CommandResult blend = RunCli("export " + Quoted(folder.path()) + " --tileable --tile-size 7");
  EXPECT_EQ(blend.exit_code, 1);
  EXPECT_THAT(blend.output, HasSubstr("--tile-blend 32 (the default): must be <= --tile-size (7)"));
}

TEST(CliWordsTest, TileSizeNeedsTileable) {
  testing::TemporaryFolder folder;
  for (const char* option : {"--tile-size 7", "--tile-blend 4"}) {
    const CommandResult result = RunCli("export " + Quoted(folder.path()) + " " + option);
    EXPECT_EQ(result.exit_code, 1) << option;
    EXPECT_THAT(result.output, HasSubstr("requires --tileable")) << option;
    EXPECT_THAT(result.output, Not(HasSubstr("TileableCropOptions"))) << option;
  }
}

TEST(CliWordsTest, ARejectedDemoLeavesNoFolderBehind) {
  testing::TemporaryFolder folder;
  const CommandResult result = RunCli("demo --width -5 --output " + Quoted(folder / "demo"));
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_THAT(result.output, HasSubstr("--width -5: must be > 0"));
  EXPECT_FALSE(fs::exists(folder / "demo"));
}

// README: "Errors ... exit with code 1"; --help and --version exit 0.
TEST(CliWordsTest, EveryParseErrorExitsOne) {
  testing::TemporaryFolder folder;
  for (const std::string& arguments : std::vector<std::string>{
           std::string(""), std::string("nosuch"), std::string("simulate"),
           "simulate " + Quoted(folder / "s") + " --width abc", "solve " + Quoted(folder.path()) + " --method svd",
           "solve /nonexistent/session", "simulate " + Quoted(folder / "s") + " --widht 5",
           "export " + Quoted(folder.path()) + " --tile-size 7", "led on 99 --simulated",
           "led on 1 --simulated --port /dev/null", "capture " + Quoted(folder / "c") + " --rig moon --sample-name x",
           "calibrate describe " + Quoted(folder.path()), "bench"}) {
    const CommandResult result = RunCli(arguments);
    EXPECT_EQ(result.exit_code, 1) << arguments << ": " << result.output;
    EXPECT_THAT(result.output, HasSubstr("--help")) << arguments << ": says where the options are";
  }
  EXPECT_EQ(RunCli("--help").exit_code, 0);
  EXPECT_EQ(RunCli("solve --help").exit_code, 0);
  EXPECT_EQ(RunCli("calibrate lights --help").exit_code, 0);
  const CommandResult version = RunCli("--version");
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_THAT(version.output, HasSubstr("scanbench "));
}

TEST(CliWordsTest, AMisspeltOptionOrCommandGetsADidYouMean) {
  testing::TemporaryFolder folder;
  const CommandResult width = RunCli("simulate " + Quoted(folder / "s") + " --widht 5");
  EXPECT_EQ(width.exit_code, 1);
  EXPECT_THAT(width.output, HasSubstr("--widht: no such option of `scanbench simulate`; did you mean --width?"));
  EXPECT_FALSE(fs::exists(folder / "s"));
  const CommandResult equals = RunCli("solve " + Quoted(folder.path()) + " --metod=lsq");
  EXPECT_THAT(equals.output, HasSubstr("did you mean --method?"));
  const CommandResult nested =
      RunCli("calibrate lights " + Quoted(folder.path()) + " -c " + Quoted(folder.path()) + " --cell-pix 8");
  EXPECT_THAT(nested.output, HasSubstr("no such option of `scanbench calibrate lights`; did you mean --cell-px?"));
  const CommandResult command = RunCli("slove " + Quoted(folder.path()));
  EXPECT_EQ(command.exit_code, 1);
  EXPECT_THAT(command.output, HasSubstr("slove: no such command; did you mean `scanbench solve`?"));
  const CommandResult far = RunCli("simulate " + Quoted(folder / "s") + " --colour red");
  EXPECT_THAT(far.output, HasSubstr("--colour: no such option of `scanbench simulate`"));
  EXPECT_THAT(far.output, Not(HasSubstr("did you mean")));
}

// Item 10: a hint names an option of the command that printed it (`led` has
// --simulated, not capture's --rig sim). Every --word of these failures'
// messages (outside a quoted other command) is one of the command's options.
TEST(CliWordsTest, EveryHintNamesAnOptionOfItsCommand) {
  testing::TemporaryFolder folder;
  // With one Arduino plugged in (not in CI) the led commands would light it: left out then.
  const bool board_attached = RunCli("led status").output.find("no LED board found") == std::string::npos;
  ASSERT_EQ(RunCli("bench init " + Quoted(folder / "rig.json")).exit_code, 0);
  struct Case {
    std::string command;    // as --help takes it
    std::string arguments;  // after the command
  };
  std::vector<Case> cases = {
      {"capture", Quoted(folder / "c") + " --sample-name x --rig hardware"},
      {"batch", Quoted(folder.path()) + " --shard 3/2"},
      {"simulate", Quoted(folder / "s") + " --widht 5"},
      {"simulate", Quoted(folder / "s") + " --width -5"},
      {"export", Quoted(folder.path()) + " --tile-size 7"},
      {"export", Quoted(folder.path()) + " --tileable --tile-size 7"},
      {"solve", Quoted(folder.path()) + " --threads 999"},
      {"calibrate describe", Quoted(folder.path()) + " --as white_sheet --spacer-mm 0"},
      {"bench init", Quoted(folder / "rig.json")},
  };
  if (!board_attached) {
    for (const char* led : {"led on", "led off", "led status", "led version"}) {
      cases.push_back({led, std::string(led) == "led on" ? "3" : ""});
    }
    cases.push_back({"capture", Quoted(folder / "h") + " --sample-name x --rig hardware --rig-file " +
                                    Quoted(folder / "rig.json")});
  }
  for (const Case& c : cases) {
    const CommandResult result = RunCli(c.command + " " + c.arguments);
    ASSERT_NE(result.exit_code, 0) << c.command << " " << c.arguments << ": " << result.output;
    const std::set<std::string> options = OptionsOf(c.command);
    for (const std::string& word : OptionWords(result.output)) {
      if (c.arguments.find(word) != std::string::npos) continue;  // the user's own words ("--widht: no such option")
      EXPECT_TRUE(options.count(word) || word == "--help")
          << "`scanbench " << c.command << "` names " << word << ", which it does not take: " << result.output;
    }
  }
  if (!board_attached) {
    const CommandResult led = RunCli("led on 3");
    EXPECT_THAT(led.output, HasSubstr("--simulated"));
    EXPECT_THAT(led.output, Not(HasSubstr("--rig sim")));
  }
}

// Item 12: report times to three significant digits ("0.0797 s", not "0.0797305 s"), in the printed
// report and in summary.txt alike.
TEST(CliWordsTest, ReportTimesHaveThreeSignificantDigits) {
  testing::TemporaryFolder folder;
  const fs::path session = folder / "s";
  ASSERT_EQ(RunCli("simulate " + Quoted(session) + " --width 160 --height 106").exit_code, 0);
  const CommandResult solve = RunCli("solve " + Quoted(session));
  ASSERT_EQ(solve.exit_code, 0) << solve.output;
  fs::path result;
  for (const auto& entry : fs::directory_iterator(session / "results")) result = entry.path();
  std::ifstream in(result / "summary.txt");
  const std::string summary((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_THAT(summary, HasSubstr("time per stage (s):"));
  for (const std::string* report : {&solve.output, &summary}) {
    std::istringstream lines(*report);
    int times = 0;
    for (std::string line; std::getline(lines, line);) {
      const bool stage_times = line.find("time per stage (s):") != std::string::npos;
      // A time: a number before " s" (" s on", " s,", " s)"), or any number on the stage-time line.
      static const std::regex kTime("([0-9]+\\.[0-9]+)( s\\b|;)");
      for (std::sregex_iterator it(line.begin(), line.end(), kTime), end; it != end; ++it) {
        if ((*it)[2] == ";" && !stage_times) continue;
        std::string digits = (*it)[1];
        digits.erase(std::remove(digits.begin(), digits.end(), '.'), digits.end());
        digits.erase(0, digits.find_first_not_of('0'));
        EXPECT_LE(digits.size(), 3u) << (*it)[1] << " in: " << line;
        ++times;
      }
    }
    EXPECT_GE(times, 5) << *report;
  }
}

TEST(CliWordsTest, HelpFitsTheTerminalWithoutDeveloperHistory) {
  for (const std::string& command : AllCommands()) {
    for (const int columns : {100, 72}) {
      const CommandResult help = RunShell("COLUMNS=" + std::to_string(columns) + " " + CliCommand(command + " --help"));
      ASSERT_EQ(help.exit_code, 0) << command;
      std::istringstream lines(help.output);
      for (std::string line; std::getline(lines, line);) {
        EXPECT_LE(line.size(), static_cast<size_t>(columns))
            << "`" << command << " --help` at " << columns << ": " << line;
      }
      EXPECT_THAT(help.output, Not(HasSubstr("issue #"))) << command;
      EXPECT_THAT(help.output, Not(HasSubstr("seed 0"))) << command;
      EXPECT_THAT(help.output, Not(HasSubstr("{false}"))) << command;
      EXPECT_THAT(help.output, Not(HasSubstr("{true}"))) << command;
      EXPECT_THAT(help.output, Not(HasSubstr("later)"))) << command;
    }
  }
  // The method table keeps one method per line, continued under its description.
  const CommandResult solve = RunCli("solve --help");
  EXPECT_THAT(solve.output, HasSubstr("--bayer-blend, --no-bayer-blend"));
  EXPECT_THAT(RunCli("devices --help").output, HasSubstr("cameras"));
  EXPECT_THAT(RunCli("calibrate describe --help").output,
              HasSubstr("Mark sessions captured of a standard target on the real bench as calibration target"));
}

}  // namespace
}  // namespace scanbench
