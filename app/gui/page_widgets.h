// Small builders the pages share (header only: Qt widgets, no state).
#pragma once

#include <QHBoxLayout>
#include <QLabel>
#include <QPushButton>
#include <QString>
#include <QWidget>

namespace scanbench {

// A push button with an object name: the GUI tests and the screenshot tour
// find widgets by it.
inline QPushButton* NamedButton(const QString& text, const char* object_name, QWidget* parent) {
  auto* button = new QPushButton(text, parent);
  button->setObjectName(object_name);
  return button;
}

// One form row: `field` takes the width, `button` sits beside it.
inline QHBoxLayout* FieldWithButton(QWidget* field, QWidget* button) {
  auto* row = new QHBoxLayout;
  row->addWidget(field, 1);
  row->addWidget(button);
  return row;
}

// A page's status line: `text`, in the error colour when `error`, and the
// line's "error" property saying so (the walkthrough test looks for it).
inline void ShowStatusText(QLabel* label, const QString& text, bool error) {
  label->setText(text);
  label->setStyleSheet(error ? QStringLiteral("color: #c0392b") : QString());
  label->setProperty("error", error && !text.isEmpty());
}

}  // namespace scanbench
