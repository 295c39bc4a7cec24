#include "app/gui/capture_page.h"

#include <QApplication>
#include <QCheckBox>
#include <QComboBox>
#include <QDir>
#include <QFileDialog>
#include <QFormLayout>
#include <QGridLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QLabel>
#include <QLineEdit>
#include <QPlainTextEdit>
#include <QPointer>
#include <QProgressBar>
#include <QPushButton>
#include <QScrollArea>
#include <QSettings>
#include <QStringList>
#include <QThreadPool>
#include <QTimer>
#include <QVBoxLayout>

#include <algorithm>
#include <fstream>
#include <sstream>

#include "app/controllers/capture_controller.h"
#include "app/controllers/live_solve.h"
#include "app/controllers/progress_plans.h"
#include "app/controllers/solve_controller.h"
#include "app/gui/bench.h"
#include "app/gui/controller_runner.h"
#include "app/gui/devices_page.h"
#include "app/gui/page_widgets.h"
#include "app/gui/result_images.h"
#include "app/session/capture_folder.h"
#include "app/session/session.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {
constexpr int kThumbnailWidth = 200;
constexpr int kThumbnailColumns = 4;

// The manifest as last journalled; nullopt while it is absent or being replaced.
std::optional<Session> ReadManifest(const fs::path& session_dir) {
  std::ifstream file(session_dir / "session.json");
  if (!file) return std::nullopt;
  std::stringstream text;
  text << file.rdbuf();
  try {
    return SessionFromJson(text.str(), (session_dir / "session.json").string());
  } catch (const std::exception&) {
    return std::nullopt;
  }
}
}  // namespace

