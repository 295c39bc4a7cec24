// Parsing of the embedded spectral CSV tables (internal to scanbench_calibration; spectra.h is the API).
#pragma once

#include <string>
#include <vector>

#include "calibration/spectra.h"

namespace scanbench {

struct SpectralTable {
  std::vector<std::string> names;  // column names from the header, without wavelength_nm
  std::vector<Spectrum> columns;
};

// The embedded table `file` ("cie_d65.csv"): '#' comment lines, a header "wavelength_nm,<names>", then
// exactly 81 rows 380, 385, .. 780 nm of finite numbers. Throws std::runtime_error naming the file, the
// line and the rule broken.
SpectralTable ParseSpectralTable(const std::string& file, int expected_columns);

}  // namespace scanbench
