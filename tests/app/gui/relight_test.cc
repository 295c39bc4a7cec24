// The relight preview's shading (app/gui/relight_shading.h) against values
// worked out by hand from UE4's formulas, the preview image built from it,
// and its rendering off the UI thread (app/gui/relight_renderer.h).
#include <QCoreApplication>
#include <QList>
#include <QSemaphore>
#include <QTest>
#include <QThread>

#include <atomic>
#include <cmath>
#include <memory>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "app/gui/relight_renderer.h"
#include "app/gui/relight_shading.h"
#include "app/gui/result_images.h"

namespace scanbench {

namespace {
const Eigen::Vector3d kUp(0, 0, 1);
// 60 degrees from the normal in the x-z plane: h is then 30 degrees from n.
const Eigen::Vector3d kLight60(std::sqrt(3.0) / 2, 0, 0.5);

bool Near(double actual, double expected, double tolerance) { return std::abs(actual - expected) <= tolerance; }

// A dome of normals over the whole map (every light direction lights a
// different part) under an albedo that varies across it.
std::shared_ptr<const RelightMaps> DomeMaps(int width, int height) {
  auto maps = std::make_shared<RelightMaps>();
  maps->normal = ImageF(width, height, 3);
  maps->albedo = ImageF(width, height, 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector3d normal = Eigen::Vector3d(1.6 * (x + 0.5) / width - 0.8, 1.6 * (y + 0.5) / height - 0.8, 1)
                                         .normalized();
      for (int c = 0; c < 3; ++c) maps->normal(x, y, c) = float(normal[c]);
      maps->albedo(x, y, 0) = 0.2f + 0.6f * float(x) / width;
      maps->albedo(x, y, 1) = 0.5f;
      maps->albedo(x, y, 2) = 0.2f + 0.6f * float(y) / height;
    }
  }
  return maps;
}

// Light directions along a drag over the pad, from the left to the upper right.
std::vector<Eigen::Vector3d> DragPath(int steps) {
  std::vector<Eigen::Vector3d> path;
  for (int i = 0; i < steps; ++i) {
    const double t = double(i) / (steps - 1);
    const double x = -0.8 + 1.4 * t, y = 0.5 * t;
    path.emplace_back(x, y, std::sqrt(1 - x * x - y * y));
  }
  return path;
}
}  // namespace

class RelightTest : public QObject {
  Q_OBJECT

 private slots:
  void DistributionAtThePeakIsOneOverPiAlphaSquared() {
    // n.h = 1: D = alpha² / (pi alpha⁴) = 1 / (pi alpha²); roughness 0.5 -> alpha² = 0.0625.
    QVERIFY(Near(GgxDistribution(0.5 * 0.5, 1.0), 1 / (std::numbers::pi * 0.0625), 1e-9));
    QVERIFY(Near(GgxDistribution(0.5 * 0.5, 1.0), 5.092958178940651, 1e-9));
    // n.h = cos 30°: (0.75 (0.0625 - 1) + 1)² = 0.296875² -> D = 0.0625 / (pi 0.088135) = 0.2257267.
    QVERIFY(Near(GgxDistribution(0.5 * 0.5, std::sqrt(3.0) / 2), 0.22572667829099857, 1e-9));
    // Roughness 1 (alpha 1): D = 1/pi everywhere.
    QVERIFY(Near(GgxDistribution(1.0 * 1.0, 0.3), 1 / std::numbers::pi, 1e-12));
  }

  void GeometryIsSchlickWithKFromRemappedRoughness() {
    // k = (0.5 + 1)² / 8 = 0.28125; G1(0.5) = 0.5 / (0.5 * 0.71875 + 0.28125) = 0.780488.
    QVERIFY(Near(SchlickSmithG1(0.5, 0.5), 0.7804878048780488, 1e-12));
    QVERIFY(Near(SchlickSmithG1(1.0, 0.5), 1.0, 1e-12));
    QCOMPARE(SchlickSmithG1(-0.2, 0.5), 0.0);
    // Roughness 1: k = 0.5, G1(0.5) = 0.5 / 0.75.
    QVERIFY(Near(SmithSchlickGeometry(0.5, 1.0, 1.0), 2.0 / 3.0, 1e-12));
  }

