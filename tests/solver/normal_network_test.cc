// The C++ forward pass of the learned solver's network against PyTorch's on
// the inputs scripts/train/train_normal_net.py wrote beside the weights
// (tests/solver/data/normal_net_vectors.txt), on every supported ISA.
#include "solver/normal_network.h"

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace scanbench {
namespace {

struct Vectors {
  NormalNetworkInput input;
  std::vector<NormalNetworkOutput> expected;
};

Vectors ReadVectors() {
  const std::string path = std::string(SCANBENCH_SOURCE_DIR) + "/tests/solver/data/normal_net_vectors.txt";
  std::ifstream in(path);
  EXPECT_TRUE(in) << path;
  Vectors v;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream words(line);
    std::string key;
    words >> key;
    if (key == "set") {
      int count = 0;
      words >> count;
      for (int k = 0; k < count; ++k) {
        std::getline(in, line);
        std::istringstream token(line);
        float light[3], value;
        token >> light[0] >> light[1] >> light[2] >> value;
        v.input.AddToken(light, value);
      }
      v.input.EndPixel();
    } else if (key == "out") {
      NormalNetworkOutput out;
      words >> out.normal_in_view.x() >> out.normal_in_view.y() >> out.normal_in_view.z() >> out.log_kappa;
      v.expected.push_back(out);
    }
  }
  return v;
}

TEST(NormalNetworkTest, EmbeddedModelMatchesPyTorchOnEveryIsa) {
  const NormalNetwork& net = NormalNetwork::Embedded();
  EXPECT_EQ(net.source(), "data/models/normal_net.bin");
  EXPECT_EQ(net.sha256().size(), 64u);
  const Vectors v = ReadVectors();
  ASSERT_GE(v.input.num_pixels(), 40);
  ASSERT_EQ(static_cast<size_t>(v.input.num_pixels()), v.expected.size());
  for (KernelIsa isa : SupportedKernelIsas()) {
    std::vector<NormalNetworkOutput> out;
    net.Predict(v.input, &out, isa);
    ASSERT_EQ(out.size(), v.expected.size());
    double worst_normal = 0, worst_kappa = 0;
    for (size_t p = 0; p < out.size(); ++p) {
      worst_normal = std::max<double>(worst_normal, (out[p].normal_in_view - v.expected[p].normal_in_view).cwiseAbs().maxCoeff());
      worst_kappa = std::max<double>(worst_kappa, std::abs(out[p].log_kappa - v.expected[p].log_kappa));
    }
    EXPECT_LT(worst_normal, 1e-5) << KernelIsaName(isa);
    EXPECT_LT(worst_kappa, 1e-5) << KernelIsaName(isa);
  }
}

TEST(NormalNetworkTest, IsasGiveTheSameBits) {
  const NormalNetwork& net = NormalNetwork::Embedded();
  const Vectors v = ReadVectors();
  std::vector<NormalNetworkOutput> baseline;
  net.Predict(v.input, &baseline, KernelIsa::kBaseline);
  for (KernelIsa isa : SupportedKernelIsas()) {
    std::vector<NormalNetworkOutput> out;
    net.Predict(v.input, &out, isa);
    for (size_t p = 0; p < out.size(); ++p) {
      EXPECT_EQ(out[p].normal_in_view, baseline[p].normal_in_view) << KernelIsaName(isa) << " pixel " << p;
      EXPECT_EQ(out[p].log_kappa, baseline[p].log_kappa) << KernelIsaName(isa) << " pixel " << p;
    }
  }
}

TEST(NormalNetworkTest, TokenOrderDoesNotMatter) {
  // A set, not a sequence: reversing the tokens changes nothing beyond rounding.
  const Vectors v = ReadVectors();
  NormalNetworkInput reversed;
  for (int p = 0; p < v.input.num_pixels(); ++p) {
    for (int t = v.input.begin[p + 1] - 1; t >= v.input.begin[p]; --t) {
      reversed.AddToken(&v.input.light_in_view[3 * t], v.input.value[t]);
    }
    reversed.EndPixel();
  }
  std::vector<NormalNetworkOutput> a, b;
  NormalNetwork::Embedded().Predict(v.input, &a);
  NormalNetwork::Embedded().Predict(reversed, &b);
  for (size_t p = 0; p < a.size(); ++p) {
    EXPECT_LT((a[p].normal_in_view - b[p].normal_in_view).norm(), 1e-5) << p;
  }
}

TEST(NormalNetworkTest, LambertianSetGivesItsNormal) {
  // Twelve lights on two rings, a noise-free Lambertian pixel: within a few degrees.
  const Eigen::Vector3f normal = Eigen::Vector3f(0.3f, -0.2f, 0.93f).normalized();
  NormalNetworkInput input;
  for (int k = 0; k < 12; ++k) {
    const float elevation = (k % 2 ? 60.0f : 35.0f) * 3.14159265f / 180, azimuth = k * 3.14159265f / 6;
    const float light[3] = {std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                            std::sin(elevation)};
    input.AddToken(light, 0.6f * std::max(0.0f, normal.dot(Eigen::Vector3f(light[0], light[1], light[2]))));
  }
  input.EndPixel();
  std::vector<NormalNetworkOutput> out;
  NormalNetwork::Embedded().Predict(input, &out);
  const double angle = std::acos(std::clamp<double>(out[0].normal_in_view.dot(normal), -1, 1)) * 180 / 3.14159265;
  EXPECT_LT(angle, 5.0);
}

TEST(NormalNetworkTest, RejectsTooFewTokensAndBadFiles) {
  NormalNetworkInput input;
  const float light[3] = {0, 0, 1};
  input.AddToken(light, 1.0f);
  input.AddToken(light, 1.0f);
  input.EndPixel();
  std::vector<NormalNetworkOutput> out;
  EXPECT_THROW(NormalNetwork::Embedded().Predict(input, &out), std::invalid_argument);
  const unsigned char junk[] = "not a network";
  try {
    NormalNetwork::Parse(junk, "junk.bin", "");
    FAIL() << "parsed junk";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("junk.bin"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace scanbench
