// Text tables embedded in the library at build time (cmake/EmbedTextFiles.cmake turns data/spectra/*.csv
// into a generated .cc), so nothing is read from disk at run time. Internal to scanbench_calibration.
#pragma once

#include <string_view>

namespace scanbench {

// The content of the embedded file with that base name ("cie_d65.csv"); empty when there is none.
std::string_view EmbeddedTextFile(std::string_view name);

}  // namespace scanbench
