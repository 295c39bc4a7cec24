// Shared by the GUI tests that drive the MainWindow through its widgets.
#pragma once

#include <QPushButton>
#include <QString>
#include <QTest>

#include "app/gui/controller_runner.h"
#include "app/gui/main_window.h"

namespace scanbench::testing {

// The widget named `name` under `window`; the test stops when there is none.
template <typename T>
T* FindWidget(QWidget& window, const char* name) {
  T* widget = window.findChild<T*>(QString::fromLatin1(name));
  if (!widget) qFatal("no widget %s", name);
  return widget;
}

// Clicks the button named `button` and waits for the job it starts; the job's outcome.
inline ControllerRunner::Outcome ClickAndWait(MainWindow& window, const char* button, int timeout_ms = 120000) {
  ControllerRunner::Outcome outcome = ControllerRunner::Outcome::kFailed;
  QObject receiver;  // the connection ends with it
  QObject::connect(window.runner(), &ControllerRunner::Finished, &receiver,
                   [&outcome](ControllerRunner::Outcome result, const QString&) { outcome = result; });
  QTest::mouseClick(FindWidget<QPushButton>(window, button), Qt::LeftButton);
  if (!window.runner()->Wait(timeout_ms)) qWarning("%s: job still running", button);
  return outcome;
}

}  // namespace scanbench::testing