  void FresnelUsesTheSphericalGaussianPower() {
    // v.h = 1: F = F0 + (1 - F0) 2^-12.53789 = 0.04 + 0.96 * 1.6816e-4.
    QVERIFY(Near(SphericalGaussianSchlickFresnel(0.04, 1.0), 0.04016143223543417, 1e-12));
    // v.h = cos 30°: exponent (-5.55473 * 0.866025 - 6.98316) * 0.866025 = -10.21363.
    QVERIFY(Near(SphericalGaussianSchlickFresnel(0.04, std::sqrt(3.0) / 2), 0.04080846046861902, 1e-12));
    // Grazing: everything reflects.
    QVERIFY(Near(SphericalGaussianSchlickFresnel(0.04, 0.0), 0.04 + 0.96 * std::exp2(0.0), 1e-12));
    QCOMPARE(SphericalGaussianSchlickFresnel(1.0, 0.3), 1.0);
  }

  void SpecularBrdfIsDfgOverFourNlNv() {
    // Light and viewer overhead: D F G / 4 = 5.092958 * 0.040161 * 1 / 4.
    QVERIFY(Near(GgxSpecularBrdf(kUp, kUp, kUp, 0.5, 0.04), 0.05113512369535629, 1e-12));
    // Light at 60°, viewer overhead: 0.225727 * 0.040808 * 0.780488 / (4 * 0.5 * 1).
    QVERIFY(Near(GgxSpecularBrdf(kUp, kLight60, kUp, 0.5, 0.04), 0.0035947544303418146, 1e-12));
    QVERIFY(Near(GgxSpecularBrdf(kUp, kLight60, kUp, 1.0, 0.04), 0.004329912135700614, 1e-12));
    // A light below the surface lights nothing.
    QCOMPARE(GgxSpecularBrdf(kUp, Eigen::Vector3d(0.6, 0, -0.8), kUp, 0.5, 0.04), 0.0);
  }

  void ShadingIsLambertPlusPiTimesTheLobe() {
    const Eigen::Vector3d albedo(0.5, 0.4, 0.2);
    RelightShading shading;
    QVERIFY(!shading.specular);  // the preview starts Lambertian
    const Eigen::Vector3d lambert = ShadeRelight(albedo, kUp, kLight60, kUp, shading);
    QVERIFY(lambert.isApprox(albedo * 0.5, 1e-12));
    shading.specular = true;
    shading.roughness = 0.5;
    shading.f0 = 0.04;
    const Eigen::Vector3d shaded = ShadeRelight(albedo, kUp, kLight60, kUp, shading);
    const double lobe = std::numbers::pi * 0.0035947544303418146 * 0.5;
    for (int c = 0; c < 3; ++c) QVERIFY(Near(shaded[c], albedo[c] * 0.5 + lobe, 1e-12));
    // Facing away from the light: black, with or without the lobe.
    QVERIFY(ShadeRelight(albedo, Eigen::Vector3d(-1, 0, 0), kLight60, kUp, shading).isZero());
  }

  void OptionsAreChecked() {
    RelightShading shading;
    shading.roughness = 0.0;
    QVERIFY_THROWS_EXCEPTION(std::invalid_argument, shading.Check());
    try {
      shading.Check();
    } catch (const std::invalid_argument& error) {
      QVERIFY2(QString(error.what()).contains("roughness = 0 must be in [0.02, 1]"), error.what());
    }
    shading.roughness = 0.5;
    shading.f0 = 1.5;
    QVERIFY_THROWS_EXCEPTION(std::invalid_argument, shading.Check());
    shading.f0 = std::nan("");
    QVERIFY_THROWS_EXCEPTION(std::invalid_argument, shading.Check());
  }

