// Renders the learned solver's training observations and writes them
// (scanbench training-set; scripts/train/train_normal_net.py calls it).
#pragma once

#include <filesystem>

#include "app/controllers/base_controller.h"
#include "app/sim/observation_sets.h"

namespace scanbench {

class TrainingSetController : public BaseController {
 public:
  TrainingSetController(std::filesystem::path output_file, ObservationSetOptions options);
  // Steps: render, write.
  void Run() override;
  const ObservationSetSummary& summary() const { return summary_; }

 private:
  std::filesystem::path output_file_;
  ObservationSetOptions options_;
  ObservationSetSummary summary_;
};

}  // namespace scanbench
