// The Results page as an operator meets it (issue #36), on a real solve and
// export of a small simulated satin session: the status map reads as solved
// with a key naming every colour; a new result opens fitted; switching maps
// never moves the picture; the pixel under the cursor is read out; a mm scale
// bar from the session's rig; specular, height and occlusion among the maps;
// the path field opens what is typed into it; the solve's report gets the
// page's width, laid out in label and value columns.
#include <QApplication>
#include <QLabel>
#include <QLineEdit>
#include <QSplitter>
#include <QStackedWidget>
#include <QTest>
#include <QTextBrowser>

#include <cstdlib>
#include <filesystem>
#include <memory>

#include "app/controllers/export_controller.h"
#include "app/controllers/simulate_controller.h"
#include "app/controllers/solve_controller.h"
#include "app/gui/colour_legend.h"
#include "app/gui/controller_runner.h"
#include "app/gui/image_view.h"
#include "app/gui/report_text.h"
#include "app/gui/result_images.h"
#include "app/gui/results_page.h"
#include "app/io/image_io.h"
#include "app/io/status_codes.h"
#include "app/session/session.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {
namespace fs = std::filesystem;

class ResultsPageTest : public QObject {
  Q_OBJECT

 private:
  testing::TemporaryFolder folder_;
  fs::path session_, result_, second_result_;
  static constexpr int kWidth = 128, kHeight = 96;

  QString Dir(const fs::path& path) const { return QString::fromStdString(path.string()); }

  // A page as the window holds it, 1200 x 800 and shown (the runner outlives it).
  std::unique_ptr<ResultsPage> ShownPage() {
    auto page = std::make_unique<ResultsPage>(&runner_);
    page->resize(1200, 800);
    page->show();
    if (!QTest::qWaitForWindowExposed(page.get())) qWarning("the page was not exposed");
    return page;
  }
  ControllerRunner runner_;

 private slots:
  void initTestCase() {
    session_ = folder_ / "satin";
    SimulateOptions simulate;
    simulate.rig.width = kWidth;
    simulate.rig.height = kHeight;
    simulate.scene.material = SurfaceMaterial::kSatin;  // a specular lobe: specular.exr, status code 7
    SimulateController(session_, simulate).Run();
    SolveOptions solve;
    solve.run_label = "first";
    SolveController first(session_, solve);
    first.Run();
    result_ = first.summary().result_dir;
    solve.run_label = "second";
    SolveController second(session_, solve);
    second.Run();
    second_result_ = second.summary().result_dir;
    ExportController exporter(result_, ExportOptions());
    exporter.Run();
    QVERIFY(fs::is_directory(exporter.summary().export_dir));
  }

  // A result solved everywhere, mostly without a specular lobe, reads as
  // solved: green in the map, "100 % solved" in its key, every code named.
  void StatusMapReadsSolvedWithAKey() {
    const std::unique_ptr<ResultsPage> shown = ShownPage();
    ResultsPage& page = *shown;
    const fs::path dir = folder_ / "all7" / "results" / "run";
    fs::create_directories(dir);
    ImageU8 status(20, 10, 1, kStatusSolvedSpecularUnsupported);
    status(3, 3) = 0;
    WritePng(dir / "status.png", status, OverwritePolicy::kRefuse);
    QVERIFY(page.OpenResult(Dir(dir)));
    QVERIFY(page.ShowLayer(ResultLayer::kStatus));
    QVERIFY(page.status_legend()->isVisible());
    QVERIFY(!page.legend()->isVisible());
    QCOMPARE(page.status_legend()->Headline(), QStringLiteral("100 % solved (200 of 200 px in the region)"));
    const QStringList entries = page.status_legend()->EntryTexts();
    QCOMPARE(entries.size(), kNumStatusPngCodes);
    for (const StatusCodeInfo& info : StatusCodes()) {
      QVERIFY2(entries[info.code].startsWith(QString::fromUtf8(info.name) + ':'), qPrintable(entries[info.code]));
    }
    QCOMPARE(entries[kStatusSolvedSpecularUnsupported], QStringLiteral("solved, no specular lobe: 199 px (99.5 %)"));
    const QColor colour(page.view()->image().pixel(0, 0));
    QVERIFY2(colour.green() > colour.red() + 40 && colour.green() > colour.blue() + 40, qPrintable(colour.name()));
    // A failure is named in the headline.
    status(0, 0) = 2;
    WritePng(dir / "status.png", status, OverwritePolicy::kReplace);
    QVERIFY(page.OpenResult(Dir(dir)));
    QVERIFY(page.ShowLayer(ResultLayer::kStatus));
    QCOMPARE(page.status_legend()->Headline(),
             QStringLiteral("99.5 % solved (199 of 200 px in the region); 1 px unsolved: 1 too few lights"));
  }

