// import (a folder of RAW files from another tool -> a session) and
// bench init (a rig description template for a new bench).
#include <filesystem>
#include <iostream>
#include <memory>

#include "app/cli/command_util.h"
#include "app/cli/commands.h"
#include "app/cli/run_controller.h"
#include "app/controllers/import_controller.h"
#include "app/io/file_util.h"
#include "app/session/rig_json.h"
#include "app/sim/bench_template.h"
#include "core/format.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

struct ImportState {
  fs::path raw_folder;
  fs::path session_dir;
  fs::path rig_file;
  ImportOptions options;
};

int RunImport(ImportState& state) {
  if (state.options.sample_name.empty()) {
    state.options.sample_name = fs::absolute(state.raw_folder).lexically_normal().filename().string();
  }
  ImportController import(state.raw_folder, state.session_dir, LoadRigDescriptionFile(state.rig_file.string()),
                          state.options);
  const int code = RunController(import);
  if (code != kExitSuccess) return code;
  const ImportSummary& summary = import.summary();
  std::cout << "Session " << fs::absolute(state.session_dir).string() << ": " << summary.frames_copied
            << " frames copied, " << summary.frames_resumed << " already there (" << summary.camera << ", matched by "
            << summary.match << ") in " << Significant(summary.seconds) << " s\n";
  for (const ImportedFrame& frame : summary.frames) std::cout << "  " << frame.frame << " <- " << frame.source << "\n";
  for (const std::string& name : summary.ignored) std::cout << "  not used: " << name << "\n";
  for (const std::string& warning : summary.warnings) std::cout << "  warning: " << warning << "\n";
  return code;
}

void RegisterImport(CLI::App& app, int* exit_code) {
  auto state = std::make_shared<ImportState>();
  CLI::App* command = app.add_subcommand(
      "import",
      "Make a session from a folder of RAW files (NEF, CR2, ARW, DNG... from digiCamControl, gphoto2 or the card): "
      "every file opened with LibRaw and checked, then copied (never moved) with its SHA-256. An interrupted import "
      "resumes when started again on the same folders. Without --pattern or --list, frames are taken in capture "
      "order (the RAW's capture time, then the file name): the dark frame first (unless --dark names it), then "
      "LED 0, 1, ... as `scanbench capture` takes them.");
  command->add_option("raw_folder", state->raw_folder, "Folder of RAW files (read only)")->required();
  command->add_option("session", state->session_dir, "Session folder to write or resume (outside raw_folder)")
      ->required();
  command->add_option("--rig", state->rig_file, "Rig description JSON, as capture --rig-file reads it")->required();
  auto* pattern = command->add_option(
      "--pattern", state->options.pattern,
      "File name (without extension) with {led} for the LED's index in the rig, 0-based, e.g. 'led_{led}'");
  command->add_option("--list", state->options.list_file,
                      "List file: lines 'dark FILE' and 'INDEX FILE' (INDEX 0-based into the rig's LEDs)")
      ->excludes(pattern);
  command->add_option("--dark", state->options.dark_file,
                      "The dark frame, a file of raw_folder by name or path (default: a file named dark.*, else "
                      "the first in capture order)");
  command->add_option("--sample-name", state->options.sample_name,
                      "Sample name recorded in session.json (default: the folder's name)");
  command->add_option("--notes", state->options.notes, "Free text recorded in session.json");
  command->callback([state, exit_code] { Guarded(exit_code, [&] { return RunImport(*state); }); });
}

struct BenchInitState {
  fs::path output;
  BenchTemplateOptions options;
  bool force = false;
};

int RunBenchInit(const BenchInitState& state) {
  const RigDescription rig = MakeBenchTemplate(state.options);
  WriteFileAtomic(state.output, RigDescriptionToJson(rig),
                  state.force ? OverwritePolicy::kReplace : OverwritePolicy::kRefuse);
  std::cout << "Wrote " << state.output.string() << ": " << rig.name << ", " << rig.leds.size()
            << " LEDs. Measure or calibrate before the first scan:\n";
  for (const std::string& field : BenchFieldsToMeasure(rig)) std::cout << "  " << field << "\n";
  return kExitSuccess;
}

void RegisterBenchInit(CLI::App& app, int* exit_code) {
  CLI::App* bench = app.add_subcommand("bench", "The bench description: bench init");
  bench->require_subcommand(1);
  auto state = std::make_shared<BenchInitState>();
  BenchTemplateOptions& o = state->options;
  CLI::App* command = bench->add_subcommand(
      "init", "Write a rig description (as capture --rig-file and import --rig read it) for a bench of LEDs on rings "
              "aimed at the sample centre and a camera looking straight down; prints the fields to measure");
  command->add_option("output", state->output, "Rig description JSON to write")->required();
  SetsField(command->add_option("--name", o.name, "Bench name recorded in the rig"), "BenchTemplateOptions.name")
      ->capture_default_str();
  SetsField(
      command->add_option("--leds", o.num_leds, "Number of LEDs, 1..10 (LED k on firmware channel k, pin D(2+k))"),
      "BenchTemplateOptions.num_leds")
      ->capture_default_str();
  SetsField(command->add_option("--ring-radii-mm", o.ring_radii_mm,
                                "Horizontal distance of each ring from the sample centre, mm; LEDs dealt round-robin"),
            {"BenchTemplateOptions.ring_radii_mm", "BenchTemplateOptions.ring_radii_mm[0]",
             "BenchTemplateOptions.ring_radii_mm[1]", "BenchTemplateOptions.ring_radii_mm[2]",
             "BenchTemplateOptions.ring_radii_mm[3]"})
      ->delimiter(',')
      ->capture_default_str();
  SetsField(command->add_option("--ring-heights-mm", o.ring_heights_mm, "Height of each ring above the table, mm"),
            {"BenchTemplateOptions.ring_heights_mm", "BenchTemplateOptions.ring_heights_mm[0]",
             "BenchTemplateOptions.ring_heights_mm[1]", "BenchTemplateOptions.ring_heights_mm[2]",
             "BenchTemplateOptions.ring_heights_mm[3]"})
      ->delimiter(',')
      ->capture_default_str();
  command->add_option("--camera", o.camera, "Camera preset")->check(CLI::IsMember({"d5100"}))->capture_default_str();
  SetsField(command->add_option("--lens-mm", o.lens_focal_mm, "Lens focal length, mm"),
            "BenchTemplateOptions.lens_focal_mm")
      ->capture_default_str();
  SetsField(command->add_option("--camera-height-mm", o.camera_height_mm, "Camera (lens) height above the table, mm"),
            "BenchTemplateOptions.camera_height_mm")
      ->capture_default_str();
  SetsField(command->add_option("--mu", o.mu, "LED angular falloff exponent, cos^mu (Lambertian: 1)"),
            "BenchTemplateOptions.mu")
      ->capture_default_str();
  command->add_flag("--force", state->force, "Replace an existing output file");
  command->callback([state, exit_code] { Guarded(exit_code, [&] { return RunBenchInit(*state); }); });
}

}  // namespace

void RegisterImportCommands(CLI::App& app, int* exit_code) {
  RegisterImport(app, exit_code);
  RegisterBenchInit(app, exit_code);
}

}  // namespace scanbench
