#include "app/gui/devices_page.h"

#include <QCheckBox>
#include <QComboBox>
#include <QFileDialog>
#include <QFormLayout>
#include <QFutureWatcher>
#include <QGridLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QSettings>
#include <QSpinBox>
#include <QTimer>
#include <QVBoxLayout>
#include <QtConcurrent/QtConcurrentRun>

#include <mutex>

#include "app/devices/camera/device_discovery.h"
#include "app/devices/serial_port_list.h"
#include "app/gui/controller_runner.h"
#include "app/gui/page_widgets.h"
#include "calibration/raw_develop.h"

namespace scanbench {

namespace {
const QString kSimulated = QStringLiteral("simulated");
}

DevicesPage::DevicesPage(ControllerRunner* runner, QWidget* parent) : QWidget(parent), runner_(runner) {
  auto* left = new QVBoxLayout;
  left->addWidget(MakeBenchBox());
  left->addWidget(MakeStatusBox());
  left->addWidget(MakeLedBox());
  left->addStretch();
  auto* layout = new QHBoxLayout(this);
  layout->addLayout(left, 1);
  layout->addWidget(MakeLiveBox(), 1);
  RefreshPorts();
  // Any job may have switched the LEDs (a capture ends with all off): the
  // buttons show what the board reports afterwards.
  connect(runner_, &ControllerRunner::Finished, this, [this] { RefreshLedState(runner_->job_name()); });
}

// Which LED board and camera, and Connect.
QWidget* DevicesPage::MakeBenchBox() {
  auto* choose = new QGroupBox(tr("Bench"), this);
  auto* form = new QFormLayout(choose);
  lights_choice_ = new QComboBox(choose);
  lights_choice_->setObjectName("lightsChoice");
  auto* refresh = new QPushButton(tr("Refresh ports"), choose);
  form->addRow(tr("LED board"), FieldWithButton(lights_choice_, refresh));
  camera_choice_ = new QComboBox(choose);
  camera_choice_->setObjectName("cameraChoice");
  camera_choice_->addItem(tr("Simulated camera"), kSimulated);
  camera_choice_->addItem(tr("Camera over USB (libgphoto2)"), QStringLiteral("gphoto2"));
  auto* detect = NamedButton(tr("Detect cameras"), "detectCameras", choose);
  form->addRow(tr("Camera"), FieldWithButton(camera_choice_, detect));
  camera_model_ = new QLineEdit(choose);
  camera_model_->setObjectName("cameraModel");
  camera_model_->setPlaceholderText(tr("autodetect, or e.g. Nikon DSC D5100 (PTP mode)"));
  form->addRow(tr("Camera model"), camera_model_);
  camera_port_ = new QLineEdit(choose);
  camera_port_->setObjectName("cameraPort");
  camera_port_->setPlaceholderText(tr("autodetect, or e.g. usb:001,004"));
  form->addRow(tr("Camera port"), camera_port_);
  rig_file_ = new QLineEdit(choose);
  rig_file_->setObjectName("rigFile");
  rig_file_->setPlaceholderText(tr("real camera: the bench's rig description (JSON)"));
  auto* rig_browse = new QPushButton(tr("Browse…"), choose);
  form->addRow(tr("Rig file"), FieldWithButton(rig_file_, rig_browse));
  form->addRow(tr("Simulated image"), MakeSimSizeRow(choose));
  connect_button_ = NamedButton(tr("Connect"), "connectButton", choose);
  form->addRow(QString(), connect_button_);

  connect(refresh, &QPushButton::clicked, this, &DevicesPage::RefreshPorts);
  connect(connect_button_, &QPushButton::clicked, this, &DevicesPage::Connect);
  connect(detect, &QPushButton::clicked, this, &DevicesPage::DetectUsbCameras);
  // Only the fields of the chosen camera kind can be edited.
  auto enable_camera_fields = [this] {
    const bool simulated = camera_choice_->currentData().toString() == kSimulated;
    for (QWidget* field : std::initializer_list<QWidget*>{camera_model_, camera_port_, rig_file_}) {
      field->setEnabled(!simulated);
    }
    sim_width_->setEnabled(simulated);
    sim_height_->setEnabled(simulated);
  };
  connect(camera_choice_, &QComboBox::currentIndexChanged, this, enable_camera_fields);
  enable_camera_fields();
  connect(rig_browse, &QPushButton::clicked, this, [this] {
    const QString file = QFileDialog::getOpenFileName(this, tr("Rig description"), rig_file_->text(),
                                                      tr("Rig description (*.json)"));
    if (!file.isEmpty()) rig_file_->setText(file);
  });
  return choose;
}

// The simulated camera's image size: width × height.
QLayout* DevicesPage::MakeSimSizeRow(QWidget* box) {
  sim_width_ = new QSpinBox(box);
  sim_width_->setObjectName("simWidth");
  sim_width_->setRange(64, 4928);
  sim_width_->setValue(1232);
  sim_height_ = new QSpinBox(box);
  sim_height_->setObjectName("simHeight");
  sim_height_->setRange(64, 3264);
  sim_height_->setValue(816);
  auto* size_row = new QHBoxLayout;
  size_row->addWidget(sim_width_);
  size_row->addWidget(new QLabel(QStringLiteral("×"), box));
  size_row->addWidget(sim_height_);
  size_row->addStretch();
  return size_row;
}

// The board and camera as they report themselves, and the last message.
QWidget* DevicesPage::MakeStatusBox() {
  auto* info = new QGroupBox(tr("Status"), this);
  auto* info_layout = new QVBoxLayout(info);
  lights_info_ = new QLabel(tr("LED board: not connected"), info);
  lights_info_->setObjectName("lightsInfo");
  camera_info_ = new QLabel(tr("Camera: not connected"), info);
  camera_info_->setObjectName("cameraInfo");
  status_ = new QLabel(info);
  status_->setObjectName("devicesStatus");
  status_->setWordWrap(true);
  for (QLabel* label : {lights_info_, camera_info_, status_}) {
    label->setTextInteractionFlags(Qt::TextSelectableByMouse);
    info_layout->addWidget(label);
  }
  return info;
}

// One button per LED, filled in by RebuildLedButtons once connected.
QWidget* DevicesPage::MakeLedBox() {
  led_box_ = new QGroupBox(tr("LED test"), this);
  led_grid_ = new QGridLayout(led_box_);
  led_box_->setEnabled(false);
  return led_box_;
}

// The camera's preview on a timer, fetched on a worker.
QWidget* DevicesPage::MakeLiveBox() {
  auto* live_box = new QGroupBox(tr("Live view"), this);
  auto* live_layout = new QVBoxLayout(live_box);
  live_view_ = new QCheckBox(tr("Show the camera's preview (red: clipped; histogram below)"), live_box);
  live_view_->setObjectName("liveView");
  live_image_ = new QLabel(live_box);
  live_image_->setObjectName("liveImage");
  live_image_->setMinimumSize(320, 240);
  live_image_->setAlignment(Qt::AlignCenter);
  live_image_->setText(tr("No camera connected."));
  live_layout->addWidget(live_view_);
  live_info_ = new QLabel(live_box);
  live_info_->setObjectName("liveInfo");
  live_info_->setWordWrap(true);
  live_layout->addWidget(live_image_, 1);
  live_layout->addWidget(live_info_);
  live_timer_ = new QTimer(this);
  live_timer_->setObjectName("liveTimer");
  live_timer_->setInterval(500);
  live_watcher_ = new QFutureWatcher<LiveFrame>(this);

  connect(live_view_, &QCheckBox::toggled, this, [this](bool on) {
    if (on) {
      live_timer_->start();
    } else {
      live_timer_->stop();
      ClearLiveView(tr("Live view off."));
    }
  });
  connect(live_timer_, &QTimer::timeout, this, &DevicesPage::UpdateLiveView);
  connect(live_watcher_, &QFutureWatcher<LiveFrame>::finished, this, &DevicesPage::ShowLiveFrame);
  return live_box;
}

// A preview still being fetched uses the bench: it ends first.
DevicesPage::~DevicesPage() { live_watcher_->waitForFinished(); }

void DevicesPage::RefreshPorts() {
  const QString current = lights_choice_->currentData().toString();
  lights_choice_->clear();
  lights_choice_->addItem(tr("Simulated LED board (firmware in simavr)"), kSimulated);
  try {
    for (const SerialPortInfo& port : ListSerialPorts()) {
      QString label = QString::fromStdString(port.path);
      if (!port.board.empty()) label += QStringLiteral(" — ") + QString::fromStdString(port.board);
      lights_choice_->addItem(label, QString::fromStdString(port.path));
    }
  } catch (const std::exception& error) {
    SetStatus(tr("Listing serial ports failed: %1").arg(error.what()), true);
  }
  const int index = lights_choice_->findData(current);
  if (index >= 0) lights_choice_->setCurrentIndex(index);
}

void DevicesPage::DetectUsbCameras() {
  // libgphoto2's autodetect can take seconds: it runs as a job.
  auto found = std::make_shared<std::vector<DetectedCamera>>();
  const bool started = runner_->Start(
      std::make_shared<FunctionController>([found] { *found = DetectCameras(); }), tr("Detect cameras"),
      [this, found](ControllerRunner::Outcome outcome, const QString& message) {
        if (outcome != ControllerRunner::Outcome::kSucceeded) {
          SetStatus(tr("Camera autodetect failed: %1").arg(message), true);
          return;
        }
        if (found->empty()) {
          SetStatus(tr("No camera found over USB: check the cable, that the camera is on, and that no other "
                       "program (gvfs, a file manager) holds it."),
                    true);
          return;
        }
        QStringList names;
        for (const DetectedCamera& camera : *found) {
          names << QStringLiteral("%1 on %2").arg(QString::fromStdString(camera.model),
                                                  QString::fromStdString(camera.port));
        }
        camera_choice_->setCurrentIndex(camera_choice_->findData(QStringLiteral("gphoto2")));
        camera_model_->setText(QString::fromStdString(found->front().model));
        camera_port_->setText(QString::fromStdString(found->front().port));
        SetStatus(tr("Cameras found: %1. The first is chosen; Connect to use it.").arg(names.join(", ")));
      });
  if (!started) SetStatus(tr("%1 is running; detect when it has finished").arg(runner_->job_name()), true);
}

BenchOptions DevicesPage::OptionsFromWidgets() const {
  BenchOptions options;
  options.simulated_lights = lights_choice_->currentData().toString() == kSimulated;
  if (!options.simulated_lights) options.serial_port = lights_choice_->currentData().toString().toStdString();
  options.simulated_camera = camera_choice_->currentData().toString() == kSimulated;
  options.camera_model = camera_model_->text().toStdString();
  options.camera_port = camera_port_->text().toStdString();
  options.rig_file = rig_file_->text().toStdString();
  options.sim_width = sim_width_->value();
  options.sim_height = sim_height_->value();
  return options;
}

void DevicesPage::SetStatus(const QString& text, bool error) {
  ShowStatusText(status_, text, error);
}

void DevicesPage::ClearLiveView(const QString& why) {
  live_image_->clear();
  live_image_->setText(why);
  live_info_->clear();
}

void DevicesPage::ShowBoardInfo() {
  BenchLights* board = lights();
  if (!board) {
    lights_info_->setText(tr("LED board: not connected"));
    return;
  }
  const LightFirmwareInfo& firmware = board->firmware();
  lights_info_->setText(tr("LED board: %1 — firmware %2 %3, %4 LEDs")
                            .arg(QString::fromStdString(board->lights().description()),
                                 QString::fromStdString(firmware.name), QString::fromStdString(firmware.version))
                            .arg(firmware.led_count));
}

void DevicesPage::Connect() {
  if (runner_->busy()) {
    SetStatus(tr("%1 is running; connect when it has finished").arg(runner_->job_name()), true);
    return;
  }
  const BenchOptions options = OptionsFromWidgets();
  // What the fields say is checked before any device is let go: a missing
  // or unreadable rig file changes nothing that is connected.
  try {
    CheckBenchOptions(options);
  } catch (const std::exception& error) {
    SetStatus(tr("Not connected: %1. What was connected stays connected.").arg(error.what()), true);
    return;
  }
  // The old devices go first: a real board's port can be opened only once.
  // The same board stays open: only the camera is connected again.
  std::shared_ptr<BenchLights> keep = lights() && lights()->Serves(options) ? (bench_ ? bench_->lights_part()
                                                                                      : lights_only_)
                                                                           : nullptr;
  live_view_->setChecked(false);
  live_watcher_->waitForFinished();
  bench_.reset();
  lights_only_.reset();
  ClearLiveView(tr("No camera connected."));
  camera_info_->setText(tr("Camera: not connected"));
  if (!keep) lit_led_.reset();
  emit BenchChanged();
  RebuildLedButtons();
  struct Made {
    std::shared_ptr<BenchLights> lights;
    std::unique_ptr<Bench> bench;
    bool camera_failed = false;  // the board connected (or was kept), the camera did not
  };
  auto made = std::make_shared<Made>();
  made->lights = keep;
  connect_button_->setEnabled(false);
  SetStatus(keep ? tr("Connecting the camera (the LED board stays connected)…") : tr("Connecting…"));
  led_message_shown_ = false;
  runner_->Start(std::make_shared<FunctionController>([made, options] {
                   if (!made->lights) made->lights = std::make_shared<BenchLights>(options);
                   made->camera_failed = true;
                   made->bench = std::make_unique<Bench>(options, made->lights);
                   made->camera_failed = false;
                 }),
                 tr("Connect"), [this, made](ControllerRunner::Outcome outcome, const QString& message) {
                   connect_button_->setEnabled(true);
                   connect_button_->setText(tr("Reconnect"));
                   if (outcome != ControllerRunner::Outcome::kSucceeded) {
                     camera_info_->setText(tr("Camera: not connected"));
                     if (made->camera_failed) {
                       lights_only_ = made->lights;
                       SetStatus(tr("Camera connect failed: %1. The LED board stays connected; check that the "
                                    "camera is on, in PTP mode and not held by another program, then Reconnect.")
                                     .arg(message),
                                 true);
                     } else {
                       SetStatus(tr("LED board connect failed: %1. Check the cable and the port, then Reconnect.")
                                     .arg(message),
                                 true);
                     }
                     ShowBoardInfo();
                     RebuildLedButtons();
                     return;
                   }
                   bench_ = std::move(made->bench);
                   ShowBoardInfo();
                   const CameraDeviceInfo& camera = bench_->camera_info();
                   camera_info_->setText(tr("Camera: %1 (%2 %3, serial %4)")
                                             .arg(QString::fromStdString(bench_->camera().description()),
                                                  QString::fromStdString(camera.make),
                                                  QString::fromStdString(camera.model),
                                                  QString::fromStdString(camera.serial)));
                   SetStatus(tr("Connected."));
                   ClearLiveView(tr("Live view off."));
                   RebuildLedButtons();
                   emit BenchChanged();
                 });
}

void DevicesPage::RebuildLedButtons() {
  while (QLayoutItem* item = led_grid_->takeAt(0)) {
    delete item->widget();
    delete item;
  }
  BenchLights* board = lights();
  led_box_->setEnabled(board != nullptr);
  if (!board) return;
  const int count = board->lights().led_count();
  for (int k = 0; k < count; ++k) {
    auto* button = new QPushButton(tr("LED %1").arg(k), led_box_);
    button->setObjectName(QStringLiteral("led%1").arg(k));
    button->setCheckable(true);  // checked: the LED the board reports lit
    connect(button, &QPushButton::clicked, this, [this, k] {
      ShowLitLed();  // a click toggles the button; the board's answer decides it
      RunDeviceJob(tr("LED %1 on").arg(k), [board = lights(), k] { board->lights().LightOnly(k); }, k);
    });
    led_grid_->addWidget(button, k / 5, k % 5);
  }
  auto* off = new QPushButton(tr("All off"), led_box_);
  off->setObjectName("allOff");
  connect(off, &QPushButton::clicked, this, [this] {
    RunDeviceJob(tr("All LEDs off"), [board = lights()] { board->lights().AllOff(); }, std::nullopt);
  });
  led_grid_->addWidget(off, (count + 4) / 5, 0, 1, 2);
  ShowLitLed();
}

void DevicesPage::ShowLitLed() {
  BenchLights* board = lights();
  if (!board) return;
  for (int k = 0; k < board->lights().led_count(); ++k) {
    if (auto* button = led_box_->findChild<QPushButton*>(QStringLiteral("led%1").arg(k))) {
      button->setChecked(lit_led_ == k);
    }
  }
}

void DevicesPage::RunDeviceJob(const QString& name, std::function<void()> work, std::optional<int> lit_after) {
  if (!lights()) return;
  if (!runner_->Start(std::make_shared<FunctionController>(std::move(work)), name,
                      [this, name, lit_after](ControllerRunner::Outcome outcome, const QString& message) {
                        if (outcome == ControllerRunner::Outcome::kSucceeded) {
                          lit_after_job_ = true;
                          lit_led_ = lit_after;
                          SetStatus(lit_after ? tr("LED %1 lit, the others off.").arg(*lit_after)
                                              : tr("All LEDs off."));
                          led_message_shown_ = true;
                        } else {
                          SetStatus(tr("%1 failed: %2. Reconnect the board if it persists.").arg(name, message), true);
                        }
                        ShowLitLed();
                      })) {
    SetStatus(tr("%1 is running; try again when it has finished").arg(runner_->job_name()), true);
  }
}

void DevicesPage::RefreshLedState(const QString& after_job) {
  if (lit_after_job_) {  // this page's own LED job: its answer is in
    lit_after_job_ = false;
    return;
  }
  BenchLights* board = lights();
  if (!board || runner_->busy()) return;
  // The board is free: no job runs, and a live-view fetch (which may ask it
  // which LED is lit) holds the device lock.
  const std::unique_lock lock(*runner_->device_mutex(), std::try_to_lock);
  if (!lock.owns_lock()) return;
  const std::optional<int> before = lit_led_;
  try {
    lit_led_ = board->lights().Status().lit_led;
  } catch (const std::exception& error) {
    if (led_message_shown_) SetStatus(tr("LED state unknown after %1: %2").arg(after_job, error.what()), true);
    return;
  }
  ShowLitLed();
  // An LED job's "LED 3 lit" no longer holds after a capture turned them off.
  if (led_message_shown_ && lit_led_ != before) {
    SetStatus(lit_led_ ? tr("LED %1 lit (after %2).").arg(*lit_led_).arg(after_job)
                       : tr("All LEDs off (%1 turned them off).").arg(after_job));
  }
}

void DevicesPage::WaitForLiveFetch() { live_watcher_->waitForFinished(); }

LiveFrame DevicesPage::FetchLiveFrame(Bench& bench) {
  if (bench.has_raw_preview()) return LiveFrameFromRaw(bench.PreviewRaw(), RawDevelopOptions{}.clip_fraction);
  const PreviewFrame preview = bench.camera().CapturePreview();
  LiveFrame frame = LiveFrameFromPreview(preview.bytes);
  if (frame.image.isNull()) {
    frame.error = QStringLiteral("the camera's preview (%1) could not be decoded")
                      .arg(QString::fromStdString(preview.mime_type));
  }
  return frame;
}

void DevicesPage::UpdateLiveView() {
  // One fetch at a time, and none while a job owns the camera (a capture).
  if (!bench_ || runner_->busy() || !isVisible() || live_watcher_->isRunning()) return;
  LiveSource source = live_source_;
  if (!source) source = [bench = bench_.get()] { return FetchLiveFrame(*bench); };
  live_watcher_->setFuture(QtConcurrent::run([source, devices = runner_->device_mutex()]() -> LiveFrame {
    // A job started since the check above: it has the camera, skip this turn.
    const std::unique_lock lock(*devices, std::try_to_lock);
    if (!lock.owns_lock()) return {};
    try {
      return source();
    } catch (const std::exception& error) {
      LiveFrame failed;
      failed.error = QString::fromStdString(error.what());
      return failed;
    }
  }));
}

void DevicesPage::ShowLiveFrame() {
  const LiveFrame frame = live_watcher_->result();
  if (!live_view_->isChecked()) return;
  if (!frame.error.isEmpty()) {
    live_view_->setChecked(false);
    ClearLiveView(tr("Live view stopped: %1").arg(frame.error));
    SetStatus(tr("Live view stopped: %1").arg(frame.error), true);
    return;
  }
  if (frame.image.isNull()) return;  // skipped: a job had the camera
  live_image_->setPixmap(QPixmap::fromImage(
      frame.image.scaled(live_image_->size(), Qt::KeepAspectRatio, Qt::SmoothTransformation)));
  live_info_->setText(
      frame.from_raw
          ? tr("Red: a RAW sample at the clip level (%1 % of the pixels). Histogram: brightest RAW sample per "
               "pixel, 0 to the white level.")
                .arg(frame.clipped_fraction * 100, 0, 'f', 2)
          : tr("Red: a channel at the top of the camera's 8-bit preview (%1 % of the pixels); the RAW frame's "
               "clip level is not known from a preview. Histogram: preview luminance.")
                .arg(frame.clipped_fraction * 100, 0, 'f', 2));
}

void DevicesPage::LoadSettings() {
  QSettings settings;
  settings.beginGroup("devices");
  const int lights = lights_choice_->findData(settings.value("lights", kSimulated));
  if (lights >= 0) lights_choice_->setCurrentIndex(lights);
  const int camera = camera_choice_->findData(settings.value("camera", kSimulated));
  if (camera >= 0) camera_choice_->setCurrentIndex(camera);
  camera_model_->setText(settings.value("camera_model").toString());
  camera_port_->setText(settings.value("camera_port").toString());
  rig_file_->setText(settings.value("rig_file").toString());
  sim_width_->setValue(settings.value("sim_width", 1232).toInt());
  sim_height_->setValue(settings.value("sim_height", 816).toInt());
}

void DevicesPage::SaveSettings() const {
  QSettings settings;
  settings.beginGroup("devices");
  settings.setValue("lights", lights_choice_->currentData());
  settings.setValue("camera", camera_choice_->currentData());
  settings.setValue("camera_model", camera_model_->text());
  settings.setValue("camera_port", camera_port_->text());
  settings.setValue("rig_file", rig_file_->text());
  settings.setValue("sim_width", sim_width_->value());
  settings.setValue("sim_height", sim_height_->value());
}

}  // namespace scanbench
