// The Sessions page's solve form and the export dialog, through the real
// widgets on a simulated session with ground truth: the method chosen is the
// method the result's report.json records; an export writes its own folder
// with material.json in the preset and convention chosen, reports the height
// error, and a cancelled export leaves no folder.
#include <QComboBox>
#include <QCheckBox>
#include <QDoubleSpinBox>
#include <QFile>
#include <QJsonDocument>
#include <QJsonObject>
#include <QLabel>
#include <QPointer>
#include <QPushButton>
#include <QScopeGuard>
#include <QSemaphore>
#include <QSettings>
#include <QTest>
#include <QTreeWidget>

#include <filesystem>

#include "app/controllers/simulate_controller.h"
#include "app/gui/controller_runner.h"
#include "app/gui/export_dialog.h"
#include "app/gui/main_window.h"
#include "app/gui/results_page.h"
#include "app/gui/sessions_page.h"
#include "solver/photometric_methods.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {
QJsonObject ReadJson(const fs::path& path) {
  QFile file(QString::fromStdString(path.string()));
  if (!file.open(QIODevice::ReadOnly)) return {};
  return QJsonDocument::fromJson(file.readAll()).object();
}

size_t CountFolders(const fs::path& dir) {
  size_t count = 0;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(dir, error)) count += entry.is_directory();
  return count;
}
}  // namespace

class SessionsExportTest : public QObject {
  Q_OBJECT

 private:
  template <typename T>
  T* Find(QObject* parent, const char* name) {
    T* widget = parent->findChild<T*>(QString::fromLatin1(name));
    if (!widget) qFatal("no widget %s", name);
    return widget;
  }

  ControllerRunner::Outcome ClickAndWait(QPushButton* button, int timeout_ms = 120000) {
    ControllerRunner::Outcome outcome = ControllerRunner::Outcome::kFailed;
    auto connection = connect(window_->runner(), &ControllerRunner::Finished, this,
                              [&outcome, this](ControllerRunner::Outcome result, const QString& message) {
                                outcome = result;
                                last_message_ = message;
                              });
    QTest::mouseClick(button, Qt::LeftButton);
    if (!window_->runner()->Wait(timeout_ms)) qWarning("job still running");
    disconnect(connection);
    return outcome;
  }

  testing::TemporaryFolder folder_;
  fs::path session_;
  std::unique_ptr<MainWindow> window_;
  QString last_message_;

 private slots:
  void initTestCase() {
    QCoreApplication::setOrganizationName("scanbench");
    QCoreApplication::setApplicationName("scanbench-gui-sessions-export-test");
    QSettings().clear();
    session_ = folder_ / "twill";
    SimulateOptions simulate;
    simulate.rig.width = 200;
    simulate.rig.height = 132;
    SimulateController(session_, simulate).Run();
    window_ = std::make_unique<MainWindow>();
    window_->resize(1200, 800);
    window_->show();
  }

  void cleanupTestCase() { window_.reset(); }

  void ResolveRecordsTheChosenMethod() {
    window_->ShowPage(MainWindow::kSessionsPage);
    SessionsPage* sessions = window_->sessions();
    sessions->SetRoot(QString::fromStdString(folder_.path().string()));
    QVERIFY(sessions->SelectSession(QString::fromStdString(session_.string())));
    auto* method = Find<QComboBox>(sessions, "solverMethod");
    // Every method of the method table is offered in its order, each with its
    // one-line description (the default's marked); adaptive first chosen.
    QCOMPARE(method->count(), int(PhotometricMethods().size()));
    for (const PhotometricMethodRow& row : PhotometricMethods()) {
      const int index = int(row.method);
      QCOMPARE(method->itemText(index), QString::fromLatin1(row.name));
      QCOMPARE(method->itemData(index).toString(), QString::fromLatin1(row.name));
      const QString tip = method->itemData(index, Qt::ToolTipRole).toString();
      QVERIFY2(tip.startsWith(QString::fromUtf8(row.description)), row.name);
      QCOMPARE(tip.endsWith(" (default)"), row.method == PhotometricSolverOptions().method);
    }
    QCOMPARE(method->currentText(), QStringLiteral("adaptive"));
    QVERIFY(!Find<QLabel>(sessions, "solverMethodDescription")->text().isEmpty());
    method->setCurrentIndex(method->findText("normal_equations"));
    QVERIFY(Find<QLabel>(sessions, "solverMethodDescription")->text().contains("normal equations"));
    Find<QDoubleSpinBox>(sessions, "shadowLevel")->setValue(0.004);
    const SolveOptions options = sessions->SolveOptionsFromWidgets();
    QCOMPARE(options.solver.method, PhotometricSolverOptions::Method::kNormalEquations);
    QCOMPARE(options.solver.min_sample_value, 0.004);

    QCOMPARE(ClickAndWait(Find<QPushButton>(sessions, "resolveSession")), ControllerRunner::Outcome::kSucceeded);
    const fs::path result = window_->results()->result_dir();
    QCOMPARE(result.parent_path().parent_path(), session_);
    const QJsonObject report = ReadJson(result / "report.json");
    QCOMPARE(report["solver"].toObject()["method"].toString(), QStringLiteral("normal_equations"));
    QVERIFY2(QString::fromStdString(result.filename().string()).endsWith("normal_equations"), result.c_str());
  }

