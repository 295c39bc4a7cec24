// The command line's pieces below the commands (issue #36): option errors in
// the user's words, "did you mean", and --help wrapped to the terminal.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "app/cli/help_format.h"
#include "app/cli/option_fields.h"
#include "app/cli/parse_errors.h"
#include "core/field_error.h"

namespace scanbench {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;

TEST(EditDistanceTest, CountsInsertionsDeletionsSubstitutionsAndSwaps) {
  EXPECT_EQ(EditDistance("width", "width"), 0u);
  EXPECT_EQ(EditDistance("widht", "width"), 1u);  // two neighbours swapped
  EXPECT_EQ(EditDistance("widt", "width"), 1u);
  EXPECT_EQ(EditDistance("wdith", "width"), 1u);
  EXPECT_EQ(EditDistance("with", "width"), 1u);
  EXPECT_EQ(EditDistance("height", "width"), 4u);
  EXPECT_EQ(EditDistance("", "abc"), 3u);
}

TEST(ClosestNamesTest, SuggestsLikelyTyposOnly) {
  const std::vector<std::string> options = {"--width", "--height", "--seed", "--scene-seed", "--threads", "-j"};
  EXPECT_THAT(ClosestNames("--widht", options), ElementsAre("--width"));
  EXPECT_THAT(ClosestNames("--heigth", options), ElementsAre("--height"));
  EXPECT_THAT(ClosestNames("--thread", options), ElementsAre("--threads"));
  EXPECT_THAT(ClosestNames("--scene", options), ElementsAre("--scene-seed")) << "the start of a name";
  EXPECT_THAT(ClosestNames("--colour", options), IsEmpty());
  EXPECT_THAT(ClosestNames("--x", options), IsEmpty()) << "one letter is no evidence";
  EXPECT_THAT(ClosestNames("slove", {"solve", "simulate", "demo"}), ElementsAre("solve"));
}

TEST(WrapTextTest, WrapsAtSpacesKeepingLineBreaksAndTableRows) {
  EXPECT_THAT(WrapText("one two three four", 9), ElementsAre("one two", "three", "four"));
  EXPECT_THAT(WrapText("short\nlines stay", 40), ElementsAre("short", "lines stay"));
  EXPECT_THAT(WrapText("averyveryverylongword x", 8), ElementsAre("averyveryverylongword", "x"));
  // A table row continues under its description.
  EXPECT_THAT(WrapText("lsq     least squares on every sample", 24),
              ElementsAre("lsq     least squares on", "        every sample"));
}

TEST(WrappingFormatterTest, WrapsEveryLineAndShowsFlagsByName) {
  CLI::App app{"A tool whose description is long enough to need more than one line at forty columns"};
  app.formatter(std::make_shared<WrappingFormatter>(40));
  bool blend = true;
  int width = 0;
  app.add_flag("--blend,!--no-blend", blend, "Blend the two solves, on by default; --no-blend: the first alone");
  app.add_option("--width", width, "Image width in pixels, a fairly long description as well");
  const std::string help = app.help();
  EXPECT_THAT(help, HasSubstr("--blend, --no-blend"));
  EXPECT_THAT(help, ::testing::Not(HasSubstr("{false}")));
  size_t start = 0;
  while (start < help.size()) {
    const size_t end = std::min(help.find('\n', start), help.size());
    EXPECT_LE(end - start, 40u) << help.substr(start, end - start);
    start = end + 1;
  }
}

TEST(CommandLineMessageTest, NamesTheOptionThatSetsTheField) {
  CLI::App app{"test"};
  CLI::App* command = app.add_subcommand("simulate", "");
  CLI::App* other = app.add_subcommand("other", "");
  int width = 0, tile = 0, blend = 0;
  SetsField(command->add_option("--width", width, ""), "RigOptions.width");
  SetsField(command->add_option("--tile-size", tile, ""), "CropOptions.tile_width");
  SetsField(command->add_option("--tile-blend", blend, ""), "CropOptions.blend_width_px");
  SetsField(other->add_option("--image-width", width, ""), "RigOptions.width");
  app.parse(std::vector<std::string>{"-5", "--width", "simulate"});  // reversed: CLI11 takes them from the back

  const FieldValueError error = FieldError("RigOptions", "width", -5, "must be > 0");
  EXPECT_EQ(std::string(error.what()), "RigOptions.width = -5 must be > 0") << "library users keep the message";
  EXPECT_EQ(CommandLineMessage(error, ParsedCommands(&app)), "--width -5: must be > 0");
  EXPECT_EQ(CommandLineMessage(error, {&app, other}), "--image-width -5 (the default): must be > 0")
      << "the command being run decides";
  EXPECT_EQ(CommandLineMessage(FieldError("CropOptions", "blend_width_px", 32, "must be <= tile_width (7)"),
                               ParsedCommands(&app)),
            "--tile-blend 32 (the default): must be <= --tile-size (7)");
  const FieldValueError unknown = FieldError("RigOptions", "height", 0, "must be > 0");
  EXPECT_EQ(CommandLineMessage(unknown, ParsedCommands(&app)), "RigOptions.height = 0 must be > 0");
  EXPECT_EQ(CommandLineMessage(std::runtime_error("no such file"), ParsedCommands(&app)), "no such file");
}

}  // namespace
}  // namespace scanbench
