#include "core/progress.h"

namespace scanbench {

ProgressCallback SubRange(const ProgressCallback& progress, double begin, double end) {
  if (!progress) return {};
  return [progress, begin, end](double fraction) { return progress(begin + (end - begin) * fraction); };
}

}  // namespace scanbench