  void ExportWritesMaterialJsonInTheChosenPreset() {
    ResultsPage* results = window_->results();
    window_->ShowPage(MainWindow::kResultsPage);
    QTest::mouseClick(Find<QPushButton>(results, "exportResult"), Qt::LeftButton);
    auto* dialog = results->findChild<ExportDialog*>();
    QVERIFY(dialog != nullptr);
    QVERIFY(dialog->isVisible());
    QCOMPARE(dialog->result_dir(), results->result_dir());
    auto* preset = Find<QComboBox>(dialog, "exportPreset");
    preset->setCurrentIndex(preset->findData(int(ExportOptions::Preset::kLinearExr)));
    auto* convention = Find<QComboBox>(dialog, "normalConvention");
    convention->setCurrentIndex(convention->findData(int(ExportOptions::NormalConvention::kDirectX)));
    Find<QCheckBox>(dialog, "tileable")->setChecked(true);
    QVERIFY(Find<QCheckBox>(dialog, "previewPage")->isChecked());  // on by default
    QVERIFY(!Find<QPushButton>(dialog, "openPreview")->isEnabled());
    QVERIFY(dialog->PreviewUrl().isEmpty());

    QCOMPARE(ClickAndWait(Find<QPushButton>(dialog, "startExport")), ControllerRunner::Outcome::kSucceeded);
    const fs::path export_dir = dialog->export_dir();
    QVERIFY2(fs::is_directory(export_dir), qPrintable(last_message_));
    QCOMPARE(export_dir.parent_path(), session_ / "exports");
    const QJsonObject material = ReadJson(export_dir / "material.json");
    QCOMPARE(material["preset"].toString(), QStringLiteral("exr"));
    QCOMPARE(material["normal_convention"].toString(), QStringLiteral("directx"));
    QCOMPARE(material["options"].toObject()["tileable"].toBool(), true);
    QCOMPARE(material["source"].toObject()["solver_method"].toString(), QStringLiteral("normal_equations"));
    // The dialog names the folder and, for a session with ground truth, the height error.
    const QString status = Find<QLabel>(dialog, "exportStatus")->text();
    QVERIFY2(status.contains(QString::fromStdString(export_dir.string())), qPrintable(status));
    QVERIFY2(status.contains("height error"), qPrintable(status));
    QVERIFY(Find<QPushButton>(dialog, "openExportFolder")->isEnabled());
    // "Open preview" opens the export's preview.html (listed in material.json) as a file:// URL.
    QVERIFY(Find<QPushButton>(dialog, "openPreview")->isEnabled());
    const QUrl preview = dialog->PreviewUrl();
    QVERIFY(preview.isLocalFile());
    QCOMPARE(fs::path(preview.toLocalFile().toStdString()), export_dir / "preview.html");
    QVERIFY(fs::is_regular_file(export_dir / "preview.html"));
    QCOMPARE(material["files"].toObject()["preview"].toObject()["path"].toString(), QStringLiteral("preview.html"));
  }

  void ExportWithoutPreviewLeavesOpenPreviewDisabled() {
    ResultsPage* results = window_->results();
    ExportDialog* dialog = results->OpenExportDialog();
    QVERIFY(dialog != nullptr);
    Find<QCheckBox>(dialog, "previewPage")->setChecked(false);
    QVERIFY(!dialog->OptionsFromWidgets().preview_page);
    QCOMPARE(ClickAndWait(Find<QPushButton>(dialog, "startExport")), ControllerRunner::Outcome::kSucceeded);
    QVERIFY(!fs::exists(dialog->export_dir() / "preview.html"));
    QVERIFY(!Find<QPushButton>(dialog, "openPreview")->isEnabled());
    QVERIFY(dialog->PreviewUrl().isEmpty());
    QSettings().remove("export/preview_page");  // StartExport kept the choice; the next dialogs start from the default
    dialog->close();
  }

