#include "app/session/capture_folder.h"

#include <algorithm>
#include <fstream>
#include <sstream>

#include "app/io/file_util.h"
#include "app/session/session.h"

namespace scanbench {
namespace fs = std::filesystem;

CaptureFolderState InspectCaptureFolder(const fs::path& dir) {
  CaptureFolderState state;
  std::error_code error;
  if (!fs::is_directory(dir, error)) {
    state.exists = fs::exists(dir, error);
    if (state.exists) {
      state.kind = CaptureFolderState::Kind::kOccupied;  // a file where the folder should be
      state.problem = "is a file, not a folder";
    }
    return state;
  }
  state.exists = true;
  for (fs::directory_iterator it(dir, error), end; !error && it != end; it.increment(error)) {
    const std::string name = it->path().filename().string();
    if (name == kFolderLockFileName) continue;  // left by any capture that ran here, also a refused one
    std::error_code ignored;
    state.entries.push_back(name + (it->is_directory(ignored) ? "/" : ""));
  }
  std::sort(state.entries.begin(), state.entries.end());
  const fs::path manifest = dir / "session.json";
  if (std::find(state.entries.begin(), state.entries.end(), "session.json") == state.entries.end()) {
    state.kind = state.entries.empty() ? CaptureFolderState::Kind::kNew : CaptureFolderState::Kind::kOccupied;
    return state;
  }
  try {
    std::ifstream file(manifest);
    std::stringstream text;
    text << file.rdbuf();
    const Session session = SessionFromJson(text.str(), manifest.string());
    state.kind = session.capture_complete ? CaptureFolderState::Kind::kComplete
                                          : CaptureFolderState::Kind::kInterrupted;
    state.sample_name = session.sample_name;
    state.frames = static_cast<int>(session.frames.size());
    state.expected_frames = static_cast<int>(session.rig.leds.size()) + 1;
  } catch (const std::exception& failure) {
    state.kind = CaptureFolderState::Kind::kUnreadable;
    state.problem = failure.what();
  }
  return state;
}

std::string ListEntries(const std::vector<std::string>& entries, size_t shown) {
  std::string text;
  const size_t listed = std::min(shown, entries.size());
  for (size_t i = 0; i < listed; ++i) {
    text += (i == 0 ? "" : i + 1 == listed && listed == entries.size() ? " and " : ", ") + entries[i];
  }
  if (entries.size() > listed) text += " and " + std::to_string(entries.size() - listed) + " more";
  return text;
}

std::string CaptureFolderRefusal(const fs::path& dir, const CaptureFolderState& state, bool resume) {
  using Kind = CaptureFolderState::Kind;
  const std::string name = dir.string();
  const std::string progress = std::to_string(state.frames) + " of " + std::to_string(state.expected_frames) +
                               " frames";
  switch (state.kind) {
    case Kind::kNew:
      if (!resume) return "";
      return name + (state.exists ? " is empty" : " does not exist") +
             ": there is no interrupted capture to resume; start a new capture (without --resume)";
    case Kind::kInterrupted:
      if (resume) return "";
      return name + " holds an interrupted capture of '" + state.sample_name + "' (" + progress +
             "): resume it (capture --resume, or Resume on the Capture page), or capture into a new, empty folder";
    case Kind::kComplete:
      return name + " holds a complete session of '" + state.sample_name + "' (" + progress + "): " +
             (resume ? "nothing to resume; " : "") + "capture into a new, empty folder";
    case Kind::kUnreadable:
      return name + "/session.json cannot be read (" + state.problem + "): " +
             (resume ? "it cannot be resumed; " : "") + "capture into a new, empty folder";
    case Kind::kOccupied:
      if (!state.problem.empty()) return name + " " + state.problem + ": capture into a new, empty folder";
      return name + " is not empty (it holds " + ListEntries(state.entries) + ") and has no session.json" +
             (resume ? " to resume" : "") + ": capture into a new, empty folder";
  }
  return "";
}

void CheckCaptureFolder(const fs::path& dir, bool resume) {
  const std::string refusal = CaptureFolderRefusal(dir, InspectCaptureFolder(dir), resume);
  if (!refusal.empty()) throw SessionError(refusal);
}

}  // namespace scanbench
