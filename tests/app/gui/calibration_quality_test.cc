// The colour step's figures and its before / after swatch image
// (calibration_quality.h), on made-up colour correction summaries: the pixels
// of every stripe, the gaps, the frame of a patch left out, and the marks and
// hints of good and bad fits.
#include <QTest>

#include <cmath>
#include <limits>
#include <string>

#include "app/gui/calibration_quality.h"
#include "calibration/color_checker.h"
#include "calibration/color_science.h"

namespace scanbench {
namespace {

// 24 patches with distinct, known values in each stripe; patch 7 clipped.
ColorCorrectionSummary MadeUpFit() {
  ColorCorrectionSummary fit;
  fit.termination = Termination::kSuccess;
  fit.method = "ciede2000_fit";
  for (int i = 0; i < 24; ++i) {
    ColorPatchResult patch;
    patch.name = ColorCheckerClassic()[i].name;
    patch.measured_camera = Eigen::Vector3d(0.01 + 0.04 * i, 0.5, 0.02);
    patch.reference_linear_rec709 = ColorCheckerClassic()[i].linear_rec709;
    patch.corrected_linear_rec709 = Eigen::Vector3d(0.9, 0.03 * i, 0.3);
    patch.delta_e_before = 5 + 0.1 * i;
    patch.delta_e_after = 0.5 + 0.05 * i;
    patch.used = i != 7;
    patch.status = patch.used ? "used" : "clipped";
    fit.patches.push_back(patch);
  }
  fit.used_patches = 23;
  fit.mean_delta_e_before = 6.2;
  fit.max_delta_e_before = 7.3;
  fit.mean_delta_e_after = 1.1;
  fit.max_delta_e_after = 1.65;
  return fit;
}

int Byte(double linear) { return int(std::lround(255 * SrgbEncode(linear))); }

}  // namespace

class CalibrationQualityTest : public QObject {
  Q_OBJECT

 private:
  // Pixel (x, y) of an 8-bit RGB image against the sRGB bytes of `linear`.
  static bool PixelIs(const ImageU8& image, int x, int y, int r, int g, int b) {
    return image(x, y, 0) == r && image(x, y, 1) == g && image(x, y, 2) == b;
  }

 private slots:
  void SwatchesShowBeforeReferenceAfter() {
    const ColorCorrectionSummary fit = MadeUpFit();
    const int s = 30, g = SwatchGapPx(s);
    QCOMPARE(g, 3);
    const ImageU8 image = ColorChartSwatches(fit, s);
    QCOMPARE(image.channels(), 3);
    QCOMPARE(image.width(), g + 6 * (s + g));
    QCOMPARE(image.height(), g + 4 * (s + g));
    for (int i = 0; i < 24; ++i) {
      const ColorPatchResult& patch = fit.patches[i];
      const int x0 = g + (i % 6) * (s + g), y0 = g + (i / 6) * (s + g);
      const Eigen::Vector3d stripes[3] = {patch.measured_camera, patch.reference_linear_rec709,
                                          patch.corrected_linear_rec709};
      for (int k = 0; k < 3; ++k) {
        // The first, middle and last column of each stripe, top and bottom row.
        const int begin = k * s / 3, end = (k + 1) * s / 3;
        for (int x : {begin, (begin + end) / 2, end - 1}) {
          for (int y : {0, s / 2, s - 1}) {
            const Eigen::Vector3d& v = stripes[k];
            QVERIFY2(PixelIs(image, x0 + x, y0 + y, Byte(v[0]), Byte(v[1]), Byte(v[2])),
                     qPrintable(QStringLiteral("patch %1 stripe %2 at (%3, %4)").arg(i).arg(k).arg(x).arg(y)));
          }
        }
      }
      // The gap left of and above each swatch: dark gray, or red around the
      // patch left out (7: the second row's second swatch).
      const bool framed = i == 7;
      QVERIFY(framed ? PixelIs(image, x0 - 1, y0 + s / 2, 0xe0, 0x20, 0x20)
                     : PixelIs(image, x0 - 1, y0 + s / 2, 0x30, 0x30, 0x30));
      QVERIFY(framed ? PixelIs(image, x0 + s / 2, y0 - 1, 0xe0, 0x20, 0x20)
                     : PixelIs(image, x0 + s / 2, y0 - 1, 0x30, 0x30, 0x30));
    }
    // The outer gap of the frame stays gray: the frame is 1 px of the 3 px gap.
    const int x7 = g + 1 * (s + g), y7 = g + 1 * (s + g);
    QVERIFY(PixelIs(image, x7 - 2, y7 + s / 2, 0x30, 0x30, 0x30));
    QVERIFY(PixelIs(image, 0, 0, 0x30, 0x30, 0x30));
  }

