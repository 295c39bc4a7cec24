// The live view: clipping judged on the RAW data where the bench has it, on
// the preview otherwise; the preview fetched on a worker so that the window
// keeps handling events while a camera is slow; no fetch while a job owns
// the camera.
#include <QCheckBox>
#include <QLabel>
#include <QPushButton>
#include <QScopeGuard>
#include <QSemaphore>
#include <QSettings>
#include <QSpinBox>
#include <QTest>
#include <QThread>
#include <QTimer>

#include <atomic>
#include <string>

#include "app/gui/controller_runner.h"
#include "app/gui/devices_page.h"
#include "app/gui/live_view.h"
#include "app/gui/main_window.h"
#include "app/gui/result_images.h"
#include "app/io/dng_writer.h"
#include "tests/util/temporary_folder.h"
#include "calibration/raw_develop.h"

namespace scanbench {

namespace {
constexpr QRgb kRed = 0xffff0000;

// 64x64 RGGB at 12 % of the range, with an 8x8 block at the white level
// (raw x, y 8..15) and one at 95 % of it (raw x, y 32..39).
RawImage TestRaw() {
  RawImage raw;
  raw.mosaic = ImageU16(64, 64, 1, uint16_t(600 + 1900));
  raw.black_level = {600, 600, 600, 600};
  raw.white_level = 16383;
  for (int y = 8; y < 16; ++y)
    for (int x = 8; x < 16; ++x) raw.mosaic(x, y) = 16383;
  for (int y = 32; y < 40; ++y)
    for (int x = 32; x < 40; ++x) raw.mosaic(x, y) = uint16_t(0.95 * 16383);
  return raw;
}
}  // namespace

class LiveViewTest : public QObject {
  Q_OBJECT

 private:
  std::unique_ptr<MainWindow> window_;

 private slots:
  void ClippingComesFromTheRawClipLevel() {
    const double clip_fraction = RawDevelopOptions{}.clip_fraction;
    const LiveFrame frame = LiveFrameFromRaw(TestRaw(), clip_fraction);
    QVERIFY(frame.from_raw);
    QVERIFY(frame.error.isEmpty());
    QCOMPARE(frame.image.width(), 32);  // one pixel per 2x2 tile, histogram under it
    QVERIFY(frame.image.height() > 32);
    // The white-level block: 4x4 preview pixels, all red; 16 of 1024.
    for (int y = 4; y < 8; ++y)
      for (int x = 4; x < 8; ++x) QCOMPARE(frame.image.pixel(x, y), kRed);
    QCOMPARE(frame.clipped_fraction, 16.0 / 1024);
    // 95 % of the range is bright (it would saturate an auto-gained 8-bit
    // preview) but below the solve's clip level: not marked.
    QVERIFY(frame.image.pixel(17, 17) != kRed);
    QVERIFY(frame.image.pixel(0, 0) != kRed);

    // The solve's rule exactly: a sample at int(clip_fraction x white) is clipped, one below is not.
    RawImage edge = TestRaw();
    const int clip_level = int(clip_fraction * edge.white_level);
    edge.mosaic(33, 33) = uint16_t(clip_level - 1);
    edge.mosaic(32, 32) = uint16_t(clip_level - 1);
    edge.mosaic(33, 32) = uint16_t(clip_level - 1);
    edge.mosaic(32, 33) = uint16_t(clip_level - 1);
    edge.mosaic(0, 1) = uint16_t(clip_level);
    const LiveFrame at_edge = LiveFrameFromRaw(edge, clip_fraction);
    QVERIFY(at_edge.image.pixel(16, 16) != kRed);
    QCOMPARE(at_edge.image.pixel(0, 0), kRed);
  }

  void WithoutRawTheChannelAtTheTopOfThePreviewIsClipped() {
    // A 2x1 PPM: one pixel with red at 255, one bright but below the top.
    const std::string ppm = std::string("P6\n2 1\n255\n") + char(255) + char(40) + char(30) + char(200) +
                            char(180) + char(150);
    const LiveFrame frame = LiveFrameFromPreview(std::vector<uint8_t>(ppm.begin(), ppm.end()));
    QVERIFY(!frame.from_raw);
    QCOMPARE(frame.image.pixel(0, 0), kRed);
    QVERIFY(frame.image.pixel(1, 0) != kRed);
    QCOMPARE(frame.clipped_fraction, 0.5);
    QVERIFY(!LiveFrameFromPreview({1, 2, 3}).error.isEmpty());
  }