  void ANewResultOpensFitted() {
    const std::unique_ptr<ResultsPage> shown = ShownPage();
    ResultsPage& page = *shown;
    QVERIFY(page.OpenResult(Dir(result_)));
    page.view()->FitToWidget();
    const double fit = page.view()->zoom();
    page.view()->ZoomBy(3, QPointF(40, 40));
    QVERIFY(!page.view()->fitted());
    QVERIFY(page.OpenResult(Dir(second_result_)));  // the same size
    QVERIFY(page.view()->fitted());
    QCOMPARE(page.view()->zoom(), fit);
  }

  // Zoomed and panned, every map of the result sits where the first did, and
  // the view keeps its size (the key's place does not come and go).
  void SwitchingMapsDoesNotMoveThePicture() {
    const std::unique_ptr<ResultsPage> shown = ShownPage();
    ResultsPage& page = *shown;
    QVERIFY(page.OpenResult(Dir(result_)));
    QVERIFY(page.ShowLayer(ResultLayer::kAlbedo));
    QApplication::processEvents();
    page.view()->ZoomBy(2.5, QPointF(100, 80));
    const QRect geometry = page.view()->geometry();
    const QPointF origin = page.view()->ImageToWidget(QPointF(0, 0));
    const double zoom = page.view()->zoom();
    for (ResultLayer layer : AvailableLayers(result_)) {
      QVERIFY2(page.ShowLayer(layer), qPrintable(ResultLayerName(layer)));
      QVERIFY(page.WaitForRelight(30000));
      QApplication::processEvents();
      QCOMPARE(page.view()->geometry(), geometry);
      QCOMPARE(page.view()->zoom(), zoom);
      QCOMPARE(page.view()->ImageToWidget(QPointF(0, 0)), origin);
      QCOMPARE(page.view()->image().size(), QSize(kWidth, kHeight));
    }
  }

  void SpecularHeightAndOcclusionAreAmongTheMaps() {
    const QList<ResultLayer> layers = AvailableLayers(result_);
    for (ResultLayer layer : {ResultLayer::kSpecularF0, ResultLayer::kSpecularRoughness, ResultLayer::kHeight,
                              ResultLayer::kOcclusion}) {
      QVERIFY2(layers.contains(layer), qPrintable(ResultLayerName(layer)));
    }
    // The second result was not exported: no height or occlusion of another result's export.
    QVERIFY(!AvailableLayers(second_result_).contains(ResultLayer::kHeight));
    const LayerImage height = LoadResultLayerImage(result_, ResultLayer::kHeight);
    QVERIFY(height.scale && height.scale->has_values);
    QCOMPARE(height.scale->unit, QStringLiteral("mm"));
    QVERIFY(height.scale->max > height.scale->min);
    const LayerImage occlusion = LoadResultLayerImage(result_, ResultLayer::kOcclusion);
    QVERIFY(occlusion.scale && occlusion.scale->max <= 1.0f && occlusion.scale->min >= 0.0f);
    const LayerImage roughness = LoadResultLayerImage(result_, ResultLayer::kSpecularRoughness);
    QVERIFY(roughness.scale && roughness.scale->has_values);
    QVERIFY(roughness.scale->min > 0);  // the pixels without a lobe are not values (grey)
  }

  void PixelReadoutUnderTheCursor() {
    const std::unique_ptr<ResultsPage> shown = ShownPage();
    ResultsPage& page = *shown;
    QVERIFY(page.OpenResult(Dir(result_)));
    QVERIFY(page.ShowLayer(ResultLayer::kAngularError));
    QVERIFY(page.WaitForPixelProbe(30000));
    const QPoint at = page.view()->ImageToWidget(QPointF(40.5, 30.5)).toPoint();
    QTest::mouseMove(page.view(), at);
    QTRY_VERIFY(page.readout()->text().startsWith("x 40, y 30"));
    const QString text = page.readout()->text();
    const ImageF normal = ReadImageFloat(result_ / "normal.exr");
    const ImageF error = ReadImageFloat(result_ / "angular_error_deg.exr");
    QVERIFY2(text.contains(QStringLiteral("normal (%1, ").arg(normal(40, 30, 0), 0, 'f', 3)), qPrintable(text));
    QVERIFY2(text.contains(QStringLiteral("error %1°").arg(error(40, 30), 0, 'f', 2)), qPrintable(text));
    QVERIFY2(text.contains("albedo ") && text.contains("residual "), qPrintable(text));
    // The shown heatmap's own value first.
    QVERIFY2(text.contains(QStringLiteral("angular error on the sample %1 deg").arg(error(40, 30), 0, 'g', 4)),
             qPrintable(text));
    QVERIFY(DescribePixel(PixelProbeMaps(), 0, 0).isEmpty());
  }