CapturePage::CapturePage(ControllerRunner* runner, DevicesPage* devices, QWidget* parent)
    : QWidget(parent), runner_(runner), devices_(devices) {
  auto* session_box = new QGroupBox(tr("Session"), this);
  auto* form = new QFormLayout(session_box);
  folder_ = new QLineEdit(session_box);
  folder_->setObjectName("sessionFolder");
  folder_->setPlaceholderText(tr("a new, empty folder (or an interrupted session to resume)"));
  auto* browse = new QPushButton(tr("Browse…"), session_box);
  form->addRow(tr("Folder"), FieldWithButton(folder_, browse));
  sample_name_ = new QLineEdit(session_box);
  sample_name_->setObjectName("sampleName");
  form->addRow(tr("Sample name"), sample_name_);
  notes_ = new QPlainTextEdit(session_box);
  notes_->setObjectName("notes");
  notes_->setMaximumHeight(60);
  form->addRow(tr("Notes"), notes_);
  check_exposure_ = new QCheckBox(tr("Check the exposure first (one test frame per LED)"), session_box);
  check_exposure_->setObjectName("checkExposure");
  check_exposure_->setChecked(true);
  form->addRow(QString(), check_exposure_);
  solve_while_capturing_ = new QCheckBox(tr("Solve while capturing (the result follows the last frame)"), session_box);
  solve_while_capturing_->setObjectName("solveWhileCapturing");
  solve_while_capturing_->setChecked(true);
  form->addRow(QString(), solve_while_capturing_);

  // The exposure: the connected camera's values (Bench::exposure_choices).
  auto* exposure_box = new QGroupBox(tr("Exposure"), this);
  auto* exposure_form = new QFormLayout(exposure_box);
  const char* names[] = {"isoChoice", "shutterChoice", "apertureChoice"};
  const QString labels[] = {tr("ISO"), tr("Shutter speed"), tr("Aperture")};
  for (int i = 0; i < 3; ++i) {
    exposure_[i] = new QComboBox(exposure_box);
    exposure_[i]->setObjectName(names[i]);
    exposure_[i]->setSizeAdjustPolicy(QComboBox::AdjustToContents);
    exposure_form->addRow(labels[i], exposure_[i]);
    connect(exposure_[i], &QComboBox::currentIndexChanged, this, [this, i] {
      if (!filling_exposure_) chosen_[i] = exposure_[i]->currentData().toString();
    });
  }
  exposure_note_ = new QLabel(exposure_box);
  exposure_note_->setObjectName("exposureNote");
  exposure_note_->setWordWrap(true);
  exposure_note_->setStyleSheet(QStringLiteral("color: #9a7d0a"));
  exposure_form->addRow(exposure_note_);

  start_ = NamedButton(tr("Start capture"), "startCapture", this);
  resume_ = NamedButton(tr("Resume"), "resumeCapture", this);
  cancel_ = NamedButton(tr("Cancel"), "cancelCapture", this);
  solve_ = NamedButton(tr("Solve"), "solveCaptured", this);
  auto* buttons = new QHBoxLayout;
  for (QPushButton* button : {start_, resume_, cancel_, solve_}) buttons->addWidget(button);
  buttons->addStretch();

  progress_ = new QProgressBar(this);
  progress_->setObjectName("captureProgress");
  progress_->setRange(0, 1000);
  progress_->setTextVisible(false);
  stage_ = new QLabel(this);
  stage_->setObjectName("captureStage");
  blocked_ = new QLabel(this);
  blocked_->setObjectName("captureBlocked");
  blocked_->setWordWrap(true);
  blocked_->setStyleSheet(QStringLiteral("color: #9a7d0a"));
  status_ = new QLabel(this);
  status_->setObjectName("captureStatus");
  status_->setWordWrap(true);
  status_->setTextInteractionFlags(Qt::TextSelectableByMouse);

  auto* thumbs_widget = new QWidget(this);
  thumbnails_ = new QGridLayout(thumbs_widget);
  auto* scroll = new QScrollArea(this);
  scroll->setWidget(thumbs_widget);
  scroll->setWidgetResizable(true);

  auto* layout = new QVBoxLayout(this);
  auto* boxes = new QHBoxLayout;
  boxes->addWidget(session_box, 3);
  boxes->addWidget(exposure_box, 1);
  layout->addLayout(boxes);
  layout->addLayout(buttons);
  layout->addWidget(blocked_);
  layout->addWidget(progress_);
  layout->addWidget(stage_);
  layout->addWidget(status_);
  layout->addWidget(scroll, 1);

  poll_ = new QTimer(this);
  poll_->setInterval(200);
  connect(poll_, &QTimer::timeout, this, &CapturePage::PollFrames);
  connect(browse, &QPushButton::clicked, this, [this] {
    const QString dir = QFileDialog::getExistingDirectory(this, tr("Session folder"), folder_->text());
    if (!dir.isEmpty()) SetSessionFolder(dir);
  });
  connect(start_, &QPushButton::clicked, this, &CapturePage::StartNew);
  connect(resume_, &QPushButton::clicked, this, &CapturePage::Resume);
  connect(cancel_, &QPushButton::clicked, runner_, &ControllerRunner::Cancel);
  connect(solve_, &QPushButton::clicked, this, &CapturePage::Solve);
  connect(folder_, &QLineEdit::textChanged, this, &CapturePage::FolderChanged);
  connect(devices_, &DevicesPage::BenchChanged, this, &CapturePage::ShowExposureChoices);
  connect(devices_, &DevicesPage::BenchChanged, this, &CapturePage::UpdateButtons);
  // One bar for the whole job: with solve-while-capturing the capture's
  // stages and then the solve's, never moving back.
  connect(runner_, &ControllerRunner::JobProgressChanged, this, [this](double fraction, const QString& text) {
    if (!capturing_ && !solving_) return;
    progress_->setValue(int(fraction * 1000));
    stage_->setText(text);
  });
  connect(runner_, &ControllerRunner::Started, this, &CapturePage::UpdateButtons);
  connect(runner_, &ControllerRunner::Finished, this, &CapturePage::UpdateButtons);
  ShowExposureChoices();
  UpdateButtons();
}

fs::path CapturePage::SessionDir() const { return fs::path(folder_->text().trimmed().toStdString()); }

void CapturePage::SetSessionFolder(const QString& folder) {
  if (folder_->text() == folder) {
    FolderChanged();  // the same folder again: shown afresh
  } else {
    folder_->setText(folder);  // FolderChanged
  }
}

void CapturePage::FolderChanged() {
  if (capturing_ || solving_) return;  // the field is read-only meanwhile
  ResetThumbnails();
  SetStatus(QString());
  stage_->clear();
  progress_->setValue(0);
  PollFrames();  // show what an interrupted session already has
  UpdateButtons();
}

void CapturePage::ShowJobEnd(const QString& job, int outcome) {
  const QString seconds = QString::number(runner_->job_seconds(), 'f', 1);
  switch (ControllerRunner::Outcome(outcome)) {
    case ControllerRunner::Outcome::kSucceeded:
      progress_->setValue(progress_->maximum());
      stage_->setText(tr("%1 finished in %2 s").arg(job, seconds));
      break;
    case ControllerRunner::Outcome::kCancelled:
      stage_->setText(tr("%1 cancelled after %2 s").arg(job, seconds));
      break;
    case ControllerRunner::Outcome::kFailed:
      stage_->setText(tr("%1 failed after %2 s").arg(job, seconds));
      break;
  }
}