  void SwatchesClampAndBlackenWhatCannotShow() {
    ColorCorrectionSummary fit = MadeUpFit();
    fit.patches[0].measured_camera = Eigen::Vector3d(-0.2, 1.7, std::numeric_limits<double>::quiet_NaN());
    const int s = 12, g = SwatchGapPx(s);
    const ImageU8 image = ColorChartSwatches(fit, s);
    QVERIFY(PixelIs(image, g + 1, g + 1, 0, 255, 0));  // below 0 -> 0, above 1 -> 255, NaN -> 0
    QVERIFY_THROWS_EXCEPTION(std::invalid_argument, ColorChartSwatches(fit, 5));
  }

  void ColourFiguresPassAGoodFit() {
    const std::vector<QualityFigure> figures = ColorQuality(MadeUpFit(), "light_field");
    QCOMPARE(figures.size(), size_t(5));
    QCOMPARE(figures[0].name, std::string("CIEDE2000 mean, corrected"));
    QCOMPARE(figures[0].value, 1.1);
    QCOMPARE(figures[0].mark, QualityFigure::Mark::kPass);
    QCOMPARE(figures[0].text, std::string("1.10 (before 6.20) over 23 patches"));
    QCOMPARE(figures[1].value, 1.65);
    QCOMPARE(figures[1].mark, QualityFigure::Mark::kPass);
    // The worst used patch is the last one (delta_e_after grows with the index).
    QVERIFY2(figures[1].text.find(ColorCheckerClassic()[23].name) != std::string::npos, figures[1].text.c_str());
    // One patch left out: a warning that says which and what to do.
    QCOMPARE(figures[2].name, std::string("patches used"));
    QCOMPARE(figures[2].mark, QualityFigure::Mark::kWarn);
    QCOMPARE(figures[2].text, std::string("23 of 24"));
    QCOMPARE(figures[2].hint,
             ColorCheckerClassic()[7].name + std::string(" clipped: shorten the exposure or dim the LEDs"));
    QVERIFY(figures[3].text.find("absolute") != std::string::npos);
    QCOMPARE(figures[4].text, std::string("ciede2000_fit"));
  }

  void ColourFiguresFailABadFit() {
    ColorCorrectionSummary fit = MadeUpFit();
    fit.mean_delta_e_after = 4.5;
    fit.max_delta_e_after = 7;
    // Half the patches left out, one without a reason kept (as read back from a set).
    for (int i = 12; i < 24; ++i) {
      fit.patches[i].used = false;
      fit.patches[i].status = i == 12 ? "" : "too dark";
    }
    const std::vector<QualityFigure> figures = ColorQuality(fit, "neutral_patches");
    QCOMPARE(figures[0].mark, QualityFigure::Mark::kFail);
    QVERIFY(!figures[0].hint.empty());
    QCOMPARE(figures[1].mark, QualityFigure::Mark::kWarn);
    QCOMPARE(figures[2].mark, QualityFigure::Mark::kFail);
    QCOMPARE(figures[2].text, std::string("11 of 24"));
    QVERIFY2(figures[2].hint.find(fit.patches[12].name + " left out") != std::string::npos, figures[2].hint.c_str());
    QVERIFY2(figures[2].hint.find(fit.patches[13].name + " too dark: lengthen the exposure") != std::string::npos,
             figures[2].hint.c_str());
    QCOMPARE(ColorPatchStatusText(fit.patches[12]), std::string("left out"));
    QCOMPARE(ColorPatchStatusText(fit.patches[0]), std::string("used"));
    QVERIFY(figures[3].text.find("relative") != std::string::npos);
    QCOMPARE(WorstMark(figures), QualityFigure::Mark::kFail);
    QVERIFY(FixHintForError(CalibrationStep::kColor, "t/color_chart: in none of its LED frames: no ColorChecker found")
                .find("lay the whole chart flat") != std::string::npos);
    QVERIFY(FixHintForError(CalibrationStep::kColor, "x is no calibration target session").find("colour chart") !=
            std::string::npos);
  }
};

}  // namespace scanbench

QTEST_APPLESS_MAIN(scanbench::CalibrationQualityTest)
#include "calibration_quality_test.moc"
