// The Sessions page's "Import RAW folder…" through the real widgets: a folder
// of the simulated camera's DNGs under card names becomes a listed, complete
// session; a refused import says which file and writes nothing.
#include <QLabel>
#include <QPushButton>
#include <QSettings>
#include <QTest>
#include <QTreeWidget>

#include <filesystem>
#include <fstream>

#include "app/controllers/simulate_controller.h"
#include "app/gui/controller_runner.h"
#include "app/gui/sessions_page.h"
#include "app/session/rig_json.h"
#include "app/session/session.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace fs = std::filesystem;

class SessionsImportTest : public QObject {
  Q_OBJECT

 private:
  testing::TemporaryFolder folder_;
  fs::path card_;
  fs::path rig_file_;
  std::unique_ptr<ControllerRunner> runner_;
  std::unique_ptr<SessionsPage> page_;

  QString Status() const { return page_->findChild<QLabel*>("sessionsStatus")->text(); }

 private slots:
  void initTestCase() {
    QCoreApplication::setOrganizationName("scanbench");
    QCoreApplication::setApplicationName("scanbench-gui-sessions-import-test");
    QSettings().clear();
    SimulateOptions simulate;
    simulate.rig.width = 200;
    simulate.rig.height = 132;
    const fs::path original = folder_ / "rendered" / "original";
    SimulateController(original, simulate).Run();
    const Session session = LoadSession(original);
    rig_file_ = folder_ / "rendered" / "bench.json";
    std::ofstream(rig_file_) << RigDescriptionToJson(session.rig);
    card_ = folder_ / "card" / "DCIM_100";
    fs::create_directories(card_);
    fs::copy_file(original / FindDarkFrame(session)->file, card_ / "DSC_0101.dng");
    for (int k = 0; k < 10; ++k) {
      fs::copy_file(original / FindLedFrame(session, k)->file, card_ / ("DSC_01" + std::to_string(10 + k) + ".dng"));
    }
    fs::create_directories(folder_ / "sessions");
    runner_ = std::make_unique<ControllerRunner>();
    page_ = std::make_unique<SessionsPage>(runner_.get());
    page_->SetRoot(QString::fromStdString((folder_ / "sessions").string()));
  }

  void cleanupTestCase() {
    page_.reset();
    runner_.reset();
  }

  void ImportButtonIsThere() {
    auto* button = page_->findChild<QPushButton*>("importRawFolder");
    QVERIFY(button != nullptr);
    QCOMPARE(button->text(), QStringLiteral("Import RAW folder…"));
  }

  void RefusalNamesTheFile() {
    // A JPEG beside the RAWs (RAW + JPEG shooting).
    std::ofstream(card_ / "DSC_0121.JPG") << "\xFF\xD8\xFF\xE0";
    QVERIFY(page_->ImportRawFolder(QString::fromStdString(card_.string()), QString::fromStdString(rig_file_.string())));
    QVERIFY(runner_->Wait(60000));
    QVERIFY2(Status().contains("Import refused") && Status().contains("DSC_0121.JPG: is a JPEG"), qPrintable(Status()));
    QVERIFY(!fs::exists(folder_ / "sessions" / "DCIM_100"));
    fs::remove(card_ / "DSC_0121.JPG");
  }

  void ImportsIntoTheListedFolder() {
    QVERIFY(page_->ImportRawFolder(QString::fromStdString(card_.string()), QString::fromStdString(rig_file_.string())));
    QVERIFY(runner_->Wait(60000));
    QVERIFY2(Status().contains("Imported 11 frames"), qPrintable(Status()));
    const fs::path session_dir = folder_ / "sessions" / "DCIM_100";
    const Session session = LoadSession(session_dir);
    QVERIFY(session.capture_complete);
    QCOMPARE(QString::fromStdString(FindLedFrame(session, 9)->source),
             QString::fromStdString((card_ / "DSC_0119.dng").string()));
    // Listed and selected, ready to solve.
    auto* sessions = page_->findChild<QTreeWidget*>();
    QVERIFY(sessions->currentItem() != nullptr);
    QCOMPARE(sessions->currentItem()->text(0), QStringLiteral("DCIM_100"));
    QCOMPARE(sessions->currentItem()->text(3), QStringLiteral("complete"));
  }
};

}  // namespace scanbench

QTEST_MAIN(scanbench::SessionsImportTest)
#include "sessions_import_test.moc"