  void ScaleBarFromTheSessionsRig() {
    std::string why;
    const std::optional<double> pitch = ResultPixelPitchMm(result_, &why);
    QVERIFY2(pitch.has_value(), why.c_str());
    SessionLoadOptions load;
    load.verify_checksums = false;
    const Session session = LoadSession(session_, load);
    QVERIFY(std::abs(*pitch / session.ground_truth->mm_per_pixel - 1) < 1e-6);
    const std::unique_ptr<ResultsPage> shown = ShownPage();
    ResultsPage& page = *shown;
    QVERIFY(page.OpenResult(Dir(result_)));
    QCOMPARE(page.view()->pixel_pitch_mm(), *pitch);
    const double bar_mm = page.view()->ScaleBarMm();
    const double bar_px = bar_mm / *pitch * page.view()->zoom();
    QVERIFY2(bar_px >= 60 && bar_px <= 150, qPrintable(QString::number(bar_px)));
    QVERIFY(page.view()->ScaleBarText().endsWith(" mm"));
    page.view()->ZoomBy(4, QPointF(10, 10));
    QVERIFY(page.view()->ScaleBarMm() < bar_mm);
    // A folder outside any session: no bar, and the reason in the view's tooltip.
    const fs::path lone = folder_ / "lone" / "results" / "run";
    fs::create_directories(lone);
    WritePng(lone / "status.png", ImageU8(4, 4, 1, 0), OverwritePolicy::kRefuse);
    QVERIFY(page.OpenResult(Dir(lone)));
    QCOMPARE(page.view()->ScaleBarMm(), 0.0);
    QVERIFY(page.view()->toolTip().startsWith("No scale bar"));

    QCOMPARE(ImageView::NiceScaleBarMm(0.1, 150), 10.0);
    QCOMPARE(ImageView::NiceScaleBarMm(0.03, 150), 2.0);
    QCOMPARE(ImageView::NiceScaleBarMm(0.004, 150), 0.5);
    QCOMPARE(ImageView::NiceScaleBarMm(0, 150), 0.0);
  }

  void TypedPathOpens() {
    const std::unique_ptr<ResultsPage> shown = ShownPage();
    ResultsPage& page = *shown;
    auto* field = page.findChild<QLineEdit*>("resultFolder");
    QVERIFY(field != nullptr);
    QVERIFY(!field->isReadOnly());
    field->setFocus();
    field->setText(Dir(second_result_));
    QTest::keyClick(field, Qt::Key_Return);
    QCOMPARE(page.result_dir(), second_result_);
    QVERIFY(page.view()->image().size() == QSize(kWidth, kHeight));
    field->setText(Dir(folder_ / "nothing-here"));
    QTest::keyClick(field, Qt::Key_Return);
    QVERIFY(page.findChild<QLabel*>("resultStatus")->text().contains("holds no maps"));
  }

  // The report across the page, in label and value columns.
  void ReportGetsThePagesWidth() {
    const std::unique_ptr<ResultsPage> shown = ShownPage();
    ResultsPage& page = *shown;
    QVERIFY(page.OpenResult(Dir(result_)));
    QApplication::processEvents();
    QVERIFY2(page.report()->width() >= 0.9 * page.width(), qPrintable(QString::number(page.report()->width())));
    QVERIFY(page.report()->height() >= 120);
    QVERIFY(page.report()->toPlainText().contains("Photometric solve"));
    // SCANBENCH_KEEP_SCREENSHOTS=DIR keeps the page with its status map, to look at.
    if (const char* keep = std::getenv("SCANBENCH_KEEP_SCREENSHOTS")) {
      QVERIFY(page.ShowLayer(ResultLayer::kStatus));
      QTest::mouseMove(page.view(), page.view()->ImageToWidget(QPointF(60.5, 50.5)).toPoint());
      QVERIFY(page.WaitForPixelProbe(30000));
      page.grab().save(QString::fromUtf8(keep) + "/results_page_test_status.png");
    }
    const QList<ReportLine> lines =
        ReportLines("scanbench solve report\n  frames:       10 LEDs + dark, 128x96\n"
                    "  Photometric solve (adaptive): success, 1 / 1 pixels\n");
    QCOMPARE(lines.size(), 3);
    QCOMPARE(lines[0].label, QString());
    QCOMPARE(lines[1].label, QStringLiteral("frames"));
    QCOMPARE(lines[1].value, QStringLiteral("10 LEDs + dark, 128x96"));
    QCOMPARE(lines[2].label, QString());
    QVERIFY(ReportHtml("  a <b>:  x & y").contains("a &lt;b&gt;"));
  }
};

}  // namespace scanbench

QTEST_MAIN(scanbench::ResultsPageTest)
#include "results_page_test.moc"
