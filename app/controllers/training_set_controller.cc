#include "app/controllers/training_set_controller.h"

#include <stdexcept>

#include "app/io/observation_set_io.h"

namespace scanbench {

TrainingSetController::TrainingSetController(std::filesystem::path output_file, ObservationSetOptions options)
    : output_file_(std::move(output_file)), options_(std::move(options)) {
  options_.Check();
  if (output_file_.empty()) throw std::invalid_argument("training-set: the output file is empty");
}

void TrainingSetController::Run() {
  ObservationSets sets;
  BeginStage("render");
  ObservationSetOptions options = options_;
  options.progress = StageCallback("render");
  summary_ = GenerateObservationSets(options, &sets);
  RequireSuccess(summary_, "render the observation sets");
  BeginStage("write");
  WriteObservationSets(output_file_, sets, options_.seed);
  ReportProgress("write", 1);
}

}  // namespace scanbench
