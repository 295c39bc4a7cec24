#include "app/cli/run_controller.h"

#include <atomic>
#include <chrono>
#include <csignal>
#include <exception>
#include <iostream>
#include <thread>

#include "app/cli/option_fields.h"
#include "app/cli/progress_bar.h"

namespace scanbench {
namespace {

volatile std::sig_atomic_t g_interrupted = 0;
void OnInterrupt(int) { g_interrupted = 1; }

}  // namespace

int RunController(BaseController& controller, const ProgressReportCallback& observer) {
  ProgressBar bar;
  controller.SetProgressCallback([&](const ProgressReport& report) {
    bar.Update(report);
    if (observer) observer(report);
  });
  g_interrupted = 0;
  std::signal(SIGINT, OnInterrupt);
  std::signal(SIGTERM, OnInterrupt);
  // The job runs on a worker so that this thread can pass a signal on as a
  // stop request; the job then ends cleanly at its next check.
  std::exception_ptr failure;
  std::atomic<bool> finished{false};
  std::thread worker([&] {
    try {
      controller.Run();
    } catch (...) {
      failure = std::current_exception();
    }
    finished = true;
  });
  while (!finished) {
    if (g_interrupted) controller.RequestStop();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  worker.join();
  bar.Finish();
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  if (!failure) return kExitSuccess;
  try {
    std::rethrow_exception(failure);
  } catch (const Cancelled& cancelled) {
    std::cerr << "scanbench: " << cancelled.what() << "; nothing was lost (frames and earlier results are intact)\n";
    return kExitCancelled;
  } catch (const std::exception& error) {
    std::cerr << "scanbench: error: " << CommandLineMessage(error) << "\n";
    return kExitFailure;
  }
}

}  // namespace scanbench
