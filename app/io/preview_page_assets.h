// The preview page's template (app/io/preview_page.html) and three.js
// (third_party/three/three.module.min.js), compiled into scanbench_io at build
// time by cmake/EmbedTextFiles.cmake. Internal to scanbench_io.
#pragma once

#include <string_view>

namespace scanbench {

// The content of the embedded file with that base name ("preview_page.html"); empty when there is none.
std::string_view PreviewPageAsset(std::string_view name);

}  // namespace scanbench
