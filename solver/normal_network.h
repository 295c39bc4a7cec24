// The learned photometric solver's network (issue #33): per pixel, a SET of
// light tokens (the light's direction in the pixel's view frame, the sample
// divided by the light's intensity), any number from 3 to kMaxTokens, in any
// order, gives a unit normal and a concentration kappa (the network's own
// estimate of how far off it may be: a von Mises-Fisher distribution about
// the normal). Trained only on the project's renders
// (scripts/train/train_normal_net.py, app/sim/observation_sets.h); the forward
// pass here is the PyTorch one of scripts/train/normal_net.py, in float, on
// the dispatched kernels of solver/network_kernels.h.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "solver/cpu_dispatch.h"

namespace scanbench {

// A batch of pixels' light sets: pixel p owns tokens [begin[p], begin[p + 1]).
struct NormalNetworkInput {
  std::vector<int> begin{0};
  std::vector<float> light_in_view;  // 3 per token: unit direction to the light, the view along +z
  std::vector<float> value;          // 1 per token: the sample over the light's intensity, >= 0

  int num_pixels() const { return static_cast<int>(begin.size()) - 1; }
  void Clear();
  // Appends one token to the pixel being built; EndPixel closes it.
  void AddToken(const float light[3], float sample) {
    light_in_view.insert(light_in_view.end(), light, light + 3);
    value.push_back(sample);
  }
  void EndPixel() { begin.push_back(static_cast<int>(value.size())); }
};

struct NormalNetworkOutput {
  Eigen::Vector3f normal_in_view = Eigen::Vector3f::UnitZ();
  float log_kappa = 0;  // [-3, 12]
  // The mean angle between the normal and the truth that kappa implies
  // (sqrt(pi / (2 kappa)) for a concentrated von Mises-Fisher), in degrees.
  float ExpectedErrorDeg() const;
};

class NormalNetwork {
 public:
  static constexpr int kMaxTokens = 256;

  // Parses a network file (scripts/train/normal_net.py, save_network).
  // Throws std::invalid_argument naming `source` and what is wrong (magic,
  // an unknown kind, a tensor missing or of the wrong shape, too few bytes).
  static NormalNetwork Parse(std::span<const unsigned char> bytes, std::string source, std::string sha256);
  // The network compiled into the library: data/models/normal_net.bin.
  static const NormalNetwork& Embedded();

  const std::string& kind() const { return kind_; }      // "settransformer" or "deepset2"
  const std::string& source() const { return source_; }  // the file it came from
  const std::string& sha256() const { return sha256_; }  // of that file
  int num_parameters() const;

  // The activations of a forward pass, kept between calls so that a caller
  // with many small batches (a solve's spans) allocates them once.
  class Workspace {
   public:
    Workspace();
    ~Workspace();
    Workspace(Workspace&&) noexcept;
    Workspace& operator=(Workspace&&) noexcept;

   private:
    friend class NormalNetwork;
    struct Buffers;
    std::unique_ptr<Buffers> buffers_;
  };

  // One output per pixel of `input`; each pixel needs 3 to kMaxTokens tokens
  // (throws std::invalid_argument otherwise). `isa` picks the kernels.
  // Thread-safe: the network is read only; a workspace serves one call at a time.
  void Predict(const NormalNetworkInput& input, std::vector<NormalNetworkOutput>* outputs,
               KernelIsa isa = ActiveKernelIsa()) const;
  void Predict(const NormalNetworkInput& input, std::vector<NormalNetworkOutput>* outputs, KernelIsa isa,
               Workspace* workspace) const;

 private:
  struct Tensor {
    int rows = 0, cols = 0;
    std::vector<float> values;  // rows x cols, row-major
  };
  const Tensor& At(const std::string& name) const;
  int Config(const std::string& key) const;
  // The deepset2 context layer's weight split into its token and summary columns.
  void SplitContextWeight();

  std::string kind_, source_, sha256_;
  std::map<std::string, int> config_;
  std::map<std::string, Tensor> tensors_;
};

}  // namespace scanbench
