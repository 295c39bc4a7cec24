// libFuzzer harness: a photometric data set folder (DiLiGenT or LUCES-style,
// app/io/dataset_io.h) through LoadPhotometricDataset. The input holds the
// folder's files in sections (fuzz_support.h), in kFiles' order; an empty
// section leaves that file out. Normal_gt.mat (matio) is not fuzzed here.
#include <cstdint>

#include "app/io/dataset_io.h"
#include "tests/fuzz/fuzz_support.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace scanbench;
  static const char* const kFiles[] = {"filenames.txt",     "light_intensities.txt", "light_directions.txt",
                                       "light_positions.txt", "light_mu.txt",        "K.txt",
                                       "mean_distance.txt", "mask.png",              "001.png",
                                       "002.png",           "003.png"};
  const std::filesystem::path folder = fuzz::FreshFolder("dataset");
  const auto sections = fuzz::SplitSections(data, size);
  for (size_t i = 0; i < sections.size() && i < std::size(kFiles); ++i) {
    if (!sections[i].empty()) fuzz::WriteBytes(folder / kFiles[i], sections[i]);
  }
  fuzz::ExpectOnlyDocumentedErrors([&] {
    if (!IsPhotometricDatasetFolder(folder)) return;
    DatasetLoadOptions options;
    options.load_ground_truth = false;
    const PhotometricDataset dataset = LoadPhotometricDataset(folder, options);
    if (dataset.kind == PhotometricDataset::Kind::kNearField) dataset.TableFrame();
    dataset.CentralLightDirections();
  });
  return 0;
}