void CapturePage::SetStatus(const QString& text, bool error) {
  ShowStatusText(status_, text, error);
}

void CapturePage::ShowExposureChoices() {
  Bench* bench = devices_->bench();
  QStringList reasons;
  filling_exposure_ = true;
  for (size_t i = 0; i < exposure_.size(); ++i) {
    QComboBox* box = exposure_[i];
    box->clear();
    box->addItem(tr("leave the camera's"), QString());
    box->setToolTip(QString());
    if (!bench) continue;
    const ExposureChoices& choices = bench->exposure_choices()[i];
    for (const std::string& value : choices.values) {
      box->addItem(QString::fromStdString(value), QString::fromStdString(value));
    }
    box->setCurrentIndex(std::max(0, box->findData(chosen_[i])));
    if (!choices.unavailable.empty()) {
      const QString why = QString::fromStdString(choices.unavailable);
      box->setToolTip(why);
      reasons << why.left(1).toUpper() + why.mid(1) + QStringLiteral(".");
    }
  }
  filling_exposure_ = false;
  exposure_note_->setText(bench ? reasons.join(' ')
                                : tr("No camera connected: connect one on the Devices page to choose its ISO, "
                                     "shutter speed and aperture."));
  exposure_note_->setVisible(!exposure_note_->text().isEmpty());
}

bool CapturePage::ExposureFromWidgets(const Bench& bench, ExposureSettings* exposure) {
  for (size_t i = 0; i < exposure_.size(); ++i) {
    const ExposureChoices& choices = bench.exposure_choices()[i];
    try {
      SetExposureValue(exposure, choices.setting,
                       ExposureChoiceNumber(choices, exposure_[i]->currentData().toString().toStdString()));
    } catch (const std::exception& error) {
      SetStatus(tr("Exposure: %1").arg(error.what()), true);
      return false;
    }
  }
  return true;
}

void CapturePage::UpdateButtons() {
  const bool busy = runner_->busy();
  const bool has_bench = devices_->bench() != nullptr;
  const fs::path dir = SessionDir();
  const CaptureFolderState state = dir.empty() ? CaptureFolderState() : InspectCaptureFolder(dir);
  const std::string new_refusal = dir.empty() ? "" : CaptureFolderRefusal(dir, state, false);
  const bool interrupted = state.kind == CaptureFolderState::Kind::kInterrupted;
  start_->setEnabled(!busy && has_bench && !dir.empty() && new_refusal.empty());
  resume_->setEnabled(!busy && has_bench && !dir.empty() && interrupted);
  cancel_->setEnabled(busy && (capturing_ || solving_));
  solve_->setEnabled(!busy && state.kind == CaptureFolderState::Kind::kComplete);
  folder_->setReadOnly(capturing_ || solving_);
  for (QComboBox* box : exposure_) box->setEnabled(has_bench && !capturing_ && !solving_ && box->count() > 1);
  // Why Start capture (or Resume) is off: the operator should not guess.
  QString why;
  if (capturing_ || solving_) {
    why.clear();
  } else if (busy) {
    why = tr("%1 is running: start when it has finished.").arg(runner_->job_name());
  } else if (!has_bench) {
    why = tr("No bench connected: connect the LED board and the camera on the Devices page to capture.");
  } else if (dir.empty()) {
    why = tr("Type or choose a session folder: a new, empty one.");
  } else if (interrupted) {
    why = tr("%1 Resume completes it.").arg(QString::fromStdString(new_refusal));
  } else if (!new_refusal.empty()) {
    why = QString::fromStdString(new_refusal) + QStringLiteral(".");
  }
  blocked_->setText(why);
  blocked_->setVisible(!why.isEmpty());
}

void CapturePage::ResetThumbnails() {
  while (QLayoutItem* item = thumbnails_->takeAt(0)) {
    delete item->widget();
    delete item;
  }
  shown_frames_.clear();
}

void CapturePage::StartNew() { StartCapture(false); }
void CapturePage::Resume() { StartCapture(true); }

