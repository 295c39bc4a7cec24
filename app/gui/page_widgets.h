// Small builders the pages share (header only: Qt widgets, no state).
#pragma once

#include <QHBoxLayout>
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

}  // namespace scanbench
