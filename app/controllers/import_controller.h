// scanbench import: a folder of RAW files taken by another tool
// (digiCamControl, gphoto2, straight from the card) becomes a session, as if
// `capture` had written it. Every file is opened with LibRaw first and
// checked against the others (one camera, one size and orientation, one ISO
// and aperture; a differing exposure is a warning, the solve compensates);
// the frames are then copied, never moved, into the session's frames/ with
// their SHA-256, session.json journalled after each one, and the source path
// of every frame recorded. An interrupted import resumes from the journal.
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "app/controllers/base_controller.h"
#include "app/session/session.h"
#include "calibration/rig.h"

namespace scanbench {

struct ImportOptions {
  std::string sample_name;                 // required; recorded in session.json
  std::string notes;
  // How files are matched to LEDs; at most one of the two. Neither: capture
  // order (the RAW's capture time, then the file name), dark frame first.
  // pattern: the file name without extension, "{led}" standing for the LED's
  // index in the rig (0-based; leading zeros allowed), e.g. "led_{led}".
  std::string pattern;
  // list_file: lines "dark FILE" and "INDEX FILE" (INDEX 0-based into the
  // rig's LEDs); FILE a name in the folder or a path; '#' starts a comment.
  std::filesystem::path list_file;
  // The dark frame: a file of the folder, by name or by path. Empty: the file
  // named "dark.*" if there is one, else (capture order only) the first file.
  std::filesystem::path dark_file;

  void Check() const;
};

// One frame as the import saw it.
struct ImportedFrame {
  std::string frame;        // "dark", "led_03"
  std::string source;       // absolute path of the original
  double exposure_time_s = 0;
  bool resumed = false;     // already in the session from an interrupted import
};

struct ImportSummary {
  std::filesystem::path session_dir;
  std::string match;                   // as recorded in session.json's "import.match"
  std::string camera;                  // "NIKON D5100 (serial ...)"
  std::vector<ImportedFrame> frames;   // dark first, then LED 0, 1, ...
  std::vector<std::string> ignored;    // files of the folder the pattern or list did not use
  std::vector<std::string> warnings;   // e.g. differing exposure times (the solve compensates)
  int frames_copied = 0;               // this run
  int frames_resumed = 0;
  double seconds = 0;
};

// The frames of an import, dark first then LED 0..N-1, as matched from the
// folder's files by `options`. `capture_time_of(file)` ("YYYY:MM:DD HH:MM:SS",
// "" if unknown) is asked in capture order only; it opens the file. Throws
// std::runtime_error naming the file (or the LED) for a missing LED, two
// files for one frame, a file listed twice, a JPEG by its extension, or a
// listed file that is not in `folder`.
struct ImportPlanEntry {
  std::optional<int> led;       // nullopt = the dark frame
  std::filesystem::path file;   // absolute
};
struct ImportPlan {
  std::vector<ImportPlanEntry> entries;
  std::vector<std::string> ignored;  // file names of the folder not used
  std::vector<std::string> warnings;
  std::string match;                 // "capture order", "pattern '...'", "list /abs/list.txt"
};
ImportPlan PlanImport(const std::filesystem::path& folder, int num_leds, const ImportOptions& options,
                      const std::function<std::string(const std::filesystem::path&)>& capture_time_of);

struct ImportFileFacts;  // what one RAW file says about itself (import_controller.cc)

class ImportController : public BaseController {
 public:
  ImportController(std::filesystem::path raw_folder, std::filesystem::path session_dir, RigDescription rig,
                   ImportOptions options);
  void Run() override;
  const ImportSummary& summary() const { return summary_; }

 private:
  // Run's steps.
  void CheckRigAndFolders() const;
  ImportPlan Match(std::map<std::filesystem::path, ImportFileFacts>* opened);
  std::vector<ImportFileFacts> OpenFrames(const ImportPlan& plan,
                                          std::map<std::filesystem::path, ImportFileFacts>* opened,
                                          std::vector<std::string>* names);
  Session ResumeOrCreateSession(const ImportPlan& plan, const std::vector<ImportFileFacts>& facts);
  bool IsImportedAlready(const Session& session, const ImportPlanEntry& entry, const ImportFileFacts& facts,
                         const std::string& name) const;
  void CopyFrame(const ImportPlanEntry& entry, const ImportFileFacts& facts, Session* session);
  const ImportFileFacts& Open(const std::filesystem::path& file,
                              std::map<std::filesystem::path, ImportFileFacts>* opened);

  std::filesystem::path raw_folder_;
  std::filesystem::path session_dir_;
  RigDescription rig_;
  ImportOptions options_;
  ImportSummary summary_;
};

}  // namespace scanbench