void CapturePage::StartCapture(bool resume) {
  Bench* bench = devices_->bench();
  if (!bench) {
    SetStatus(tr("No bench connected: connect the LED board and camera on the Devices page first."), true);
    return;
  }
  const fs::path dir = SessionDir();
  if (dir.empty()) {
    SetStatus(tr("Choose a session folder first."), true);
    return;
  }
  CaptureOptions options;
  options.sample_name = sample_name_->text().trimmed().toStdString();
  options.notes = notes_->toPlainText().toStdString();
  options.check_exposure = check_exposure_->isChecked() && !resume;
  options.resume = resume;
  if (!ExposureFromWidgets(*bench, &options.exposure)) return;
  if (!resume && options.sample_name.empty()) {
    SetStatus(tr("Enter the sample name: it is recorded in session.json."), true);
    return;
  }
  if (resume) {
    // The journal has the sample; the controller checks it is the same bench.
    const std::optional<Session> session = ReadManifest(dir);
    if (!session) {
      SetStatus(tr("%1 has no readable session.json to resume").arg(QString::fromStdString(dir.string())), true);
      return;
    }
    options.sample_name = session->sample_name;
    options.notes = session->notes;
  }
  if (!resume) ResetThumbnails();
  // The same capture either way; live, each frame is decoded as it is
  // journalled and the solve follows the last one.
  std::shared_ptr<BaseController> controller;
  std::function<void()> report_success;
  const int num_leds = static_cast<int>(bench->rig().leds.size());
  std::vector<ProgressStagePlan> plan;
  if (solve_while_capturing_->isChecked()) {
    plan = LiveSolveProgressPlan(options, num_leds);
    LiveSolveOptions live_options;
    live_options.capture = options;
    auto live = std::make_shared<LiveSolveController>(dir, bench->rig(), &bench->camera(), &bench->lights(),
                                                      live_options);
    report_success = [this, live] {
      ReportCaptured(live->summary().capture);
      const QString result = QString::fromStdString(live->summary().solve.result_dir.string());
      status_->setText(status_->text() + tr(" Solved into %1, %2 s after the last frame.")
                                             .arg(result)
                                             .arg(live->summary().seconds_after_last_frame, 0, 'f', 1));
      emit ResultReady(result);
    };
    controller = live;
  } else {
    plan = CaptureProgressPlan(options, num_leds);
    auto capture =
        std::make_shared<CaptureController>(dir, bench->rig(), &bench->camera(), &bench->lights(), options);
    report_success = [this, capture] {
      ReportCaptured(capture->summary());
      status_->setText(status_->text() + tr(" Solve it next."));
    };
    controller = capture;
  }
  capturing_ = true;
  progress_->setValue(0);
  SetStatus(resume ? tr("Resuming %1…").arg(folder_->text()) : tr("Capturing into %1…").arg(folder_->text()));
  const bool started = runner_->Start(
      controller, tr("Capture"), [this, report_success](ControllerRunner::Outcome outcome, const QString& message) {
        capturing_ = false;
        poll_->stop();
        PollFrames();
        ShowJobEnd(tr("Capture"), int(outcome));
        switch (outcome) {
          case ControllerRunner::Outcome::kSucceeded:
            report_success();
            break;
          case ControllerRunner::Outcome::kCancelled:
            SetStatus(tr("Capture cancelled; the frames taken are kept (no result was written). Resume completes "
                         "the session."),
                      true);
            break;
          case ControllerRunner::Outcome::kFailed:
            SetStatus(tr("Capture failed: %1. The frames taken are kept; fix the cause and Resume.").arg(message),
                      true);
            break;
        }
        UpdateButtons();
      },
      plan);
  if (!started) {
    capturing_ = false;
    SetStatus(tr("%1 is running; start when it has finished").arg(runner_->job_name()), true);
    return;
  }
  poll_->start();
}

void CapturePage::ReportCaptured(const CaptureSummary& summary) {
  SetStatus(tr("Captured %1 frames (%2 already there, %3 retried) in %4 s.")
                .arg(summary.frames_captured)
                .arg(summary.frames_resumed)
                .arg(summary.retries)
                .arg(summary.seconds, 0, 'f', 1));
  if (summary.exposure_check.empty()) return;
  // The check's worst figures: what to fix first if a frame is poor.
  double clipped = 0, signal = 1;
  for (const FrameExposure& exposure : summary.exposure_check) {
    clipped = std::max(clipped, exposure.clipped_fraction);
    signal = std::min(signal, exposure.signal_p99);
  }
  status_->setText(status_->text() + tr(" Exposure check: at most %1 % clipped, weakest LED at %2 % of the range.")
                                         .arg(clipped * 100, 0, 'g', 2)
                                         .arg(signal * 100, 0, 'f', 1));
}