  void PreviewShowsTheHighlightWhereTheNormalIsTheHalfVector() {
    // Two pixels: one tilted to the half vector of a 60° light (mirror
    // direction), one flat. The lobe lifts the first far more than the second.
    RelightMaps maps;
    maps.normal = ImageF(2, 1, 3);
    maps.albedo = ImageF(2, 1, 3);
    const Eigen::Vector3d half = (kLight60 + kUp).normalized();
    for (int c = 0; c < 3; ++c) {
      maps.normal(0, 0, c) = float(half[c]);
      maps.normal(1, 0, c) = float(kUp[c]);
      maps.albedo(0, 0, c) = maps.albedo(1, 0, c) = 0.2f;
    }
    maps.albedo_scale = 1;
    const QImage matte = Relight(maps, kLight60.x(), kLight60.y(), kLight60.z());
    RelightShading glossy;
    glossy.specular = true;
    glossy.roughness = 0.3;
    const QImage shiny = Relight(maps, kLight60.x(), kLight60.y(), kLight60.z(), glossy);
    const int gain_at_mirror = qGreen(shiny.pixel(0, 0)) - qGreen(matte.pixel(0, 0));
    const int gain_off_mirror = qGreen(shiny.pixel(1, 0)) - qGreen(matte.pixel(1, 0));
    QVERIFY2(gain_at_mirror > 40, qPrintable(QString::number(gain_at_mirror)));
    QVERIFY2(gain_off_mirror < gain_at_mirror / 4, qPrintable(QString::number(gain_off_mirror)));
    glossy.roughness = 0.001;
    QVERIFY_THROWS_EXCEPTION(std::invalid_argument, Relight(maps, 0, 0, 1, glossy));
  }

  void RequestsMadeWhileOneRendersCollapseIntoTheLast() {
    // Requests in one burst (no event processed between them): the first
    // starts at once, the next six are stale before they could start, the
    // last is rendered after the first. Exactly two renders, in that order.
    const std::shared_ptr<const RelightMaps> maps = DomeMaps(400, 300);
    RelightShading glossy;
    glossy.specular = true;
    RelightRenderer renderer;
    renderer.SetMaps(maps);
    QList<QImage> shown;
    connect(&renderer, &RelightRenderer::Rendered, this, [&](const QImage& image) { shown << image; });
    const std::vector<Eigen::Vector3d> path = DragPath(8);
    for (const Eigen::Vector3d& light : path) renderer.Request(light.x(), light.y(), light.z(), glossy);
    QVERIFY(shown.isEmpty());  // Request never renders on the calling thread
    QVERIFY(renderer.WaitUntilIdle(30000));
    QCOMPARE(renderer.renders_started(), 2);
    QCOMPARE(shown.size(), 2);
    QVERIFY(shown[0] == Relight(*maps, path[0].x(), path[0].y(), path[0].z(), glossy));
    QVERIFY(shown[1] == Relight(*maps, path[7].x(), path[7].y(), path[7].z(), glossy));
    QVERIFY(shown[0] != shown[1]);
    // A shading that fails its check throws at once and queues nothing.
    glossy.roughness = 0.001;
    QVERIFY_THROWS_EXCEPTION(std::invalid_argument, renderer.Request(0, 0, 1, glossy));
    QVERIFY(!renderer.busy());
  }