  void initTestCase() {
    QCoreApplication::setOrganizationName("scanbench");
    QCoreApplication::setApplicationName("scanbench-gui-live-view-test");
    QSettings().clear();
    window_ = std::make_unique<MainWindow>();
    window_->resize(1000, 700);
    window_->show();
    window_->ShowPage(MainWindow::kDevicesPage);
    window_->findChild<QSpinBox*>("simWidth")->setValue(160);
    window_->findChild<QSpinBox*>("simHeight")->setValue(106);
    QTest::mouseClick(window_->findChild<QPushButton*>("connectButton"), Qt::LeftButton);
    QVERIFY(window_->runner()->Wait(60000));
    QVERIFY(window_->devices()->bench() != nullptr);
  }

  void cleanupTestCase() { window_.reset(); }

  // Issue #36 item 4: a capture thumbnail is developed by the live view's
  // helper: white-balanced (a sensor's green-heavy raw reads neutral) and box
  // filtered (a weave finer than the thumbnail's step averages out instead of
  // aliasing), and a dark frame stays dark.
  void ThumbnailsAreDevelopedLikeTheLiveView() {
    // 256x64 RGGB, the raw of a grey cloth: red at 45 % and blue at 70 % of
    // green. The left half a weave of alternating bright and black tile
    // columns (period 2 tiles), the right half even at the weave's mean.
    RawImage raw;
    raw.mosaic = ImageU16(256, 64, 1, uint16_t(600));
    raw.black_level = {600, 600, 600, 600};
    raw.white_level = 16383;
    const double green = 3000;
    for (int y = 0; y < 64; ++y) {
      for (int x = 0; x < 256; ++x) {
        const int colour = CfaColorAt(raw.cfa, x, y);
        const double level = green * (colour == 0 ? 0.45 : colour == 2 ? 0.7 : 1.0);
        const bool left = x < 128;
        const double weave = left ? ((x / 2) % 2 == 0 ? 2.0 : 0.0) : 1.0;
        raw.mosaic(x, y) = uint16_t(600 + level * weave);
      }
    }
    testing::TemporaryFolder folder;
    WriteDng(folder / "led_00.dng", raw);
    const QImage thumbnail = RawThumbnail(folder / "led_00.dng", 32);  // a step of 4 tiles
    QCOMPARE(thumbnail.width(), 32);
    QCOMPARE(thumbnail, DevelopRawPreview(raw, RawDevelopOptions{}.clip_fraction, 32, 0.05).image);
    double sums[2][3] = {{0, 0, 0}, {0, 0, 0}};
    for (int y = 0; y < thumbnail.height(); ++y) {
      for (int x = 0; x < thumbnail.width(); ++x) {
        const QRgb p = thumbnail.pixel(x, y);
        double* sum = sums[x < 16 ? 0 : 1];
        sum[0] += qRed(p);
        sum[1] += qGreen(p);
        sum[2] += qBlue(p);
      }
    }
    const double n = 16.0 * thumbnail.height();
    for (int half = 0; half < 2; ++half) {
      // Neutral: the raw's tint is balanced away.
      QVERIFY2(std::abs(sums[half][0] - sums[half][1]) / n < 3 && std::abs(sums[half][2] - sums[half][1]) / n < 3,
               qPrintable(QStringLiteral("RGB %1 %2 %3").arg(sums[half][0] / n).arg(sums[half][1] / n).arg(sums[half][2] / n)));
    }
    // Filtered: the weave reads as its mean, as bright as the even half
    // (sampling one tile per step would show it at twice that, or black).
    QVERIFY2(std::abs(sums[0][1] - sums[1][1]) / n < 3,
             qPrintable(QStringLiteral("weave %1, even %2").arg(sums[0][1] / n).arg(sums[1][1] / n)));

    // A dark frame (black plus a little noise) is not brightened into noise.
    RawImage dark = raw;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 256; ++x) dark.mosaic(x, y) = uint16_t(600 + (x * 7 + y * 3) % 9);
    WriteDng(folder / "dark.dng", dark);
    const QImage dark_thumbnail = RawThumbnail(folder / "dark.dng", 32);
    int brightest = 0;
    for (int y = 0; y < dark_thumbnail.height(); ++y)
      for (int x = 0; x < dark_thumbnail.width(); ++x) brightest = std::max(brightest, qGreen(dark_thumbnail.pixel(x, y)));
    QVERIFY2(brightest < 40, qPrintable(QString::number(brightest)));
  }

