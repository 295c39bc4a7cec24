// Spectral data and the spectral rendering helpers built on it: the CIE 1931 observer, CIE illuminants
// D65, D50 and LED-B5, the Nikon D5100 camera's measured sensitivities and the Mallett & Yuksel (2019)
// reflectance basis. The tables (data/spectra/*.csv, sources and licences in data/spectra/README.md) are
// compiled into the library; nothing is read from disk. All share one grid: 380 .. 780 nm in 5 nm steps.
// A malformed table throws std::runtime_error (naming the file, line and rule) on first use.
#pragma once

#include <array>
#include <string>

#include <Eigen/Core>

namespace scanbench {

inline constexpr double kSpectrumFirstNm = 380, kSpectrumStepNm = 5;
inline constexpr int kSpectrumSamples = 81;  // 380 .. 780 nm
using Spectrum = Eigen::Matrix<double, kSpectrumSamples, 1>;

// Wavelength of sample i, nm.
inline constexpr double SpectrumWavelengthNm(int i) { return kSpectrumFirstNm + kSpectrumStepNm * i; }

struct SpectralSensitivities {
  std::string name;
  std::array<Spectrum, 3> rgb;  // camera R, G, B, relative (only ratios matter)
};

const std::array<Spectrum, 3>& Cie1931ColorMatchingFunctions();  // x-bar, y-bar, z-bar
const Spectrum& CieD65Spd();    // relative, 560 nm = 100
const Spectrum& CieD50Spd();    // relative, 560 nm = 100
const Spectrum& CieLedB5Spd();  // CIE 15:2018 LED-B5: phosphor-converted white LED, 6598 K
const SpectralSensitivities& NikonD5100Sensitivities();  // Darrodi et al. 2015 (NPL)

// Mallett & Yuksel 2019: reflectance = r B_r + g B_g + b B_b, in [0, 1] for rgb in [0, 1], and it
// reproduces rgb under D65 through the CIE observer.
const std::array<Spectrum, 3>& Mallett2019Basis();
// The Mallett reflectance of a linear Rec.709 colour; the result is clamped to the physical [0, 1]
// (which only bites for rgb outside [0, 1]); a NaN component reads 0.
Spectrum ReflectanceFromLinearRec709(const Eigen::Vector3d& rgb_linear_rec709);

// XYZ of a reflectance under an illuminant, normalised so that the perfect white reads Y = 1.
Eigen::Vector3d XyzOfReflectance(const Spectrum& reflectance, const Spectrum& illuminant);
// Linear Rec.709 of a reflectance under D65 (the colour a material pipeline wants), white = (1, 1, 1):
// LinearRec709FromXyz of the D65 XYZ, with a per-channel scale (< 3e-4 from 1) that takes the
// tabulated D65 white exactly to (1, 1, 1).
Eigen::Vector3d LinearRec709OfReflectance(const Spectrum& reflectance);
// Camera response sum_l S_c(l) E(l) R(l) per channel, divided by the perfect white's response per channel:
// "white-balanced camera RGB" of the reflectance under that light (a perfect white reads (1, 1, 1)).
Eigen::Vector3d WhiteBalancedCameraRgb(const SpectralSensitivities& camera, const Spectrum& illuminant,
                                       const Spectrum& reflectance);
// The perfect white's raw response per channel relative to green (green = 1).
Eigen::Vector3d CameraWhiteRelativeToGreen(const SpectralSensitivities& camera, const Spectrum& illuminant);

// CIE 1931 xy chromaticity of an illuminant (its perfect white) through the 2-degree observer.
Eigen::Vector2d ChromaticityOfIlluminant(const Spectrum& illuminant);

}  // namespace scanbench