  void DraggingEndsWithTheLastPositionsImage() {
    // A drag as the pad sends it: the event loop runs between the moves, so
    // how many renders start depends on the machine; what is shown is
    // always some requested position's image, in the order of the drag, and
    // the last image is the last position's.
    const std::shared_ptr<const RelightMaps> maps = DomeMaps(640, 480);
    RelightRenderer renderer;
    renderer.SetMaps(maps);
    QList<QImage> shown;
    connect(&renderer, &RelightRenderer::Rendered, this, [&](const QImage& image) { shown << image; });
    const std::vector<Eigen::Vector3d> path = DragPath(12);
    for (const Eigen::Vector3d& light : path) {
      renderer.Request(light.x(), light.y(), light.z(), RelightShading());
      QCoreApplication::processEvents();
    }
    QVERIFY(renderer.WaitUntilIdle(30000));
    QVERIFY(!shown.isEmpty());
    QVERIFY(renderer.renders_started() <= int(path.size()));
    QCOMPARE(int(shown.size()), renderer.renders_started());
    std::vector<QImage> expected;
    for (const Eigen::Vector3d& light : path) expected.push_back(Relight(*maps, light.x(), light.y(), light.z()));
    int previous = -1;
    for (const QImage& image : shown) {
      int position = previous + 1;
      while (position < int(expected.size()) && image != expected[position]) ++position;
      QVERIFY2(position < int(expected.size()), "an image shown is no later position's");
      previous = position;
    }
    QVERIFY(shown.last() == expected.back());
  }

  void UiThreadGoesOnWhileALargeRelightRenders() {
    // 3000 x 2000 with the lobe. The worker hook holds the render on its
    // thread until the UI thread has run calls queued after the request: a
    // render on the UI thread could not let them through.
    const std::shared_ptr<const RelightMaps> maps = DomeMaps(3000, 2000);
    RelightShading glossy;
    glossy.specular = true;
    glossy.roughness = 0.3;
    RelightRendererOptions full_size_only;
    full_size_only.preview_max_pixels = 0;
    RelightRenderer renderer(full_size_only);
    renderer.SetMaps(maps);
    QThread* const ui_thread = QThread::currentThread();
    std::atomic<bool> hook_on_worker = false;
    QSemaphore entered, release;
    renderer.SetWorkerHook([&] {
      hook_on_worker = QThread::currentThread() != ui_thread;
      entered.release();
      release.acquire();
    });
    QImage shown;
    int rendered = 0;
    connect(&renderer, &RelightRenderer::Rendered, this, [&](const QImage& image) {
      shown = image;
      ++rendered;
    });
    renderer.Request(-0.6, 0.45, std::sqrt(1 - 0.36 - 0.2025), glossy);
    QVERIFY(entered.tryAcquire(1, 30000));
    QVERIFY(hook_on_worker);
    int handled = 0;
    for (int i = 0; i < 5; ++i) QMetaObject::invokeMethod(this, [&handled] { ++handled; }, Qt::QueuedConnection);
    QTRY_COMPARE_WITH_TIMEOUT(handled, 5, 30000);
    // A newer light position while it renders: it waits, then wins.
    renderer.Request(0.5, 0, std::sqrt(0.75), glossy);
    QCoreApplication::processEvents();
    QVERIFY(renderer.busy());
    QCOMPARE(rendered, 0);
    release.release(2);  // this render and the next
    QVERIFY(renderer.WaitUntilIdle(120000));
    QCOMPARE(renderer.renders_started(), 2);
    QCOMPARE(rendered, 2);
    QCOMPARE(shown.size(), QSize(3000, 2000));
    QVERIFY(shown == Relight(*maps, 0.5, 0, std::sqrt(0.75), glossy));
  }