  void SimulatedBenchShowsRawClipping() {
    auto* live = window_->findChild<QCheckBox*>("liveView");
    auto* image = window_->findChild<QLabel*>("liveImage");
    live->setChecked(true);
    QTRY_VERIFY_WITH_TIMEOUT(!image->pixmap().isNull(), 10000);
    // The simulated camera's RAW data is behind the picture.
    QVERIFY2(window_->findChild<QLabel*>("liveInfo")->text().contains("RAW sample"),
             qPrintable(window_->findChild<QLabel*>("liveInfo")->text()));
    live->setChecked(false);
    // Off: no old frame, and no caption of it (issue #36 item 6).
    QVERIFY(image->pixmap().isNull());
    QVERIFY(window_->findChild<QLabel*>("liveInfo")->text().isEmpty());
  }

  void UiKeepsHandlingEventsWhileTheCameraIsSlow() {
    DevicesPage* devices = window_->devices();
    auto* image = window_->findChild<QLabel*>("liveImage");
    image->clear();
    std::atomic<bool> entered{false};
    std::atomic<bool> returned{false};
    std::atomic<QThread*> fetch_thread{nullptr};
    QSemaphore release;
    const auto drop_source = qScopeGuard([&] {
      release.release();
      window_->findChild<QCheckBox*>("liveView")->setChecked(false);
      devices->WaitForLiveFetch();  // the source uses this function's locals
      devices->SetLiveSource({});
    });
    devices->SetLiveSource([&]() -> LiveFrame {
      fetch_thread = QThread::currentThread();
      entered = true;
      // A camera that hangs until the test lets it go (bounded, so that a
      // regression fails rather than hangs).
      release.tryAcquire(1, 20000);
      returned = true;
      return LiveFrameFromRaw(TestRaw(), 0.98);
    });
    window_->findChild<QCheckBox*>("liveView")->setChecked(true);
    QTRY_VERIFY_WITH_TIMEOUT(entered.load(), 5000);
    QVERIFY(fetch_thread.load() != QThread::currentThread());
    // While the fetch hangs, the window handles events: a queued call runs
    // and a button click lands.
    bool queued_ran = false;
    QTimer::singleShot(0, this, [&] { queued_ran = true; });
    QTRY_VERIFY_WITH_TIMEOUT(queued_ran, 5000);
    bool clicked = false;
    QPushButton probe("probe");
    connect(&probe, &QPushButton::clicked, this, [&] { clicked = true; });
    QTest::mouseClick(&probe, Qt::LeftButton);
    QVERIFY(clicked);
    QVERIFY(!returned.load());
    QVERIFY(image->pixmap().isNull());
    release.release();
    QTRY_VERIFY_WITH_TIMEOUT(!image->pixmap().isNull(), 5000);
  }

  void NoPreviewIsFetchedWhileAJobOwnsTheCamera() {
    DevicesPage* devices = window_->devices();
    std::atomic<int> fetches{0};
    QSemaphore job_may_end;
    const auto drop_source = qScopeGuard([&] {
      job_may_end.release();
      window_->runner()->Wait(10000);
      window_->findChild<QCheckBox*>("liveView")->setChecked(false);
      devices->WaitForLiveFetch();
      devices->SetLiveSource({});
    });
    devices->SetLiveSource([&]() -> LiveFrame {
      ++fetches;
      return LiveFrameFromRaw(TestRaw(), 0.98);
    });
    auto* timer = devices->findChild<QTimer*>("liveTimer");
    QVERIFY(timer != nullptr);
    std::atomic<bool> job_running{false};
    QVERIFY(window_->runner()->Start(std::make_shared<FunctionController>([&] {
                                       job_running = true;
                                       job_may_end.tryAcquire(1, 30000);
                                     }),
                                     "Hold the camera"));
    QTRY_VERIFY_WITH_TIMEOUT(job_running.load(), 5000);
    int ticks = 0;
    QObject counting;  // the connection ends with it, however this ends
    connect(timer, &QTimer::timeout, &counting, [&] { ++ticks; });
    window_->findChild<QCheckBox*>("liveView")->setChecked(true);
    QTRY_VERIFY_WITH_TIMEOUT(ticks >= 3, 10000);  // the live view had three turns...
    QCOMPARE(fetches.load(), 0);                  // ...and left the camera to the job
    job_may_end.release();
    QVERIFY(window_->runner()->Wait(10000));
    QTRY_VERIFY_WITH_TIMEOUT(fetches.load() > 0, 5000);  // and resumes after it
  }
};

}  // namespace scanbench

QTEST_MAIN(scanbench::LiveViewTest)
#include "live_view_test.moc"
