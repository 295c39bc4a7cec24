// `scanbench batch` run as a user would (issue #7): quoted glob, list file,
// exit code 1 with a corrupt session, summary files written.
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/util/command_runner.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// Runs scanbench with `arguments` in the folder `cwd`.
CommandResult RunScanbenchIn(const fs::path& cwd, const std::string& arguments) {
  return RunShell("cd " + Quoted(cwd) + " && " + CliCommand(arguments));
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The name of the i-th copy of the simulated session (appended: `"c" + string`
// draws GCC 12's false -Wrestrict).
std::string CopyName(int i) {
  std::string name = "c";
  name += std::to_string(i);
  return name;
}

std::vector<fs::path> FilesWithExtension(const fs::path& folder, const std::string& extension) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder)) {
    if (entry.path().extension() == extension) files.push_back(entry.path());
  }
  return files;
}

TEST(BatchCliTest, GlobListFileExitCodesAndSummary) {
  testing::TemporaryFolder folder;
  const CommandResult simulated =
      RunScanbenchIn(folder.path(), "simulate source --width 96 --height 64 --render-threads 2");
  ASSERT_EQ(simulated.exit_code, 0) << simulated.output;
  for (const char* name : {"s1", "s2", "s3", "s4"}) {
    fs::create_directories(folder / "lib");
    fs::copy(folder / "source", folder / "lib" / name, fs::copy_options::recursive);
  }
  {  // s3's led_05 frame damaged after capture: its checksum no longer matches
    std::fstream frame(folder / "lib" / "s3" / "frames" / "led_05.dng", std::ios::in | std::ios::out | std::ios::binary);
    frame.seekp(2000);
    frame.put('\x5a').put('\xa5');
  }

  // A quoted glob: the program expands it. One corrupt session: exit code 1, the others solved.
  const CommandResult first = RunScanbenchIn(folder.path(), "batch 'lib/s*' --jobs 2 --threads 1");
  EXPECT_EQ(first.exit_code, 1) << first.output;
  EXPECT_THAT(first.output, HasSubstr("frames/led_05.dng"));
  EXPECT_THAT(first.output, HasSubstr("4 sessions: 3 solved, 0 skipped, 1 failed, 0 cancelled"));
  EXPECT_TRUE(FilesWithExtension(folder.path(), ".csv").empty()) << "nothing written where the command runs";
  EXPECT_TRUE(FilesWithExtension(folder.path(), ".json").empty());
  const fs::path reports = folder / "lib" / "batch-reports";
  ASSERT_TRUE(fs::is_directory(reports)) << "default summary lib/batch-reports/batch-<UTC time>.csv";
  const std::vector<fs::path> csv_files = FilesWithExtension(reports, ".csv");
  ASSERT_EQ(csv_files.size(), 1u);
  EXPECT_THAT(csv_files[0].filename().string(), ::testing::StartsWith("batch-"));
  EXPECT_EQ(FilesWithExtension(reports, ".json").size(), 1u);
  EXPECT_THAT(first.output, HasSubstr("lib/batch-reports/" + csv_files[0].filename().string())) << "printed";
  const std::string csv = ReadText(csv_files[0]);
  EXPECT_THAT(csv, HasSubstr("/lib/s3,failed,"));
  EXPECT_THAT(csv, HasSubstr("/lib/s4,solved,"));

  // A list file (comment, relative paths against its folder, a duplicate) without the corrupt session:
  // everything already solved is skipped, exit code 0, the summary where asked.
  fs::create_directories(folder / "lists");
  std::ofstream(folder / "lists" / "lib.txt") << "# good sessions\n../lib/s1\n../lib/s2\n\n../lib/s4\n../lib/s1/\n";
  const CommandResult second =
      RunScanbenchIn(folder.path(), "batch --list lists/lib.txt --summary out-second --threads 1");
  EXPECT_EQ(second.exit_code, 0) << second.output;
  EXPECT_THAT(second.output, HasSubstr("3 sessions: 0 solved, 3 skipped, 0 failed"));
  const std::string second_csv = ReadText(folder / "out-second.csv");
  EXPECT_EQ(std::count(second_csv.begin(), second_csv.end(), '\n'), 4);
  EXPECT_THAT(second_csv, HasSubstr("/lib/s2,skipped,"));
  EXPECT_TRUE(fs::is_regular_file(folder / "out-second.json"));

  // A summary is never overwritten; a pattern that matches nothing and a bad shard are named.
  const CommandResult again = RunScanbenchIn(folder.path(), "batch --list lists/lib.txt --summary out-second");
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_THAT(again.output, HasSubstr("out-second.csv: exists"));
  const CommandResult nothing = RunScanbenchIn(folder.path(), "batch 'lib/x*'");
  EXPECT_EQ(nothing.exit_code, 1);
  EXPECT_THAT(nothing.output, HasSubstr("'lib/x*' matches no session"));
  const CommandResult bad_shard = RunScanbenchIn(folder.path(), "batch 'lib/s*' --shard 9/8");
  EXPECT_EQ(bad_shard.exit_code, 1);
  EXPECT_THAT(bad_shard.output, HasSubstr("--shard '9/8'"));

  // Shard 2 of 2 of the sorted s1..s4 is s2 and s4.
  const CommandResult shard = RunScanbenchIn(folder.path(), "batch 'lib/s*' --shard 2/2 --summary shard2");
  EXPECT_EQ(shard.exit_code, 0) << shard.output;
  EXPECT_THAT(shard.output, HasSubstr("2 sessions (shard 2/2 of 4): 0 solved, 2 skipped"));
  EXPECT_THAT(ReadText(folder / "shard2.csv"), HasSubstr("/lib/s4,skipped,"));
}

