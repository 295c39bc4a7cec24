// The CLI's progress lines without a terminal (issue #36 item 8): stages
// reported from two threads, as `capture --solve` does, print each quarter of
// each stage once, and the times (since the job started) never run backwards.
#include "app/cli/progress_bar.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace scanbench {
namespace {

std::string ReadAll(std::FILE* file) {
  std::rewind(file);
  std::string text;
  char buffer[4096];
  for (size_t n; (n = std::fread(buffer, 1, sizeof(buffer), file)) > 0;) text.append(buffer, n);
  return text;
}

TEST(ProgressBarTest, InterleavedStagesPrintEachQuarterOnceWithTimesThatNeverRunBackwards) {
  std::FILE* log = std::tmpfile();
  ASSERT_NE(log, nullptr);
  {
    ProgressBar bar(log, /*interactive=*/false);
    // Alternating, as the capture thread and the solve's writer report.
    for (int i = 0; i <= 20; ++i) {
      bar.Update({"capture", "", i / 20.0});
      bar.Update({"decode RAW", "", i / 40.0});
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    bar.Update({"capture", "", 0.5});  // a late, older report
    bar.Finish();
  }
  const std::string text = ReadAll(log);
  std::fclose(log);
  std::istringstream lines(text);
  const std::regex format(R"(^([a-z][a-z A-Z]*?) +(\d+)% +(\d+\.\d)s$)");
  std::map<std::string, std::vector<int>> percents;
  double last_seconds = 0;
  for (std::string line; std::getline(lines, line);) {
    std::smatch match;
    ASSERT_TRUE(std::regex_match(line, match, format)) << line;
    percents[match[1]].push_back(std::stoi(match[2]));
    const double seconds = std::stod(match[3]);
    EXPECT_GE(seconds, last_seconds) << line;
    last_seconds = seconds;
  }
  EXPECT_EQ(percents["capture"], (std::vector<int>{0, 25, 50, 75, 100})) << text;
  EXPECT_EQ(percents["decode RAW"], (std::vector<int>{0, 25, 50})) << text;
}

// On a terminal the line is redrawn; a stage seen before (reported again by
// another thread) redraws in place instead of opening a line per switch.
TEST(ProgressBarTest, InteractiveOpensALineOnlyForANewStage) {
  std::FILE* tty = std::tmpfile();
  ASSERT_NE(tty, nullptr);
  {
    ProgressBar bar(tty, /*interactive=*/true);
    for (int i = 0; i < 10; ++i) {
      bar.Update({"capture", "", i / 10.0});
      bar.Update({"decode RAW", "", i / 20.0});
    }
  }
  const std::string text = ReadAll(tty);
  std::fclose(tty);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 2) << "one line per stage";
}

}  // namespace
}  // namespace scanbench
