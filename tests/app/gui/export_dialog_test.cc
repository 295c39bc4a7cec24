// The export dialog's presets (issue #36): every preset of the export's
// table (app/io/export_contents.h) in its order, titled from it, and under
// the choice what the chosen preset's files hold, the table's own text: a
// png16 / tiff16 base colour reads sRGB-encoded, its normals linear.
#include <QComboBox>
#include <QLabel>
#include <QSettings>
#include <QTest>

#include "app/gui/controller_runner.h"
#include "app/gui/export_dialog.h"
#include "app/io/export_contents.h"

namespace scanbench {

class ExportDialogTest : public QObject {
  Q_OBJECT

 private slots:
  void PresetsAndWhatTheirFilesHoldAreTheTables() {
    QSettings().clear();
    ControllerRunner runner;
    ExportDialog dialog(&runner, "/nonexistent/session/results/run");
    QComboBox* preset = dialog.preset();
    QLabel* holds = dialog.findChild<QLabel*>("exportPresetContents");
    QVERIFY(holds != nullptr);
    const std::vector<ExportPresetContents>& table = ExportPresetContentsTable();
    QCOMPARE(preset->count(), int(table.size()));
    for (int i = 0; i < preset->count(); ++i) {
      const ExportPresetContents& row = table[size_t(i)];
      QCOMPARE(preset->itemText(i), QString::fromStdString(ExportPresetTitle(row)));
      QCOMPARE(preset->itemData(i).toInt(), int(ExportPresetFromName(row.name)));
      QCOMPARE(preset->itemData(i, Qt::ToolTipRole).toString(), QString::fromStdString(ExportPresetHolds(row)));
      preset->setCurrentIndex(i);
      QCOMPARE(holds->text(), QString::fromStdString(ExportPresetHolds(row)));
      QCOMPARE(dialog.PresetContentsText(), holds->text());
      QCOMPARE(ExportPresetName(dialog.OptionsFromWidgets().preset), std::string(row.name));
    }
    // The words an operator reads: no "linear" base colour in the integer presets.
    for (const char* name : {"png16", "tiff16"}) {
      preset->setCurrentIndex(preset->findData(int(ExportPresetFromName(name))));
      QVERIFY2(holds->text().startsWith("base colour 16-bit, sRGB-encoded"), qPrintable(holds->text()));
      QVERIFY2(holds->text().contains("normals 16-bit, linear"), qPrintable(holds->text()));
      QVERIFY(!preset->currentText().contains("linear"));
    }
    // A new dialog starts at the export's default preset, the table's first.
    ExportDialog fresh(&runner, "/nonexistent/session/results/run");
    QCOMPARE(fresh.preset()->currentIndex(), 0);
  }
};

}  // namespace scanbench

QTEST_MAIN(scanbench::ExportDialogTest)
#include "export_dialog_test.moc"