// Ctrl-C: exit code 130, the rest marked cancelled, no partial result; the rerun completes the batch.
TEST(BatchCliTest, InterruptCancelsAndTheRerunContinues) {
  testing::TemporaryFolder folder;
  const CommandResult simulated =
      RunScanbenchIn(folder.path(), "simulate source --width 96 --height 64 --render-threads 2");
  ASSERT_EQ(simulated.exit_code, 0) << simulated.output;
  fs::create_directories(folder / "lib");
  for (int i = 0; i < 10; ++i) fs::copy(folder / "source", folder / "lib" / CopyName(i),
                                        fs::copy_options::recursive);
  const fs::path log = folder / "log.txt";
  const std::string pattern = (folder / "lib" / "c*").string();
  const std::string summary = (folder / "interrupted").string();
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(fd, 1);
    ::dup2(fd, 2);
    ::execl(SCANBENCH_CLI, SCANBENCH_CLI, "batch", pattern.c_str(), "--jobs", "1", "--threads", "1", "--summary",
            summary.c_str(), static_cast<char*>(nullptr));
    ::_exit(127);
  }
  // Ctrl-C as soon as the first session has its complete result (a committed folder holds report.json).
  const fs::path first_results = folder / "lib" / "c0" / "results";
  auto first_is_solved = [&] {
    for (const auto& entry : fs::directory_iterator(first_results)) {
      if (fs::exists(entry.path() / "report.json") && !entry.path().filename().string().starts_with(".")) return true;
    }
    return false;
  };
  for (int i = 0; i < 6000 && !first_is_solved(); ++i) ::usleep(5000);
  ::kill(pid, SIGINT);
  int status = 0;
  ::waitpid(pid, &status, 0);
  const std::string output = ReadText(log);
  ASSERT_TRUE(WIFEXITED(status)) << output;
  ASSERT_EQ(WEXITSTATUS(status), 130) << output;
  EXPECT_THAT(output, HasSubstr("not started: the batch was cancelled"));
  EXPECT_THAT(ReadText(summary + ".csv"), HasSubstr(",cancelled,"));
  size_t solved = 0;
  for (int i = 0; i < 10; ++i) {
    const fs::path results = folder / "lib" / CopyName(i) / "results";
    for (const auto& entry : fs::directory_iterator(results)) {
      EXPECT_FALSE(entry.path().filename().string().starts_with(".")) << "partial result " << entry.path();
      ++solved;
    }
  }
  EXPECT_GE(solved, 1u);
  EXPECT_LT(solved, 10u);

  const CommandResult rerun = RunScanbenchIn(folder.path(), "batch 'lib/c*' --threads 1 --summary rerun");
  EXPECT_EQ(rerun.exit_code, 0) << rerun.output;
  EXPECT_THAT(rerun.output, HasSubstr("10 sessions: " + std::to_string(10 - solved) + " solved, " +
                                          std::to_string(solved) + " skipped, 0 failed, 0 cancelled"));
}

}  // namespace
}  // namespace scanbench
