// The file of the learned solver's training observations (solver/observation_sets.h, rendered by app/sim/observation_sets.h),
// read by scripts/train/train_normal_net.py with numpy alone:
//
//   line 1   "SCANBENCH-OBSERVATIONS 1"
//   line 2   one JSON object: "num_sets", "num_samples", "seed", and "arrays", a
//            list of {"name", "dtype" (numpy's, little-endian), "shape", "offset"}
//            where offset counts bytes from the first byte after line 2
//   then     the arrays back to back: offset (int64, num_sets + 1), normal
//            (float32, num_sets x 3), albedo (float32), light_set_kind (int32),
//            material_flags (int32), light_dir (float32, num_samples x 3),
//            value (float32, num_samples)
#pragma once

#include <filesystem>

#include "solver/observation_sets.h"

namespace scanbench {

// Writes `sets` to `path` (temporary name, fsync, rename; an existing file is
// replaced). Throws std::runtime_error naming the path on an I/O error.
void WriteObservationSets(const std::filesystem::path& path, const ObservationSets& sets, uint64_t seed);

// Reads a file written by WriteObservationSets. Throws std::runtime_error
// naming the path and what is wrong (not this format, truncated, offsets out
// of order).
ObservationSets ReadObservationSets(const std::filesystem::path& path);

}  // namespace scanbench
