// The Devices page's state (issue #36 items 6 and 7): the LED buttons show
// the LED the board reports lit, also after a job that turned them off; the
// live view shows no old frame once it is off; a failed camera connect keeps
// a working LED board and says what the actual problem is.
#include <QCheckBox>
#include <QComboBox>
#include <QGroupBox>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QSettings>
#include <QSpinBox>
#include <QTemporaryDir>
#include <QTest>

#include <fstream>

#include "app/gui/controller_runner.h"
#include "app/gui/devices_page.h"
#include "app/gui/main_window.h"
#include "tests/app/gui/widget_test_util.h"
#include "app/session/rig_json.h"
#include "app/sim/simulated_rig.h"

namespace scanbench {

class DevicesPageTest : public QObject {
  Q_OBJECT

 private:
  template <typename T>
  T* Find(const char* name) {
    return testing::FindWidget<T>(*window_, name);
  }
  ControllerRunner::Outcome ClickAndWait(const char* button, int timeout_ms = 60000) {
    return testing::ClickAndWait(*window_, button, timeout_ms);
  }
  QString Status() { return Find<QLabel>("devicesStatus")->text(); }

  std::unique_ptr<MainWindow> window_;
  QTemporaryDir work_;

 private slots:
  void initTestCase() {
    QCoreApplication::setOrganizationName("scanbench");
    QCoreApplication::setApplicationName("scanbench-devices-page-test");
    QSettings().clear();
    window_ = std::make_unique<MainWindow>();
    window_->resize(1200, 800);
    window_->show();
    window_->ShowPage(MainWindow::kDevicesPage);
    Find<QSpinBox>("simWidth")->setValue(160);
    Find<QSpinBox>("simHeight")->setValue(106);
    QCOMPARE(ClickAndWait("connectButton"), ControllerRunner::Outcome::kSucceeded);
    QVERIFY(window_->devices()->bench() != nullptr);
  }
  void cleanupTestCase() { window_.reset(); }

  // "LED 3 on: done." stayed after a capture had turned every LED off, and no
  // button showed which LED was lit.
  void LedButtonsShowWhatTheBoardReportsAfterAnyJob() {
    QCOMPARE(ClickAndWait("led3"), ControllerRunner::Outcome::kSucceeded);
    QVERIFY(Find<QPushButton>("led3")->isChecked());
    QVERIFY(!Find<QPushButton>("led2")->isChecked());
    QVERIFY2(Status().contains("LED 3 lit"), qPrintable(Status()));
    // Another page's job switches the LEDs off, as a capture does at its end.
    Bench* bench = window_->devices()->bench();
    QVERIFY(window_->runner()->Start(
        std::make_shared<FunctionController>([bench] { bench->lights().AllOff(); }), "Capture"));
    QVERIFY(window_->runner()->Wait(10000));
    QVERIFY(!Find<QPushButton>("led3")->isChecked());
    QVERIFY2(Status().contains("All LEDs off (Capture turned them off)"), qPrintable(Status()));
    // A click on a lit LED's button keeps it shown lit (the board decides, not the toggle).
    QCOMPARE(ClickAndWait("led1"), ControllerRunner::Outcome::kSucceeded);
    QCOMPARE(ClickAndWait("led1"), ControllerRunner::Outcome::kSucceeded);
    QVERIFY(Find<QPushButton>("led1")->isChecked());
    QCOMPARE(ClickAndWait("allOff"), ControllerRunner::Outcome::kSucceeded);
    QVERIFY(!Find<QPushButton>("led1")->isChecked());
  }

  // The live view kept the last frame with "Show preview" unticked.
  void LiveViewShowsNoOldFrameOnceOff() {
    auto* live = Find<QCheckBox>("liveView");
    auto* image = Find<QLabel>("liveImage");
    live->setChecked(true);
    QTRY_VERIFY_WITH_TIMEOUT(!image->pixmap().isNull(), 10000);
    live->setChecked(false);
    window_->devices()->WaitForLiveFetch();
    QCoreApplication::processEvents();
    QVERIFY(image->pixmap().isNull());
    QCOMPARE(image->text(), QStringLiteral("Live view off."));
  }

