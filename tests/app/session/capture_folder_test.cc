// Whether a folder takes a new capture or a resume (issue #36 item 3).
#include "app/session/capture_folder.h"

#include "app/io/file_util.h"
#include "tests/app/session/session_test_util.h"

namespace scanbench {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using testing_util::FakeRawBytes;
using testing_util::MakeFrameRecord;
using testing_util::MakeTestSession;
using testing_util::TemporaryFolder;
using testing_util::WriteText;
using Kind = CaptureFolderState::Kind;

TEST(CaptureFolderTest, AMissingOrEmptyFolderTakesANewCaptureOnly) {
  TemporaryFolder folder;
  const fs::path missing = folder / "new";
  EXPECT_EQ(InspectCaptureFolder(missing).kind, Kind::kNew);
  EXPECT_EQ(CaptureFolderRefusal(missing, InspectCaptureFolder(missing), false), "");
  EXPECT_THAT(CaptureFolderRefusal(missing, InspectCaptureFolder(missing), true),
              AllOf(HasSubstr(missing.string() + " does not exist"), HasSubstr("no interrupted capture to resume")));
  // The lock file a refused or failed capture leaves does not count.
  fs::create_directories(missing);
  WriteText(missing / kFolderLockFileName, "123\n");
  EXPECT_EQ(InspectCaptureFolder(missing).kind, Kind::kNew);
  EXPECT_NO_THROW(CheckCaptureFolder(missing, false));
  EXPECT_THROW(CheckCaptureFolder(missing, true), SessionError);
}

TEST(CaptureFolderTest, OtherFilesAreNamedAndRefused) {
  TemporaryFolder folder;
  const fs::path dir = folder / "busy";
  fs::create_directories(dir / "raw");
  for (const char* name : {"a.txt", "b.txt", "c.txt", "d.txt"}) WriteText(dir / name, "x");
  const CaptureFolderState state = InspectCaptureFolder(dir);
  EXPECT_EQ(state.kind, Kind::kOccupied);
  EXPECT_EQ(state.entries.size(), 5u);
  EXPECT_EQ(CaptureFolderRefusal(dir, state, false),
            dir.string() + " is not empty (it holds a.txt, b.txt, c.txt and 2 more) and has no session.json: capture "
                           "into a new, empty folder");
  EXPECT_THAT(CaptureFolderRefusal(dir, state, true), HasSubstr("has no session.json to resume"));
  EXPECT_EQ(ListEntries({"frames/", "notes.txt"}), "frames/ and notes.txt");
  WriteText(folder / "file", "x");
  EXPECT_THAT(CaptureFolderRefusal(folder / "file", InspectCaptureFolder(folder / "file"), false),
              HasSubstr("is a file, not a folder"));
}

TEST(CaptureFolderTest, AnInterruptedSessionResumesOnlyWhenAskedAndACompleteOneNever) {
  TemporaryFolder folder;
  const fs::path dir = folder / "session";
  Session session = MakeTestSession(3);
  CreateSessionFolder(dir);
  WriteSessionManifest(dir, session);
  AddFrame(dir, session, MakeFrameRecord(FrameKind::kDark, -1), FakeRawBytes(0));
  AddFrame(dir, session, MakeFrameRecord(FrameKind::kLed, 0), FakeRawBytes(1));
  CaptureFolderState state = InspectCaptureFolder(dir);
  EXPECT_EQ(state.kind, Kind::kInterrupted);
  EXPECT_EQ(state.frames, 2);
  EXPECT_EQ(state.expected_frames, 4);
  EXPECT_EQ(CaptureFolderRefusal(dir, state, true), "");
  EXPECT_THAT(CaptureFolderRefusal(dir, state, false),
              AllOf(HasSubstr("holds an interrupted capture of 'denim-0042' (2 of 4 frames)"), HasSubstr("--resume"),
                    HasSubstr("Resume on the Capture page")));

  AddFrame(dir, session, MakeFrameRecord(FrameKind::kLed, 1), FakeRawBytes(2));
  AddFrame(dir, session, MakeFrameRecord(FrameKind::kLed, 2), FakeRawBytes(3));
  session.capture_complete = true;
  WriteSessionManifest(dir, session);
  state = InspectCaptureFolder(dir);
  EXPECT_EQ(state.kind, Kind::kComplete);
  EXPECT_THAT(CaptureFolderRefusal(dir, state, false), HasSubstr("holds a complete session of 'denim-0042' (4 of 4"));
  EXPECT_THAT(CaptureFolderRefusal(dir, state, true), HasSubstr("nothing to resume"));

  WriteText(dir / "session.json", "{ not json");
  state = InspectCaptureFolder(dir);
  EXPECT_EQ(state.kind, Kind::kUnreadable);
  EXPECT_THAT(CaptureFolderRefusal(dir, state, true),
              AllOf(HasSubstr(dir.string() + "/session.json cannot be read"), HasSubstr("cannot be resumed")));
}

}  // namespace
}  // namespace scanbench
