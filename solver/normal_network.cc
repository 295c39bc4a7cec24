#include "solver/normal_network.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "solver/network_kernels.h"

namespace scanbench {

namespace embedded {
extern const unsigned char kNormalNetBytes[];
extern const unsigned long kNormalNetSize;
extern const char kNormalNetSha256[];
extern const char kNormalNetSource[];
}  // namespace embedded

namespace {

constexpr char kMagic[] = "SCANBENCH-NORMAL-NET 1\n";
constexpr int kFeatures = 5;
// Tokens per block of the forward pass: the activations of a block (a few
// hundred floats per token) stay in the second-level cache.
constexpr int kBlockTokens = 512;

int RoundUp16(int n) { return (n + 15) / 16 * 16; }

[[noreturn]] void Fail(const std::string& source, const std::string& problem) {
  throw std::invalid_argument(source + ": " + problem);
}

// Feature-major scratch: `rows` rows of `stride` floats. Grows, never
// shrinks: a column past `columns` may hold an earlier block's values, which
// only ever reach columns that are not read (every kernel works per column).
struct Block {
  std::vector<float> data;
  int stride = 0;
  void Resize(int rows, int columns) {
    stride = RoundUp16(std::max(columns, 1));
    const size_t size = static_cast<size_t>(rows) * stride;
    if (data.size() < size) data.resize(size, 0.0f);
  }
  float* Row(int r) { return data.data() + static_cast<size_t>(r) * stride; }
};

}  // namespace

struct NormalNetwork::Workspace::Buffers {
  Block feats, h, x, wide, y, pooled, head1, head2, raw, summary_term;
  std::vector<float> scratch;  // attention scores: the largest pixel's tokens squared
  std::vector<int> begin;
};

NormalNetwork::Workspace::Workspace() : buffers_(std::make_unique<Buffers>()) {}
NormalNetwork::Workspace::~Workspace() = default;
NormalNetwork::Workspace::Workspace(Workspace&&) noexcept = default;
NormalNetwork::Workspace& NormalNetwork::Workspace::operator=(Workspace&&) noexcept = default;

void NormalNetworkInput::Clear() {
  begin.assign(1, 0);
  light_in_view.clear();
  value.clear();
}

float NormalNetworkOutput::ExpectedErrorDeg() const {
  const double kappa = std::exp(static_cast<double>(log_kappa));
  return static_cast<float>(std::sqrt(std::numbers::pi / (2.0 * kappa)) * 180.0 / std::numbers::pi);
}

NormalNetwork NormalNetwork::Parse(std::span<const unsigned char> bytes, std::string source, std::string sha256) {
  NormalNetwork net;
  net.source_ = std::move(source);
  net.sha256_ = std::move(sha256);
  const std::string_view text(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  if (!text.starts_with(kMagic)) Fail(net.source_, "is not a scanbench normal network (no 'SCANBENCH-NORMAL-NET 1' line)");
  size_t at = std::strlen(kMagic);
  std::vector<std::pair<std::string, Tensor>> order;
  while (true) {
    const size_t end = text.find('\n', at);
    if (end == std::string_view::npos) Fail(net.source_, "header ends before its 'data' line");
    std::istringstream line{std::string(text.substr(at, end - at))};
    at = end + 1;
    std::string key;
    line >> key;
    if (key == "data") break;
    if (key == "kind") {
      line >> net.kind_;
    } else if (key == "tensor") {
      std::string name;
      Tensor tensor;
      line >> name >> tensor.rows >> tensor.cols;
      if (!line || tensor.rows <= 0 || tensor.cols <= 0) Fail(net.source_, "bad tensor line for '" + name + "'");
      order.emplace_back(name, std::move(tensor));
    } else {
      int value = 0;
      line >> value;
      if (!line) Fail(net.source_, "header line '" + key + "' has no integer value");
      net.config_[key] = value;
    }
  }
  if (net.kind_ != "settransformer" && net.kind_ != "deepset2") {
    Fail(net.source_, "kind '" + net.kind_ + "' is neither settransformer nor deepset2");
  }
  for (auto& [name, tensor] : order) {
    const size_t count = static_cast<size_t>(tensor.rows) * tensor.cols;
    if (at + count * sizeof(float) > bytes.size()) Fail(net.source_, "is truncated in tensor '" + name + "'");
    tensor.values.resize(count);
    std::memcpy(tensor.values.data(), bytes.data() + at, count * sizeof(float));
    at += count * sizeof(float);
    net.tensors_[name] = std::move(tensor);
  }
  if (at != bytes.size()) Fail(net.source_, std::to_string(bytes.size() - at) + " bytes after the last tensor");
  // Every tensor the forward pass uses, with the shapes it assumes.
  auto require = [&](const std::string& name, int rows, int cols) {
    const Tensor& t = net.At(name);
    if (t.rows != rows || t.cols != cols) {
      Fail(net.source_, "tensor '" + name + "' is " + std::to_string(t.rows) + " x " + std::to_string(t.cols) +
                            ", expected " + std::to_string(rows) + " x " + std::to_string(cols));
    }
  };
  const int w = net.Config("width"), head = net.Config("head");
  if (net.kind_ == "settransformer") {
    const int heads = net.Config("heads"), blocks = net.Config("blocks"), ffn = net.Config("ffn");
    if (heads <= 0 || w % heads != 0) Fail(net.source_, "width " + std::to_string(w) + " is not a multiple of heads");
    require("embed.0.weight", w, kFeatures);
    require("embed.1.weight", w, w);
    for (int b = 0; b < blocks; ++b) {
      const std::string p = "block" + std::to_string(b) + ".";
      require(p + "ln1.weight", w, 1);
      require(p + "qkv.weight", 3 * w, w);
      require(p + "out.weight", w, w);
      require(p + "ln2.weight", w, 1);
      require(p + "ff1.weight", ffn, w);
      require(p + "ff2.weight", w, ffn);
    }
  } else {
    require("phi1.0.weight", w, kFeatures);
    require("phi1.1.weight", w, w);
    require("phi2.0.weight", w, 3 * w);
    require("phi2.1.weight", w, w);
    net.SplitContextWeight();
  }
  require("rho.0.weight", head, 2 * w);
  require("rho.1.weight", head / 2, head);
  require("rho.2.weight", 4, head / 2);
  return net;
}

const NormalNetwork& NormalNetwork::Embedded() {
  static const NormalNetwork net =
      Parse(std::span<const unsigned char>(embedded::kNormalNetBytes, embedded::kNormalNetSize),
            embedded::kNormalNetSource, embedded::kNormalNetSha256);
  return net;
}

const NormalNetwork::Tensor& NormalNetwork::At(const std::string& name) const {
  const auto found = tensors_.find(name);
  if (found == tensors_.end()) Fail(source_, "has no tensor '" + name + "'");
  return found->second;
}

int NormalNetwork::Config(const std::string& key) const {
  const auto found = config_.find(key);
  if (found == config_.end()) Fail(source_, "header lacks '" + key + "'");
  return found->second;
}

int NormalNetwork::num_parameters() const {
  int count = 0;
  for (const auto& [name, tensor] : tensors_) {
    if (!name.starts_with("split.")) count += tensor.rows * tensor.cols;
  }
  return count;
}

void NormalNetwork::SplitContextWeight() {
  const Tensor& full = At("phi2.0.weight");
  const int w = full.rows;
  Tensor token{w, w, {}}, summary{w, 2 * w, {}};
  for (int r = 0; r < w; ++r) {
    const float* row = full.values.data() + static_cast<size_t>(r) * 3 * w;
    token.values.insert(token.values.end(), row, row + w);
    summary.values.insert(summary.values.end(), row + w, row + 3 * w);
  }
  tensors_["split.phi2.token"] = std::move(token);
  tensors_["split.phi2.summary"] = std::move(summary);
  tensors_["split.zero_bias"] = Tensor{w, 1, std::vector<float>(w, 0.0f)};
}

void NormalNetwork::Predict(const NormalNetworkInput& input, std::vector<NormalNetworkOutput>* outputs,
                            KernelIsa isa) const {
  Workspace workspace;
  Predict(input, outputs, isa, &workspace);
}

void NormalNetwork::Predict(const NormalNetworkInput& input, std::vector<NormalNetworkOutput>* outputs,
                            KernelIsa isa, Workspace* workspace) const {
  const network::NetworkKernels& kernels = network::NetworkKernelsFor(isa);
  const int num_pixels = input.num_pixels();
  outputs->assign(num_pixels, NormalNetworkOutput());
  for (int p = 0; p < num_pixels; ++p) {
    const int k = input.begin[p + 1] - input.begin[p];
    if (k < 3 || k > kMaxTokens) {
      throw std::invalid_argument("NormalNetwork::Predict: pixel " + std::to_string(p) + " has " + std::to_string(k) +
                                  " tokens, must lie in [3, " + std::to_string(kMaxTokens) + "]");
    }
  }
  const bool transformer = kind_ == "settransformer";
  const int w = Config("width"), head = Config("head");
  const int ffn = transformer ? Config("ffn") : 0, heads = transformer ? Config("heads") : 0;
  const int blocks = transformer ? Config("blocks") : 0;
  Workspace::Buffers& buffers = *workspace->buffers_;
  Block &feats = buffers.feats, &h = buffers.h, &x = buffers.x, &wide = buffers.wide, &y = buffers.y;
  Block &pooled = buffers.pooled, &head1 = buffers.head1, &head2 = buffers.head2, &raw = buffers.raw;
  Block& summary_term = buffers.summary_term;
  std::vector<float>& scratch = buffers.scratch;
  std::vector<int>& begin = buffers.begin;
  int most_tokens = 0;
  for (int p = 0; p < num_pixels; ++p) most_tokens = std::max(most_tokens, input.begin[p + 1] - input.begin[p]);
  if (transformer && scratch.size() < static_cast<size_t>(most_tokens) * most_tokens) {
    scratch.resize(static_cast<size_t>(most_tokens) * most_tokens);
  }

  auto dense = [&](const std::string& name, int in, int out, const float* src, int src_stride, float* dst,
                   int dst_stride, int columns, bool relu, bool accumulate) {
    network::DenseArgs a;
    a.weight = At(name + ".weight").values.data();
    a.bias = At(name + ".bias").values.data();
    a.in = in;
    a.out = out;
    a.x = src;
    a.x_stride = src_stride;
    a.y = dst;
    a.y_stride = dst_stride;
    a.columns = columns;
    a.relu = relu;
    a.accumulate = accumulate;
    kernels.dense(a);
  };

  for (int first = 0; first < num_pixels;) {
    // A block of whole pixels.
    int last = first, tokens = 0;
    while (last < num_pixels && (last == first || tokens + input.begin[last + 1] - input.begin[last] <= kBlockTokens)) {
      tokens += input.begin[last + 1] - input.begin[last];
      ++last;
    }
    const int pixels = last - first;
    begin.assign(pixels + 1, 0);
    for (int p = 0; p < pixels; ++p) begin[p + 1] = begin[p] + input.begin[first + p + 1] - input.begin[first + p];
    const network::Segments segments{begin.data(), pixels};

    // Token features: direction, x = b / max b, sqrt(x) (normal_net.py, token_features).
    feats.Resize(kFeatures, tokens);
    for (int p = 0; p < pixels; ++p) {
      const int src = input.begin[first + p];
      float peak = 0.0f;
      for (int t = 0; t < begin[p + 1] - begin[p]; ++t) peak = std::max(peak, std::max(input.value[src + t], 0.0f));
      peak = std::max(peak, 1e-8f);
      for (int t = 0; t < begin[p + 1] - begin[p]; ++t) {
        const int col = begin[p] + t;
        for (int c = 0; c < 3; ++c) feats.Row(c)[col] = input.light_in_view[3 * (src + t) + c];
        const float ratio = std::max(input.value[src + t], 0.0f) / peak;
        feats.Row(3)[col] = ratio;
        feats.Row(4)[col] = std::sqrt(ratio);
      }
    }

    pooled.Resize(2 * w, pixels);
    if (transformer) {
      h.Resize(w, tokens);
      x.Resize(w, tokens);
      dense("embed.0", kFeatures, w, feats.Row(0), feats.stride, x.Row(0), x.stride, tokens, true, false);
      dense("embed.1", w, w, x.Row(0), x.stride, h.Row(0), h.stride, tokens, false, false);
      wide.Resize(std::max(3 * w, ffn), tokens);
      y.Resize(w, tokens);
      for (int b = 0; b < blocks; ++b) {
        const std::string p = "block" + std::to_string(b) + ".";
        network::LayerNormArgs ln{At(p + "ln1.weight").values.data(), At(p + "ln1.bias").values.data(), w,
                                  h.Row(0), x.Row(0), h.stride, tokens};
        kernels.layer_norm(ln);
        dense(p + "qkv", w, 3 * w, x.Row(0), x.stride, wide.Row(0), wide.stride, tokens, false, false);
        network::AttentionArgs att{wide.Row(0), y.Row(0), wide.stride, w, heads, segments, scratch.data()};
        kernels.attention(att);
        dense(p + "out", w, w, y.Row(0), y.stride, h.Row(0), h.stride, tokens, false, true);
        ln.gamma = At(p + "ln2.weight").values.data();
        ln.beta = At(p + "ln2.bias").values.data();
        kernels.layer_norm(ln);
        dense(p + "ff1", w, ffn, x.Row(0), x.stride, wide.Row(0), wide.stride, tokens, true, false);
        dense(p + "ff2", ffn, w, wide.Row(0), wide.stride, h.Row(0), h.stride, tokens, false, true);
      }
    } else {
      h.Resize(w, tokens);
      x.Resize(w, tokens);
      dense("phi1.0", kFeatures, w, feats.Row(0), feats.stride, x.Row(0), x.stride, tokens, true, false);
      dense("phi1.1", w, w, x.Row(0), x.stride, h.Row(0), h.stride, tokens, true, false);
      network::PoolArgs pool{h.Row(0), w, h.stride, segments, pooled.Row(0), pooled.stride};
      kernels.pool(pool);
      // phi2.0 on [h; g]: its token columns on h, its summary columns once per pixel.
      summary_term.Resize(w, pixels);
      network::DenseArgs s;
      s.weight = At("split.phi2.summary").values.data();
      s.bias = At("split.zero_bias").values.data();
      s.in = 2 * w;
      s.out = w;
      s.x = pooled.Row(0);
      s.x_stride = pooled.stride;
      s.y = summary_term.Row(0);
      s.y_stride = summary_term.stride;
      s.columns = pixels;
      kernels.dense(s);
      network::DenseArgs t = s;
      t.weight = At("split.phi2.token").values.data();
      t.bias = At("phi2.0.bias").values.data();
      t.in = w;
      t.x = h.Row(0);
      t.x_stride = h.stride;
      t.y = x.Row(0);
      t.y_stride = x.stride;
      t.columns = tokens;
      kernels.dense(t);
      network::BroadcastAddArgs add{x.Row(0), w, x.stride, summary_term.Row(0), summary_term.stride, segments, true};
      kernels.broadcast_add(add);
      dense("phi2.1", w, w, x.Row(0), x.stride, h.Row(0), h.stride, tokens, true, false);
    }
    network::PoolArgs pool{h.Row(0), w, h.stride, segments, pooled.Row(0), pooled.stride};
    kernels.pool(pool);
    head1.Resize(head, pixels);
    head2.Resize(head / 2, pixels);
    raw.Resize(4, pixels);
    dense("rho.0", 2 * w, head, pooled.Row(0), pooled.stride, head1.Row(0), head1.stride, pixels, true, false);
    dense("rho.1", head, head / 2, head1.Row(0), head1.stride, head2.Row(0), head2.stride, pixels, true, false);
    dense("rho.2", head / 2, 4, head2.Row(0), head2.stride, raw.Row(0), raw.stride, pixels, false, false);
    for (int p = 0; p < pixels; ++p) {
      Eigen::Vector3f n(raw.Row(0)[p], raw.Row(1)[p], raw.Row(2)[p]);
      const float norm = n.norm();
      NormalNetworkOutput& out = (*outputs)[first + p];
      out.normal_in_view = std::isfinite(norm) && norm > 1e-8f ? Eigen::Vector3f(n / norm) : Eigen::Vector3f::UnitZ();
      const float lk = raw.Row(3)[p];
      out.log_kappa = std::isfinite(lk) ? std::clamp(lk, -3.0f, 12.0f) : -3.0f;
    }
    first = last;
  }
}

}  // namespace scanbench
