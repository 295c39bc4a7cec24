// Internal to the solver library: the learned network's normals for the
// pixels of a span (solver/normal_network.h), and the fit around them. Used
// by the `learned` method's kernel and by the default's flagged pixels.
//
// Per pixel: every light whose sample is valid becomes a token, its
// direction turned into the pixel's view frame (view = +z, as the network was
// trained), its value the intensity-divided luminance, 0 for a sample at or
// below the shadow level (a shadow is information, not a missing sample);
// clipped and invalid samples are left out. The normal is turned back; the
// albedo is then fitted per channel on the samples that agree with the normal
// (shading ratio within kAlbedoBand of their median: highlights and shadows
// out).
#pragma once

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "solver/kernel_settings.h"
#include "solver/normal_network.h"

namespace scanbench::tiled {

class LearnedSpanNormals {
 public:
  LearnedSpanNormals(const KernelSettings& settings, int capacity);

  // Predicts the normal of every pixel i of the span with select[i] != 0 (null:
  // every wanted pixel) that has at least `min_tokens` (>= 3) tokens.
  void Predict(const Span& span, const uint8_t* select, int min_tokens = 3);
  // Whether pixel i got a prediction in the last Predict.
  bool Predicted(int i) const { return index_[i] >= 0; }
  Eigen::Vector3d NormalInTable(int i) const;
  float ExpectedErrorDeg(int i) const { return outputs_[index_[i]].ExpectedErrorDeg(); }

  // The fit of pixel i (Predicted) with the predicted normal: albedo and
  // confidence from its used samples (GatherSamples), status kSolved unless
  // fewer than min_lights samples agree or the albedo is below min_albedo.
  // With `refine`, the normal is then re-solved by least squares on the
  // samples that agree with it (twice), where that stays near the prediction.
  PixelFit FinishFit(const PixelSamples& samples, int i, bool refine) const;

 private:
  const KernelSettings& settings_;
  const NormalNetwork& network_;
  NormalNetworkInput input_;
  std::vector<NormalNetworkOutput> outputs_;
  NormalNetwork::Workspace workspace_;
  std::vector<int> index_;                 // per span pixel: its place in outputs_, or -1
  std::vector<float> kept_dir_, kept_value_;  // one pixel's tokens before the stride
  std::vector<Eigen::Quaterniond> to_view_;  // per span pixel: table frame -> view frame
};

}  // namespace scanbench::tiled
