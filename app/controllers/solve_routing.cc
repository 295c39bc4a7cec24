#include "app/controllers/solve_routing.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <future>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/spill_file.h"
#include "pipeline/banded_solve.h"

namespace scanbench {
namespace fs = std::filesystem;

namespace {

// Every map of a solution, in one order, for `f(image)`.
template <typename Solution, typename F>
void ForEachMap(Solution& s, const F& f) {
  f(s.normal_in_table);
  f(s.albedo);
  f(s.status);
  f(s.lights_used);
  f(s.condition_number);
  f(s.residual);
  f(s.solve_path);
  f(s.specular);
  f(s.specular_status);
  f(s.learned_error_deg);
}
constexpr int kNormalMap = 0, kStatusMap = 2, kSolvePathMap = 6;  // their places in ForEachMap's order

}  // namespace

// The first pass of a solve whose depth refinement may re-solve (point LEDs,
// refinement on): each solved band goes into the decision blocks and, every
// map of it that is written or evaluated (not solve_path), into an unlinked
// spill file (43 bytes a pixel: 0.7 GB of the file system's cache at 16 MP,
// not the process's memory). Once the decision is
// taken the bands are handed on to be written (the table plane kept) or only
// the normals and status read back (the re-solves start from them), so a
// draped sample's first pass is never encoded nor evaluated. A solve that
// streams the first pass's maps meanwhile (SolveOptions::stream_first_pass)
// spills only the normals and status (13 bytes a pixel; no Replay).
class FirstPassSpill {
 public:
  FirstPassSpill(const fs::path& folder, int width, int height, int num_threads, bool all_maps = true)
      : width_(width), all_maps_(all_maps), blocks_(width, height), spill_(folder), num_threads_(num_threads) {}

  void Add(const PhotometricSolution& band) {
    blocks_.AddRows(band, num_threads_);
    int map = 0;
    ForEachMap(band, [&](const auto& image) {
      if (band_rows_.empty()) channels_[map] = image.empty() ? 0 : image.channels();
      if (image.empty() != (channels_[map] == 0) || (!image.empty() && image.channels() != channels_[map])) {
        throw std::logic_error("FirstPassSpill: the bands' maps differ");
      }
      if (Spilled(map)) spill_.Append(image.data(), image.size() * sizeof(*image.data()));
      ++map;
    });
    band_rows_.push_back(band.status.height());
  }

  const DepthDecisionBlocks& decision_blocks() const { return blocks_; }

  // The bands as they were added, in order. The next band is read from the
  // spill on a thread of its own while the sink takes this one (the read is
  // a serial 28 MB copy a band at 16 MP, which left the pool idle), into the
  // other of two bands whose maps are reused (the sink holds none of them
  // after it returns): no fresh pages to fault in and fill per band.
  void Replay(const std::function<void(PhotometricSolution& band)>& sink) {
    if (!all_maps_) throw std::logic_error("FirstPassSpill::Replay: only the normals and status were spilled");
    std::array<PhotometricSolution, 2> bands;
    const auto read = [this](int rows, size_t offset, PhotometricSolution* band) {
      int map = 0;
      ForEachMap(*band, [&](auto& image) {
        if (channels_[map] > 0 && Spilled(map)) {
          image.Reshape(width_, rows, channels_[map]);
          const size_t bytes = image.size() * sizeof(*image.data());
          spill_.ReadAt(offset, image.data(), bytes);  // pread only: the spill was flushed before
          offset += bytes;
        }
        ++map;
      });
      return offset;
    };
    if (band_rows_.empty()) return;
    spill_.Flush();  // so that ReadAt only reads, from either thread
    size_t next_offset = read(band_rows_[0], 0, &bands[0]);
    for (size_t b = 0; b < band_rows_.size(); ++b) {
      std::future<size_t> next;
      if (b + 1 < band_rows_.size()) {
        next = std::async(std::launch::async, read, band_rows_[b + 1], next_offset, &bands[(b + 1) % 2]);
      }
      try {
        sink(bands[b % 2]);
      } catch (...) {
        if (next.valid()) next.wait();  // its band is this function's
        throw;
      }
      if (next.valid()) next_offset = next.get();
    }
  }

  // The first pass's normals and status at full size (all RefineDepth reads of it).
  PhotometricSolution NormalsAndStatus() {
    PhotometricSolution first;
    int height = 0;
    for (const int rows : band_rows_) height += rows;
    first.normal_in_table = ImageF(width_, height, 3);
    first.status = ImageU8(width_, height, 1);
    size_t offset = 0;
    int y = 0;
    for (const int rows : band_rows_) {
      int map = 0;
      PhotometricSolution shapes;  // only for the maps' sample types
      ForEachMap(shapes, [&](auto& image) {
        const size_t bytes = size_t(width_) * rows * channels_[map] * sizeof(*image.data());
        if (map == kNormalMap) spill_.ReadAt(offset, first.normal_in_table.row(y), bytes);
        if (map == kStatusMap) spill_.ReadAt(offset, first.status.row(y), bytes);
        if (Spilled(map)) offset += bytes;
        ++map;
      });
      y += rows;
    }
    return first;
  }

  bool all_maps() const { return all_maps_; }

