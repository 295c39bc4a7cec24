// Whether a folder may take a capture (issue #36 item 3): a new capture goes
// into a new, empty folder only; a resume only into an interrupted session.
// The one rule the CLI's `capture [--resume]`, the GUI's Start capture /
// Resume and CaptureController all apply, with one wording.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace scanbench {

struct CaptureFolderState {
  enum class Kind {
    kNew,          // missing, or empty (a lock file left by an earlier try does not count)
    kInterrupted,  // session.json of a capture that did not finish
    kComplete,     // session.json of a finished capture
    kUnreadable,   // session.json that does not parse or check
    kOccupied,     // other files, no session.json
  };
  Kind kind = Kind::kNew;
  bool exists = false;
  std::vector<std::string> entries;  // what is there, sorted, folders with a '/' (all of them)
  std::string sample_name;           // kInterrupted, kComplete
  int frames = 0;                    // journalled (kInterrupted, kComplete)
  int expected_frames = 0;           // the dark frame and one per LED of the recorded rig
  std::string problem;               // kUnreadable: the loader's message
};

// Looks at `dir` and its session.json (parsed and checked, no frame read).
CaptureFolderState InspectCaptureFolder(const std::filesystem::path& dir);

// "" when a new capture (resume false) or a resume (resume true) may use the
// folder, else why not, naming the folder, what is there and what to do.
std::string CaptureFolderRefusal(const std::filesystem::path& dir, const CaptureFolderState& state, bool resume);

// Throws SessionError with CaptureFolderRefusal's text unless it is "".
void CheckCaptureFolder(const std::filesystem::path& dir, bool resume);

// "notes.txt, frames/ and 3 more": the first `shown` entries.
std::string ListEntries(const std::vector<std::string>& entries, size_t shown = 3);

}  // namespace scanbench
