// Devices: which LED board and camera (simulated by default), connect /
// reconnect, the firmware and camera as they report themselves, one button
// per LED, and the live view (preview + histogram + clipping) on a timer.
#pragma once

#include <QWidget>

#include <functional>
#include <memory>
#include <optional>

#include "app/gui/bench.h"
#include "app/gui/live_view.h"

template <typename T>
class QFutureWatcher;

class QCheckBox;
class QComboBox;
class QGridLayout;
class QLabel;
class QLayout;
class QLineEdit;
class QPushButton;
class QSpinBox;
class QTimer;

namespace scanbench {

class ControllerRunner;

class DevicesPage : public QWidget {
  Q_OBJECT

 public:
  DevicesPage(ControllerRunner* runner, QWidget* parent = nullptr);
  ~DevicesPage() override;

  // nullptr until both devices are connected.
  Bench* bench() { return bench_.get(); }
  // The LED board, also while the camera is not connected (a failed camera
  // connect keeps it); nullptr when none is.
  BenchLights* lights() { return bench_ ? bench_->lights_part().get() : lights_only_.get(); }
  // What the live view shows, called on a worker thread while no job runs.
  // Default: FetchLiveFrame on the connected bench. Tests put a slow or
  // scripted camera here.
  using LiveSource = std::function<LiveFrame()>;
  void SetLiveSource(LiveSource source) { live_source_ = std::move(source); }
  // Blocks until a preview being fetched has arrived (tests, reconnect).
  void WaitForLiveFetch();
  // The RAW-based frame when the bench has one (simulated camera), else the
  // camera's own preview.
  static LiveFrame FetchLiveFrame(Bench& bench);
  void LoadSettings();
  void SaveSettings() const;

 signals:
  void BenchChanged();

 public slots:
  void Connect();
  void RefreshPorts();
  void DetectUsbCameras();

 private:
  // The constructor's steps; each builds one group box and connects its own
  // widgets.
  QWidget* MakeBenchBox();
  QLayout* MakeSimSizeRow(QWidget* box);
  QWidget* MakeStatusBox();
  QWidget* MakeLedBox();
  QWidget* MakeLiveBox();

  BenchOptions OptionsFromWidgets() const;
  void RebuildLedButtons();
  void RunDeviceJob(const QString& name, std::function<void()> work, std::optional<int> lit_after);
  // Asks the board which LED is lit (after any job: a capture turns them all
  // off) and shows it on the LED buttons; `after_job` names the job.
  void RefreshLedState(const QString& after_job);
  void ShowLitLed();
  void ShowBoardInfo();
  // The live view shows nothing (with why) rather than an old frame.
  void ClearLiveView(const QString& why);
  void UpdateLiveView();
  void ShowLiveFrame();
  void SetStatus(const QString& text, bool error = false);

  ControllerRunner* runner_;
  std::unique_ptr<Bench> bench_;
  std::shared_ptr<BenchLights> lights_only_;  // the board a failed camera connect left connected
  std::optional<int> lit_led_;                // as the board last reported (nullopt: all off)
  bool led_message_shown_ = false;            // the status line is an LED job's
  bool lit_after_job_ = false;                // the job that just ended was an LED job of this page
  QComboBox* lights_choice_;
  QComboBox* camera_choice_;
  QLineEdit* camera_model_;
  QLineEdit* camera_port_;
  QLineEdit* rig_file_;
  QSpinBox* sim_width_;
  QSpinBox* sim_height_;
  QPushButton* connect_button_;
  QLabel* lights_info_;
  QLabel* camera_info_;
  QLabel* status_;
  QGridLayout* led_grid_;
  QWidget* led_box_;
  QCheckBox* live_view_;
  QLabel* live_image_;
  QLabel* live_info_;
  QTimer* live_timer_;
  QFutureWatcher<LiveFrame>* live_watcher_;
  LiveSource live_source_;
};

}  // namespace scanbench
