#include "calibration/spectra.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "calibration/color_science.h"
#include "calibration/embedded_text.h"
#include "calibration/spectral_table.h"

namespace scanbench {
namespace {

std::array<Spectrum, 3> ThreeColumns(const char* file) {
  const SpectralTable table = ParseSpectralTable(file, 3);
  return {table.columns[0], table.columns[1], table.columns[2]};
}

}  // namespace

SpectralTable ParseSpectralTable(const std::string& file, int expected_columns) {
  const std::string_view text = EmbeddedTextFile(file);
  if (text.empty()) throw std::runtime_error("spectral table " + file + " is not embedded in the library");
  auto fail = [&](int line, const std::string& what) {
    std::ostringstream message;
    message << "spectral table " << file << " line " << line << ": " << what;
    return std::runtime_error(message.str());
  };
  SpectralTable table;
  std::istringstream in{std::string(text)};
  std::string line;
  int line_number = 0;
  int sample = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::istringstream row(line);
    for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
    if (table.names.empty()) {  // the header: wavelength_nm, column names
      if (cells.size() != static_cast<size_t>(expected_columns) + 1 || cells[0] != "wavelength_nm") {
        throw fail(line_number, "header must be wavelength_nm and " + std::to_string(expected_columns) +
                                    " columns, got '" + line + "'");
      }
      table.names.assign(cells.begin() + 1, cells.end());
      table.columns.assign(expected_columns, Spectrum::Zero());
      continue;
    }
    if (sample >= kSpectrumSamples) throw fail(line_number, "more than 81 samples (380 .. 780 nm, 5 nm)");
    if (cells.size() != static_cast<size_t>(expected_columns) + 1) {
      throw fail(line_number, "has " + std::to_string(cells.size()) + " cells, must have " +
                                  std::to_string(expected_columns + 1));
    }
    std::vector<double> values;
    for (const std::string& cell : cells) {
      size_t used = 0;
      double value = NAN;
      try {
        value = std::stod(cell, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != cell.size() || !std::isfinite(value)) throw fail(line_number, "'" + cell + "' is not a finite number");
      values.push_back(value);
    }
    if (values[0] != SpectrumWavelengthNm(sample)) {
      throw fail(line_number, "wavelength " + cells[0] + " must be " +
                                  std::to_string(static_cast<int>(SpectrumWavelengthNm(sample))));
    }
    for (int c = 0; c < expected_columns; ++c) table.columns[c](sample) = values[c + 1];
    ++sample;
  }
  if (sample != kSpectrumSamples) {
    throw fail(line_number, "has " + std::to_string(sample) + " samples, must have 81 (380 .. 780 nm, 5 nm)");
  }
  return table;
}

const std::array<Spectrum, 3>& Cie1931ColorMatchingFunctions() {
  static const std::array<Spectrum, 3> cmfs = ThreeColumns("cie1931_2deg_cmf.csv");
  return cmfs;
}

const Spectrum& CieD65Spd() {
  static const Spectrum spd = ParseSpectralTable("cie_d65.csv", 1).columns[0];
  return spd;
}

const Spectrum& CieD50Spd() {
  static const Spectrum spd = ParseSpectralTable("cie_d50.csv", 1).columns[0];
  return spd;
}

const Spectrum& CieLedB5Spd() {
  static const Spectrum spd = ParseSpectralTable("cie_led_b5.csv", 1).columns[0];
  return spd;
}

const SpectralSensitivities& NikonD5100Sensitivities() {
  static const SpectralSensitivities camera{"Nikon D5100 (NPL)", ThreeColumns("nikon_d5100_npl.csv")};
  return camera;
}

const std::array<Spectrum, 3>& Mallett2019Basis() {
  static const std::array<Spectrum, 3> basis = ThreeColumns("mallett2019_srgb_basis.csv");
  return basis;
}

Spectrum ReflectanceFromLinearRec709(const Eigen::Vector3d& rgb_linear_rec709) {
  const std::array<Spectrum, 3>& basis = Mallett2019Basis();
  Spectrum reflectance = Spectrum::Zero();
  for (int c = 0; c < 3; ++c) {
    const double weight = rgb_linear_rec709(c);
    if (std::isfinite(weight)) reflectance += weight * basis[c];
  }
  return reflectance.cwiseMax(0.0).cwiseMin(1.0);
}

Eigen::Vector3d XyzOfReflectance(const Spectrum& reflectance, const Spectrum& illuminant) {
  const std::array<Spectrum, 3>& cmfs = Cie1931ColorMatchingFunctions();
  const Spectrum light = illuminant.cwiseProduct(reflectance);
  const double white_y = illuminant.dot(cmfs[1]);
  return Eigen::Vector3d(light.dot(cmfs[0]), light.dot(cmfs[1]), light.dot(cmfs[2])) / white_y;
}

Eigen::Vector3d LinearRec709OfReflectance(const Spectrum& reflectance) {
  static const Eigen::Vector3d white_rec709 =
      LinearRec709FromXyz() * XyzOfReflectance(Spectrum::Ones(), CieD65Spd());
  return (LinearRec709FromXyz() * XyzOfReflectance(reflectance, CieD65Spd())).cwiseQuotient(white_rec709);
}

Eigen::Vector3d WhiteBalancedCameraRgb(const SpectralSensitivities& camera, const Spectrum& illuminant,
                                       const Spectrum& reflectance) {
  const Spectrum light = illuminant.cwiseProduct(reflectance);
  Eigen::Vector3d rgb;
  for (int c = 0; c < 3; ++c) rgb(c) = camera.rgb[c].dot(light) / camera.rgb[c].dot(illuminant);
  return rgb;
}

Eigen::Vector3d CameraWhiteRelativeToGreen(const SpectralSensitivities& camera, const Spectrum& illuminant) {
  Eigen::Vector3d white;
  for (int c = 0; c < 3; ++c) white(c) = camera.rgb[c].dot(illuminant);
  return white / white(1);
}

Eigen::Vector2d ChromaticityOfIlluminant(const Spectrum& illuminant) {
  const Eigen::Vector3d xyz = XyzOfReflectance(Spectrum::Ones(), illuminant);
  return xyz.head<2>() / xyz.sum();
}

}  // namespace scanbench
