#include "app/sim/sensor_color.h"

#include <cmath>
#include <vector>

#include <Eigen/Dense>

#include "calibration/color_science.h"

namespace scanbench {
namespace {

// The old simulated camera's raw response to its LEDs relative to green (the
// inverse of a D5100's daylight white-balance multipliers), kept so that its
// frames stay bit-identical.
const Eigen::Vector3d kSrgbPrimariesRawWhite(0.48, 1.0, 0.70);

// Smooth reflectances a camera maker would fit a matrix on (never the
// ColorChecker, which the colour calibration is scored against): Mallett
// upsamplings of a 5^3 grid of linear Rec.709 colours, Gaussian bands and
// sigmoid edges across the visible range, all within [0.05, 0.9].
std::vector<Spectrum> MatrixTrainingReflectances() {
  std::vector<Spectrum> set;
  for (int r = 0; r < 5; ++r) {
    for (int g = 0; g < 5; ++g) {
      for (int b = 0; b < 5; ++b) {
        set.push_back(ReflectanceFromLinearRec709(Eigen::Vector3d(r, g, b) / 4.0));
      }
    }
  }
  auto spectrum_of = [](auto&& shape) {
    Spectrum s;
    for (int i = 0; i < kSpectrumSamples; ++i) s[i] = 0.05 + 0.85 * shape(SpectrumWavelengthNm(i));
    return s;
  };
  for (double centre = 400; centre <= 700; centre += 20) {
    for (const double width : {20.0, 40.0, 80.0}) {
      set.push_back(spectrum_of([&](double nm) { return std::exp(-0.5 * std::pow((nm - centre) / width, 2)); }));
    }
  }
  for (double edge = 420; edge <= 680; edge += 20) {
    for (const double sign : {-1.0, 1.0}) {
      set.push_back(spectrum_of([&](double nm) { return 1.0 / (1.0 + std::exp(sign * (nm - edge) / 15.0)); }));
    }
  }
  return set;
}

// camera_from_xyz under D65: least squares of native camera RGB on XYZ over
// the training set, constrained to map the perfect white exactly, then scaled
// so that white's camera neutral has a largest component of 1 (DNG 1.4).
Eigen::Matrix3d FitCameraFromXyzD65(const SpectralSensitivities& camera) {
  const Spectrum& d65 = CieD65Spd();
  const Eigen::Vector3d native_white = CameraWhiteRelativeToGreen(camera, d65);
  const std::vector<Spectrum> training = MatrixTrainingReflectances();
  Eigen::MatrixXd xyz(training.size(), 3), native(training.size(), 3);
  for (size_t i = 0; i < training.size(); ++i) {
    xyz.row(i) = XyzOfReflectance(training[i], d65).transpose();
    native.row(i) = WhiteBalancedCameraRgb(camera, d65, training[i]).cwiseProduct(native_white).transpose();
  }
  // Rows: native^T = xyz^T M^T. Unconstrained M^T = G A^T B with G = (A^T A)^-1;
  // the white constraint w^T M^T = r^T adds G w (r^T - w^T M0^T) / (w^T G w).
  const Eigen::Vector3d white_xyz = XyzOfReflectance(Spectrum::Ones(), d65);
  const Eigen::Matrix3d gram_inverse = (xyz.transpose() * xyz).inverse();
  const Eigen::Matrix3d unconstrained = gram_inverse * xyz.transpose() * native;
  const Eigen::Vector3d gw = gram_inverse * white_xyz;
  const Eigen::RowVector3d miss = native_white.transpose() - white_xyz.transpose() * unconstrained;
  const Eigen::Matrix3d m_transposed = unconstrained + gw * miss / white_xyz.dot(gw);
  const Eigen::Matrix3d camera_from_xyz = m_transposed.transpose();
  return camera_from_xyz / (camera_from_xyz * white_xyz).maxCoeff();
}

SensorColor MakeSensorColor(SensorColorModel model) {
  SensorColor color;
  color.model = model;
  if (model == SensorColorModel::kSrgbPrimaries) {
    color.raw_white_relative_to_green = kSrgbPrimariesRawWhite;
    color.camera_from_xyz_d65 = LinearRec709FromXyz();
  } else {
    const SpectralSensitivities& camera = NikonD5100Sensitivities();
    const Spectrum& led = CieLedB5Spd();
    const std::array<Spectrum, 3>& basis = Mallett2019Basis();
    for (int j = 0; j < 3; ++j) color.camera_from_linear_rec709.col(j) = WhiteBalancedCameraRgb(camera, led, basis[j]);
    color.raw_white_relative_to_green = CameraWhiteRelativeToGreen(camera, led);
    color.camera_from_xyz_d65 = FitCameraFromXyzD65(camera);
  }
  color.as_shot_neutral = color.raw_white_relative_to_green / color.raw_white_relative_to_green.maxCoeff();
  return color;
}

}  // namespace

const char* SensorColorModelName(SensorColorModel model) {
  switch (model) {
    case SensorColorModel::kNikonD5100: return "d5100";
    case SensorColorModel::kSrgbPrimaries: return "srgb-primaries";
  }
  return "?";
}

std::optional<SensorColorModel> SensorColorModelFromName(const std::string& name) {
  for (const auto model : {SensorColorModel::kNikonD5100, SensorColorModel::kSrgbPrimaries}) {
    if (name == SensorColorModelName(model)) return model;
  }
  return std::nullopt;
}

const SensorColor& SimulatedSensorColor(SensorColorModel model) {
  // Function-local statics: each built once, on first use, thread-safely.
  if (model == SensorColorModel::kSrgbPrimaries) {
    static const SensorColor srgb = MakeSensorColor(SensorColorModel::kSrgbPrimaries);
    return srgb;
  }
  static const SensorColor d5100 = MakeSensorColor(SensorColorModel::kNikonD5100);
  return d5100;
}

Eigen::Vector3d WhiteBalancedCameraRgbOf(SensorColorModel model, const Spectrum& reflectance) {
  if (model == SensorColorModel::kSrgbPrimaries) return LinearRec709OfReflectance(reflectance);
  return WhiteBalancedCameraRgb(NikonD5100Sensitivities(), CieLedB5Spd(), reflectance);
}

Eigen::Matrix3d SimulatedCameraFromXyzD65(SensorColorModel model) {
  return SimulatedSensorColor(model).camera_from_xyz_d65;
}

Eigen::Vector3d SimulatedAsShotNeutral(SensorColorModel model) {
  return SimulatedSensorColor(model).as_shot_neutral;
}

}  // namespace scanbench