  // A USB camera chosen without a rig file: nothing connected is let go, and
  // the message is about the rig file, not the cable.
  void ACameraWithoutARigFileChangesNothing() {
    auto* camera = Find<QComboBox>("cameraChoice");
    camera->setCurrentIndex(camera->findData(QStringLiteral("gphoto2")));
    Find<QLineEdit>("rigFile")->clear();
    QTest::mouseClick(Find<QPushButton>("connectButton"), Qt::LeftButton);
    QVERIFY(!window_->runner()->busy());
    QVERIFY2(Status().contains("needs the bench's rig description"), qPrintable(Status()));
    QVERIFY2(!Status().contains("cable"), qPrintable(Status()));
    QVERIFY2(window_->devices()->bench() != nullptr, "the working bench stays connected");
    camera->setCurrentIndex(camera->findData(QStringLiteral("simulated")));
  }

  // The camera itself fails (no USB camera here): the LED board stays
  // connected and usable; the message is the camera's.
  void AFailedCameraConnectKeepsTheLedBoard() {
    const QString rig_file = work_.filePath("rig.json");
    {
      std::ofstream(rig_file.toStdString()) << RigDescriptionToJson(MakeDefaultSimulatedRig(160, 106));
    }
    QCOMPARE(ClickAndWait("led4"), ControllerRunner::Outcome::kSucceeded);
    auto* live = Find<QCheckBox>("liveView");
    live->setChecked(true);
    QTRY_VERIFY_WITH_TIMEOUT(!Find<QLabel>("liveImage")->pixmap().isNull(), 10000);

    auto* camera = Find<QComboBox>("cameraChoice");
    camera->setCurrentIndex(camera->findData(QStringLiteral("gphoto2")));
    Find<QLineEdit>("rigFile")->setText(rig_file);
    Find<QLineEdit>("cameraModel")->setText("No Such Camera");
    Find<QLineEdit>("cameraPort")->setText("usb:999,999");
    QCOMPARE(ClickAndWait("connectButton", 120000), ControllerRunner::Outcome::kFailed);
    QVERIFY2(Status().startsWith("Camera connect failed"), qPrintable(Status()));
    QVERIFY2(Status().contains("The LED board stays connected"), qPrintable(Status()));
    QVERIFY2(!Status().contains("Check the cable and the port"), qPrintable(Status()));
    QVERIFY(window_->devices()->bench() == nullptr);
    QVERIFY(window_->devices()->lights() != nullptr);
    QVERIFY2(Find<QLabel>("lightsInfo")->text().contains("scanbench-leds"), qPrintable(Find<QLabel>("lightsInfo")->text()));
    QCOMPARE(Find<QLabel>("cameraInfo")->text(), QStringLiteral("Camera: not connected"));
    // No frame of the camera that is gone.
    QVERIFY(Find<QLabel>("liveImage")->pixmap().isNull());
    // The board still works, and still shows its lit LED (the same board, not reopened).
    QVERIFY(Find<QPushButton>("led4")->isChecked());
    QCOMPARE(ClickAndWait("led2"), ControllerRunner::Outcome::kSucceeded);
    QCOMPARE(window_->devices()->lights()->lights().Status().lit_led, std::optional<int>(2));
    // Back to the simulated camera: the kept board is used, no new one opened.
    BenchLights* kept = window_->devices()->lights();
    camera->setCurrentIndex(camera->findData(QStringLiteral("simulated")));
    QCOMPARE(ClickAndWait("connectButton"), ControllerRunner::Outcome::kSucceeded);
    QVERIFY(window_->devices()->bench() != nullptr);
    QCOMPARE(window_->devices()->lights(), kept);
    QVERIFY(Find<QPushButton>("led2")->isChecked());
  }
};

}  // namespace scanbench

QTEST_MAIN(scanbench::DevicesPageTest)
#include "devices_page_test.moc"