  void ExportOffersTheEnginePresets() {
    ResultsPage* results = window_->results();
    ExportDialog* dialog = results->OpenExportDialog();
    QVERIFY(dialog != nullptr);
    auto* preset = Find<QComboBox>(dialog, "exportPreset");
    auto* convention = Find<QComboBox>(dialog, "normalConvention");
    for (const auto engine : {ExportOptions::Preset::kUnreal, ExportOptions::Preset::kUnityHdrp,
                              ExportOptions::Preset::kGltf}) {
      const int index = preset->findData(int(engine));
      QVERIFY2(index >= 0, ExportPresetName(engine));
      preset->setCurrentIndex(index);
      QVERIFY2(!convention->isEnabled(), "the engine decides the normal convention");
    }
    preset->setCurrentIndex(preset->findData(int(ExportOptions::Preset::kPng16)));
    QVERIFY(convention->isEnabled());
    preset->setCurrentIndex(preset->findData(int(ExportOptions::Preset::kGltf)));
    QCOMPARE(ClickAndWait(Find<QPushButton>(dialog, "startExport")), ControllerRunner::Outcome::kSucceeded);
    const fs::path export_dir = dialog->export_dir();
    QVERIFY2(fs::is_directory(export_dir), qPrintable(last_message_));
    const QJsonObject material = ReadJson(export_dir / "material.json");
    QCOMPARE(material["preset"].toString(), QStringLiteral("gltf"));
    QCOMPARE(material["normal_convention"].toString(), QStringLiteral("opengl"));
    const QJsonObject files = material["files"].toObject();
    for (const char* kind : {"gltf", "gltf_buffer", "materialx", "occlusion_roughness_metallic"}) {
      QVERIFY2(fs::is_regular_file(export_dir / files[kind].toObject()["path"].toString().toStdString()), kind);
    }
  }

  void ClosingTheDialogMidExportLetsTheExportFinish() {
    ResultsPage* results = window_->results();
    ExportDialog* dialog = results->OpenExportDialog();
    QVERIFY(dialog != nullptr);
    const size_t exports_before = CountFolders(session_ / "exports");
    QPointer<ExportDialog> watched(dialog);
    QTest::mouseClick(Find<QPushButton>(dialog, "startExport"), Qt::LeftButton);
    QVERIFY(window_->runner()->busy());
    dialog->close();  // deletes it (WA_DeleteOnClose) while the job runs
    QTRY_VERIFY_WITH_TIMEOUT(watched.isNull(), 5000);
    QVERIFY(window_->runner()->Wait(120000));
    QCOMPARE(CountFolders(session_ / "exports"), exports_before + 1);
  }

  void CancelledExportLeavesNoFolder() {
    SessionsPage* sessions = window_->sessions();
    window_->ShowPage(MainWindow::kSessionsPage);
    QVERIFY(sessions->SelectSession(QString::fromStdString(session_.string())));
    QTest::mouseClick(Find<QPushButton>(sessions, "exportSelectedResult"), Qt::LeftButton);
    auto* dialog = sessions->findChild<ExportDialog*>();
    QVERIFY(dialog != nullptr);
    const size_t exports_before = CountFolders(session_ / "exports");
    // Hold the export at its first progress report until Cancel was clicked:
    // the stop lands at a known point, however loaded the machine.
    QSemaphore cancelled;
    bool held = false;
    window_->runner()->SetWorkerProgressHook([&](const QString&, double) {
      if (held) return;
      held = true;
      cancelled.tryAcquire(1, 30000);
    });
    bool clicked = false;
    auto cancel_on_progress = connect(window_->runner(), &ControllerRunner::Progress, this, [&] {
      if (clicked) return;
      clicked = true;
      QTest::mouseClick(Find<QPushButton>(dialog, "cancelExport"), Qt::LeftButton);
      cancelled.release();
    });
    {
      // Dropped however this ends: both capture locals by reference.
      const auto drop_hooks = qScopeGuard([&] {
        disconnect(cancel_on_progress);
        window_->runner()->SetWorkerProgressHook({});
      });
      QCOMPARE(ClickAndWait(Find<QPushButton>(dialog, "startExport")), ControllerRunner::Outcome::kCancelled);
    }
    QVERIFY(Find<QLabel>(dialog, "exportStatus")->text().contains("cancelled"));
    QCOMPARE(CountFolders(session_ / "exports"), exports_before);
  }
};

}  // namespace scanbench

QTEST_MAIN(scanbench::SessionsExportTest)
#include "sessions_export_test.moc"
