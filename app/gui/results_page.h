// Results: one result folder's maps (albedo, normal, status, confidence,
// angular error when the session had ground truth) in a zoom-and-pan view,
// the solver's summary beside them, and a relight preview driven by a light
// the operator drags over a pad.
#pragma once

#include <QWidget>

#include <filesystem>
#include <optional>

#include "app/gui/result_images.h"

class QComboBox;
class QLabel;
class QLineEdit;
class QPlainTextEdit;

namespace scanbench {

class ImageView;
class LightPad;

class ResultsPage : public QWidget {
  Q_OBJECT

 public:
  explicit ResultsPage(QWidget* parent = nullptr);

  // Shows `result_dir`; false (and the reason on the page) if it holds no maps.
  bool OpenResult(const QString& result_dir);
  // Selects a layer by its ResultLayerName; false if absent.
  bool ShowLayer(ResultLayer layer);
  const std::filesystem::path& result_dir() const { return result_dir_; }
  ImageView* view() const { return view_; }
  LightPad* light_pad() const { return pad_; }

 private:
  void ShowSelectedLayer();
  void UpdateRelight(double x, double y, double z);

  std::filesystem::path result_dir_;
  QLineEdit* folder_;
  QComboBox* layer_;
  ImageView* view_;
  LightPad* pad_;
  QLabel* pad_label_;
  QPlainTextEdit* summary_;
  QLabel* status_;
  std::optional<RelightMaps> relight_;
};

}  // namespace scanbench