void CapturePage::PollFrames() {
  const fs::path dir = SessionDir();
  if (dir.empty()) return;
  const std::optional<Session> session = ReadManifest(dir);
  if (!session) return;
  for (const FrameRecord& frame : session->frames) {
    if (!shown_frames_.insert(frame.file).second) continue;
    const QString name = frame.kind == FrameKind::kDark ? tr("dark") : tr("LED %1").arg(frame.led_index);
    auto* cell = new QLabel;
    cell->setObjectName(QStringLiteral("thumbnail_%1").arg(frame.kind == FrameKind::kDark ? -1 : frame.led_index));
    cell->setAlignment(Qt::AlignCenter);
    cell->setToolTip(QString::fromStdString(frame.file));
    cell->setText(tr("decoding…"));
    // Decoding a full-size RAW takes long enough to stutter the window: it
    // runs on the thread pool, the picture is set back on the UI thread.
    QPointer<QLabel> target(cell);
    const fs::path file = dir / frame.file;
    const QString name_in_session = QString::fromStdString(frame.file);
    QThreadPool::globalInstance()->start([target, file, name_in_session] {
      QImage image;
      QString problem;
      try {
        image = RawThumbnail(file, kThumbnailWidth);
      } catch (const std::exception& error) {
        problem = QString::fromUtf8(error.what());
      }
      QMetaObject::invokeMethod(
          qApp,
          [target, image, problem, name_in_session] {
            if (!target) return;  // the thumbnails were cleared meanwhile
            if (image.isNull()) {
              target->setText(QObject::tr("%1 unreadable: %2").arg(name_in_session, problem));
              target->setWordWrap(true);
            } else {
              target->setPixmap(QPixmap::fromImage(image));
            }
          },
          Qt::QueuedConnection);
    });
    auto* caption = new QLabel(name);
    caption->setAlignment(Qt::AlignCenter);
    // Dark first, then the LEDs in order, whatever order they arrive in.
    const int slot = frame.kind == FrameKind::kDark ? 0 : frame.led_index + 1;
    thumbnails_->addWidget(cell, (slot / kThumbnailColumns) * 2, slot % kThumbnailColumns);
    thumbnails_->addWidget(caption, (slot / kThumbnailColumns) * 2 + 1, slot % kThumbnailColumns);
  }
}

void CapturePage::Solve() {
  const fs::path dir = SessionDir();
  SolveOptions options;
  auto controller = std::make_shared<SolveController>(dir, options);
  solving_ = true;
  progress_->setValue(0);
  SetStatus(tr("Solving %1…").arg(folder_->text()));
  const bool started = runner_->Start(
      controller, tr("Solve"), [this, controller](ControllerRunner::Outcome outcome, const QString& message) {
        solving_ = false;
        ShowJobEnd(tr("Solve"), int(outcome));
        if (outcome == ControllerRunner::Outcome::kSucceeded) {
          const QString result = QString::fromStdString(controller->summary().result_dir.string());
          SetStatus(tr("Solved into %1").arg(result));
          emit ResultReady(result);
        } else if (outcome == ControllerRunner::Outcome::kCancelled) {
          SetStatus(tr("Solve cancelled; no result folder was left."), true);
        } else {
          SetStatus(tr("Solve failed: %1").arg(message), true);
        }
        UpdateButtons();
      },
      SolveProgressPlan());
  if (!started) {
    solving_ = false;
    SetStatus(tr("%1 is running; solve when it has finished").arg(runner_->job_name()), true);
  }
}

void CapturePage::LoadSettings() {
  QSettings settings;
  const QString last_root = settings.value("capture/last_parent", QDir::homePath()).toString();
  folder_->setPlaceholderText(tr("a new, empty folder, e.g. %1/sample-01").arg(last_root));
  check_exposure_->setChecked(settings.value("capture/check_exposure", true).toBool());
  solve_while_capturing_->setChecked(settings.value("capture/solve_while_capturing", true).toBool());
}

void CapturePage::SaveSettings() const {
  QSettings settings;
  if (!folder_->text().isEmpty()) {
    settings.setValue("capture/last_parent", QString::fromStdString(SessionDir().parent_path().string()));
  }
  settings.setValue("capture/check_exposure", check_exposure_->isChecked());
  settings.setValue("capture/solve_while_capturing", solve_while_capturing_->isChecked());
}

}  // namespace scanbench
