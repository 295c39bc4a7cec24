// Heatmap layers and their colour legend: the scale and the map's min / max
// the legend states are the values in the files, with their unit; the legend
// shows under heatmaps only. The results page states the albedo's colour space
// and scale from report.json.
#include <QApplication>
#include <QLabel>
#include <QTest>

#include <cmath>
#include <filesystem>
#include <limits>

#include "app/gui/colour_legend.h"
#include "app/gui/controller_runner.h"
#include "app/gui/result_images.h"
#include "app/gui/results_page.h"
#include "app/io/file_util.h"
#include "app/io/image_io.h"
#include "tests/util/temporary_folder.h"

namespace scanbench {

class ResultLayersTest : public QObject {
  Q_OBJECT

 private:
  testing::TemporaryFolder folder_;
  std::filesystem::path dir_;

 private slots:
  void initTestCase() {
    // A result folder with a known angular error map (one NaN off the
    // sample, one value beyond the 5° scale), a confidence file and an albedo.
    dir_ = folder_ / "result";
    std::filesystem::create_directories(dir_);
    ImageF error(8, 4, 1);
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 8; ++x) error(x, y) = 0.25f + 0.5f * float(x + 8 * y) / 31;
    error(3, 1) = 7.5f;
    error(0, 3) = std::numeric_limits<float>::quiet_NaN();
    WriteExr(dir_ / "angular_error_deg.exr", error, OverwritePolicy::kRefuse);
    ImageF confidence(8, 4, 3);
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 8; ++x) {
        confidence(x, y, 0) = float(3 + (x % 8));     // lights_used 3..10
        confidence(x, y, 1) = 1.5f + float(y);        // condition_number 1.5..4.5
        confidence(x, y, 2) = 0.001f * float(1 + x);  // residual 0.001..0.008
      }
    confidence(7, 3, 2) = 0;  // an unsolved pixel
    WriteExr(dir_ / "confidence.exr", confidence, OverwritePolicy::kRefuse,
             {"lights_used", "condition_number", "residual"});
    WritePng(dir_ / "albedo_srgb.png", ImageU8(8, 4, 3, 128), OverwritePolicy::kRefuse);
  }

  // Issue #13: status.png's code 7 (solved, specular map unsupported) has its
  // own colour; solved stays green, unknown codes read as invalid input.
  // Issue #36: the colours are app/io/status_codes.h's, code 7 a green too.
  void StatusShowsSpecularUnsupportedApart() {
    const std::filesystem::path dir = folder_ / "status_result";
    std::filesystem::create_directories(dir);
    ImageU8 status(4, 1, 1);
    status(0, 0) = 0;
    status(1, 0) = 7;
    status(2, 0) = 6;
    status(3, 0) = 200;
    WritePng(dir / "status.png", status, OverwritePolicy::kRefuse);
    const QImage image = LoadResultLayerImage(dir, ResultLayer::kStatus).image;
    QCOMPARE(image.pixel(0, 0), qRgb(40, 170, 70));
    QCOMPARE(image.pixel(1, 0), qRgb(130, 205, 110));
    QVERIFY(image.pixel(1, 0) != image.pixel(0, 0));
    QCOMPARE(image.pixel(2, 0), qRgb(255, 255, 255));
    QCOMPARE(image.pixel(3, 0), qRgb(255, 255, 255));
    for (int code = 0; code < kNumStatusPngCodes; ++code) {
      const StatusCodeInfo& info = StatusCodes()[code];
      QCOMPARE(StatusColour(code), qRgb(info.r, info.g, info.b));
    }
  }

  void AngularErrorScaleStatesTheMapsRange() {
    const LayerImage layer = LoadResultLayerImage(dir_, ResultLayer::kAngularError);
    QVERIFY(layer.scale.has_value());
    const HeatmapScale& scale = *layer.scale;
    QCOMPARE(scale.unit, QStringLiteral("deg"));
    QCOMPARE(scale.lo, 0.0f);
    QCOMPARE(scale.hi, 5.0f);
    QVERIFY(scale.has_values);
    QCOMPARE(scale.min, 0.25f);  // the NaN is not a value
    QCOMPARE(scale.max, 7.5f);
    // The colours follow the scale: beyond it clamped to its top, NaN grey.
    QCOMPARE(layer.image.pixel(3, 1), HeatmapColour(1.0) | 0xff000000);
    QCOMPARE(layer.image.pixel(0, 3), qRgb(128, 128, 128));
    QCOMPARE(layer.image.pixel(0, 0), HeatmapColour(0.25 / 5) | 0xff000000);
  }

  void AngularErrorRangeIsOverTheSessionsSampleMask() {
    // <session>/results/<run>/ beside <session>/ground_truth/sample_mask.png:
    // the file's zeros off the sample are not the map's minimum.
    const std::filesystem::path session = folder_ / "session";
    const std::filesystem::path run = session / "results" / "run";
    std::filesystem::create_directories(run);
    std::filesystem::create_directories(session / "ground_truth");
    ImageF error(4, 2, 1, 0.0f);
    ImageU8 mask(4, 2, 1, 0);
    for (int x = 1; x < 3; ++x) {
      error(x, 1) = 1.5f * float(x);  // 1.5 and 3 on the sample
      mask(x, 1) = 255;
    }
    error(0, 0) = 9;  // off the sample
    WriteExr(run / "angular_error_deg.exr", error, OverwritePolicy::kRefuse);
    WritePng(session / "ground_truth" / "sample_mask.png", mask, OverwritePolicy::kRefuse);
    const HeatmapScale scale = *LoadResultLayerImage(run, ResultLayer::kAngularError).scale;
    QCOMPARE(scale.quantity, QStringLiteral("angular error on the sample"));
    QCOMPARE(scale.min, 1.5f);
    QCOMPARE(scale.max, 3.0f);
  }

  void ConfidenceChannelsHaveTheirOwnScales() {
    const QList<ResultLayer> layers = AvailableLayers(dir_);
    for (ResultLayer layer : {ResultLayer::kResidual, ResultLayer::kConditionNumber, ResultLayer::kLightsUsed}) {
      QVERIFY2(layers.contains(layer), qPrintable(ResultLayerName(layer)));
    }
    const HeatmapScale residual = *LoadResultLayerImage(dir_, ResultLayer::kResidual).scale;
    QCOMPARE(residual.min, 0.0f);
    QCOMPARE(residual.max, 0.008f);
    QCOMPARE(residual.lo, 0.0f);
    QVERIFY(residual.hi > 0.006f && residual.hi <= 0.008f);  // the 99th percentile of the solved pixels
    const HeatmapScale condition = *LoadResultLayerImage(dir_, ResultLayer::kConditionNumber).scale;
    QCOMPARE(condition.min, 1.5f);
    QCOMPARE(condition.max, 4.5f);
    QCOMPARE(condition.lo, 1.0f);
    const HeatmapScale lights = *LoadResultLayerImage(dir_, ResultLayer::kLightsUsed).scale;
    QCOMPARE(lights.min, 3.0f);
    QCOMPARE(lights.max, 10.0f);
    QCOMPARE(lights.hi, 10.0f);
    QVERIFY(!LoadResultLayerImage(dir_, ResultLayer::kAlbedo).scale.has_value());
  }

  void LegendStatesScaleAndRangeWithUnits() {
    ColourLegend legend;
    legend.SetScale(*LoadResultLayerImage(dir_, ResultLayer::kAngularError).scale);
    QCOMPARE(legend.LowText(), QStringLiteral("0 deg"));
    QCOMPARE(legend.HighText(), QStringLiteral("5 deg"));
    QCOMPARE(legend.RangeText(), QStringLiteral("angular error: map min 0.25 deg, max 7.5 deg"));
  }

  void ResultsPageShowsTheLegendUnderHeatmapsOnly() {
    ControllerRunner runner;
    ResultsPage page(&runner);
    page.resize(900, 600);
    page.show();
    QVERIFY(page.OpenResult(QString::fromStdString(dir_.string())));
    QVERIFY(page.ShowLayer(ResultLayer::kAngularError));
    QVERIFY(page.legend()->isVisible());
    QCOMPARE(page.legend()->scale().max, 7.5f);
    QCOMPARE(page.legend()->scale().min, 0.25f);
    QVERIFY(page.ShowLayer(ResultLayer::kResidual));
    QVERIFY(page.legend()->isVisible());
    QCOMPARE(page.legend()->scale().max, 0.008f);
    QVERIFY(page.ShowLayer(ResultLayer::kAlbedo));
    QVERIFY(!page.legend()->isVisible());
  }

  // report.json's "color" (issue #12) on one line; a result from before it
  // (no "color") is white-balanced camera RGB of a relative scale.
  void ResultsPageStatesTheAlbedoColour() {
    ControllerRunner runner;
    ResultsPage page(&runner);
    QLabel* line = page.findChild<QLabel*>("resultAlbedoColor");
    QVERIFY(line != nullptr);
    const std::filesystem::path report = dir_ / "report.json";
    WriteFileAtomic(report,
                    std::string_view("{\"color\": {\"color_space\": \"linear_rec709\", \"scale\": \"absolute\", "
                                     "\"description\": \"ColorChecker fit in cal/calibration.json, CIEDE2000 mean 1.0\", "
                                     "\"scale_source\": \"the set's light calibration\"}}"),
                    OverwritePolicy::kReplace);
    QVERIFY(page.OpenResult(QString::fromStdString(dir_.string())));
    QCOMPARE(line->text(), QStringLiteral("Albedo: linear_rec709, absolute — ColorChecker fit in cal/calibration.json, "
                                          "CIEDE2000 mean 1.0"));
    QCOMPARE(line->toolTip(), QStringLiteral("the set's light calibration"));

    WriteFileAtomic(report, std::string_view("{\"method\": \"adaptive\"}"), OverwritePolicy::kReplace);
    QVERIFY(page.OpenResult(QString::fromStdString(dir_.string())));
    QVERIFY2(line->text().startsWith("Albedo: camera_rgb, relative — not colour calibrated"), qPrintable(line->text()));

    WriteFileAtomic(report, std::string_view("not json"), OverwritePolicy::kReplace);
    QVERIFY(page.OpenResult(QString::fromStdString(dir_.string())));
    QVERIFY2(line->text().contains("unknown") && line->text().contains("report.json"), qPrintable(line->text()));
    std::filesystem::remove(report);
    QVERIFY(page.OpenResult(QString::fromStdString(dir_.string())));
    QVERIFY2(line->text().contains("no report.json"), qPrintable(line->text()));
  }
};

}  // namespace scanbench

QTEST_MAIN(scanbench::ResultLayersTest)
#include "result_layers_test.moc"