  void LargeMapsShowAPreviewThenTheFullImage() {
    // 1200 x 800 with at most 100 000 preview pixels: every 4th pixel
    // (300 x 200), enlarged back to 1200 x 800.
    const std::shared_ptr<const RelightMaps> maps = DomeMaps(1200, 800);
    RelightRendererOptions options;
    options.preview_max_pixels = 100000;
    RelightRenderer renderer(options);
    renderer.SetMaps(maps);
    QList<QImage> shown;
    QList<bool> full;
    connect(&renderer, &RelightRenderer::Rendered, this, [&](const QImage& image, bool full_size) {
      shown << image;
      full << full_size;
    });
    // A burst of positions: the first one's preview, then the last one's
    // preview (newer than refining the first), then the last one at full size.
    const std::vector<Eigen::Vector3d> path = DragPath(6);
    for (const Eigen::Vector3d& light : path) renderer.Request(light.x(), light.y(), light.z(), RelightShading());
    QVERIFY(renderer.WaitUntilIdle(30000));
    QCOMPARE(renderer.renders_started(), 3);
    QCOMPARE(full, QList<bool>({false, false, true}));
    const QImage first = Relight(*maps, path[0].x(), path[0].y(), path[0].z());
    const QImage last = Relight(*maps, path[5].x(), path[5].y(), path[5].z());
    QVERIFY(shown[2] == last);
    for (int i : {0, 1}) {
      const QImage& expected = i == 0 ? first : last;
      QCOMPARE(shown[i].size(), QSize(1200, 800));
      QVERIFY(shown[i] != expected);  // a preview, not the full image
      int off_grid = 0;
      for (int y = 0; y < 800; y += 4)
        for (int x = 0; x < 1200; x += 4) off_grid += shown[i].pixel(x, y) != expected.pixel(x, y);
      QCOMPARE(off_grid, 0);  // but exact at the pixels it sampled
    }

    // The light rests (its preview shown, the full size rendering), then
    // moves on: the stale refinement is stopped and never shown, the new
    // position's preview and full image follow.
    shown.clear();
    full.clear();
    QSemaphore release;
    std::atomic<int> renders_seen = 0;
    std::atomic<bool> refinement_held = false;
    renderer.SetWorkerHook([&] {
      if (++renders_seen == 2) {  // the first position's refinement
        refinement_held = true;
        release.acquire();
      }
    });
    renderer.Request(path[0].x(), path[0].y(), path[0].z(), RelightShading());
    QTRY_VERIFY_WITH_TIMEOUT(refinement_held.load(), 30000);  // the preview's end starts the refinement
    renderer.Request(path[5].x(), path[5].y(), path[5].z(), RelightShading());
    release.release();
    QVERIFY(renderer.WaitUntilIdle(30000));
    QCOMPARE(renders_seen.load(), 4);
    QCOMPARE(full, QList<bool>({false, false, true}));
    QVERIFY(shown[2] == last);

    options.preview_max_pixels = -1;
    QVERIFY_THROWS_EXCEPTION(std::invalid_argument, RelightRenderer{options});
  }

  void RenderOfReplacedMapsIsDropped() {
    RelightRenderer renderer;
    renderer.SetMaps(DomeMaps(64, 48));
    QSemaphore release;
    renderer.SetWorkerHook([&] { release.acquire(); });
    int rendered = 0;
    connect(&renderer, &RelightRenderer::Rendered, this, [&] { ++rendered; });
    renderer.Request(0, 0, 1, RelightShading());
    // Another result opened while the first one's relight renders.
    const std::shared_ptr<const RelightMaps> other = DomeMaps(32, 24);
    renderer.SetMaps(other);
    release.release();
    QVERIFY(renderer.WaitUntilIdle(30000));
    QCOMPARE(rendered, 0);
    QImage shown;
    connect(&renderer, &RelightRenderer::Rendered, this, [&](const QImage& image) { shown = image; });
    release.release();
    renderer.Request(0, 0, 1, RelightShading());
    QVERIFY(renderer.WaitUntilIdle(30000));
    QCOMPARE(rendered, 1);
    QVERIFY(shown == Relight(*other, 0, 0, 1));
    renderer.SetMaps(nullptr);
    renderer.Request(0, 0, 1, RelightShading());  // no maps: nothing to do
    QVERIFY(!renderer.busy());
  }
};

}  // namespace scanbench

QTEST_GUILESS_MAIN(scanbench::RelightTest)
#include "relight_test.moc"