 private:
  // Map `map` (ForEachMap's order) goes to the spill: all but solve_path
  // (neither written nor evaluated: a replayed band has none), or the
  // normals and status.
  bool Spilled(int map) const { return all_maps_ ? map != kSolvePathMap : map == kNormalMap || map == kStatusMap; }

  int width_;
  bool all_maps_;
  std::array<int, 10> channels_{};  // per map (ForEachMap's order), 0 = empty
  std::vector<int> band_rows_;
  DepthDecisionBlocks blocks_;
  SpillFile spill_;
  int num_threads_;
};


ResultStream::ResultStream(const fs::path& folder, int width, int height, const AlbedoColor& color,
                           const ExrEncoding& exr, std::optional<GroundTruthEvaluation> evaluation, int num_threads,
                           StageTimes* times)
    : folder_(folder),
      width_(width),
      height_(height),
      color_(color),
      exr_(exr),
      num_threads_(num_threads),
      times_(times),
      evaluation_(std::move(evaluation)) {}

ResultStream::~ResultStream() = default;

void ResultStream::Add(PhotometricSolution& band) {
  times_->Time("color", [&] {
    solved_.Reshape(band.status.width(), band.status.height(), 1);
    for (size_t i = 0; i < solved_.size(); ++i) {
      solved_.data()[i] = band.status.data()[i] == static_cast<uint8_t>(PixelStatus::kSolved);
    }
    ApplyAlbedoColor(color_, solved_, &band.albedo);
  });
  times_->Time("write_maps", [&] {
    specular_.Add(band);
    // The maps open at the first band: whether there is a specular map is the solve's.
    if (!maps_) {
      maps_.emplace(folder_, width_, height_, !band.specular.empty(), evaluation_.has_value(),
                    !band.learned_error_deg.empty(), color_, exr_);
    }
    const double evaluated_before = maps_->alongside_seconds();
    maps_->AddBand(band,
                   evaluation_ ? std::function<ImageF()>([&] { return evaluation_->AddBand(band, num_threads_); })
                               : std::function<ImageF()>(),
                   num_threads_);
    if (evaluation_) times_->Add("evaluate", maps_->alongside_seconds() - evaluated_before);
  });
}

SolveRouting::SolveRouting(Route route, int width, int height, const fs::path& spill_folder, int num_threads,
                           std::function<std::unique_ptr<ResultStream>()> open_results)
    : open_results_(std::move(open_results)) {
  if (route != Route::kStream) {
    first_pass_ = std::make_unique<FirstPassSpill>(spill_folder, width, height, num_threads,
                                                   /*all_maps=*/route == Route::kSpill);
  }
  if (route != Route::kSpill) results_ = open_results_();
  // kStreamAndSpill: the bands are taken on a thread of their own, so that
  // one band's files are encoded while the next band is solved (the solve's
  // threads and this one share the cores, and what one leaves idle, a band's
  // last file or the solve's serial steps, the other takes). The bands come in
  // order, as on the solve's thread, so the files are the same. Two bands wait
  // at most (about 28 MB each at 16 MP).
  if (route == Route::kStreamAndSpill) {
    writer_ = std::make_unique<BoundedWorker<PhotometricSolution>>(
        [this](PhotometricSolution& band) { Take(band); }, 2);
  }
}

SolveRouting::~SolveRouting() = default;

void SolveRouting::Take(PhotometricSolution& band) {
  if (first_pass_) first_pass_->Add(band);  // before the results: they colour the albedo in place
  if (results_) results_->Add(band);
}

void SolveRouting::AddFirstPassBand(PhotometricSolution& band) {
  if (writer_) {
    writer_->Push(std::move(band));
  } else {
    Take(band);
  }
}

void SolveRouting::FinishFirstPass() {
  if (!writer_) return;
  writer_->Finish();
  writer_.reset();
}

const DepthDecisionBlocks* SolveRouting::decision_blocks() const {
  return first_pass_ ? &first_pass_->decision_blocks() : nullptr;
}

PhotometricSolution SolveRouting::TakeFirstPassForResolve() {
  if (!first_pass_ || writer_) throw std::logic_error("SolveRouting::TakeFirstPassForResolve: no finished first pass");
  results_.reset();  // a streamed first pass is not the result: its files go
  PhotometricSolution first = first_pass_->NormalsAndStatus();
  first_pass_.reset();
  return first;
}

void SolveRouting::StreamResolved(const PhotometricSolution& solution) {
  if (first_pass_ || results_) throw std::logic_error("SolveRouting::StreamResolved: the first pass was not taken");
  results_ = open_results_();
  const int height = solution.status.height();
  for (int y = 0; y < height; y += kEvaluationBandRows) {
    PhotometricSolution band = SolutionRows(solution, y, std::min(kEvaluationBandRows, height - y));
    results_->Add(band);
  }
}

ResultStream& SolveRouting::Results() {
  if (writer_) throw std::logic_error("SolveRouting::Results: the first pass is not finished");
  if (first_pass_ && first_pass_->all_maps()) {
    // The table plane kept: the first pass's bands, written and evaluated now.
    results_ = open_results_();
    first_pass_->Replay([&](PhotometricSolution& band) { results_->Add(band); });
  }
  first_pass_.reset();  // a streamed first pass's spilled normals and status
  if (!results_) throw std::logic_error("SolveRouting::Results: no result was routed");
  return *results_;
}

}  // namespace scanbench
