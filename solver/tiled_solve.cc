#include "solver/tiled_solve.h"

#include <algorithm>
#include <atomic>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/parallel_for.h"

namespace scanbench::tiled {
namespace {

// All lights of one span: the rows' addresses and the per-span constants,
// then the hot loop of the job's instruction set (span_kernels_impl.h).
template <bool kUniform, bool kBayer, bool kAlbedo>
void AccumulateSpan(const SolveJob& job, const SharedLights& shared, int x0, int count, int y, SpanBuffers* b) {
  const PhotometricSolverOptions& options = *job.options;
  constexpr int kChannels = kBayer ? 1 : 3;
  // The kernel asks for the next row's samples while it sums this one's.
  const bool next = y + 1 < job.field->height();
  for (int k = 0; k < job.num_lights; ++k) {
    b->rows[k] = (*job.images)[k]->row(y) + static_cast<size_t>(x0) * kChannels;
    b->marks[k] = job.sample_valid->empty() ? b->ones.data() : (*job.sample_valid)[k]->row(y) + x0;
    if (next) {
      b->next_rows[k] = (*job.images)[k]->row(y + 1) + static_cast<size_t>(x0) * kChannels;
      b->next_marks[k] = job.sample_valid->empty() ? b->ones.data() : (*job.sample_valid)[k]->row(y + 1) + x0;
    }
  }
  AccumulateArgs a;
  a.count = count;
  a.num_lights = job.num_lights;
  a.capacity = b->capacity;
  a.uniform = kUniform;
  a.bayer = kBayer;
  a.albedo = kAlbedo;
  a.pixels = b->rows.data();
  a.marks = b->marks.data();
  a.next_pixels = next ? b->next_rows.data() : nullptr;
  a.next_marks = next ? b->next_marks.data() : nullptr;
  a.w0 = static_cast<float>(options.luminance_weights[0]);
  a.w1 = static_cast<float>(options.luminance_weights[1]);
  a.w2 = static_cast<float>(options.luminance_weights[2]);
  // With no shadow level every finite sample counts (also 0 and negatives).
  a.threshold = options.min_sample_value > 0 ? static_cast<float>(options.min_sample_value)
                                             : -std::numeric_limits<float>::infinity();
  a.shared_dir = shared.dir.data();
  a.shared_inv = shared.inv.data();
  // Bayer: the colour channel of even and odd columns of this row.
  a.even_channel = job.cfa_channels[(y & 1) * 2 + (x0 & 1)];
  a.odd_channel = job.cfa_channels[(y & 1) * 2 + ((x0 + 1) & 1)];
  a.dir = b->dir.data();
  a.inv = b->inv.data();
  a.lum = b->lum.data();
  a.ok = b->ok.data();
  a.rgb = b->rgb.data();
  a.clipped = b->clipped.data();
  a.acc = b->acc.data();
  KernelsOf(job).accumulate(a);
}

}  // namespace

SpanBuffers::SpanBuffers(int lights, int span_capacity) : num_lights(lights), capacity(span_capacity) {
  const size_t k3n = static_cast<size_t>(3) * num_lights * capacity;
  const size_t kn = static_cast<size_t>(num_lights) * capacity;
  dir.assign(k3n, 0.0f);
  inv.assign(k3n, 0.0f);
  lum.assign(kn, 0.0f);
  rgb.assign(k3n, 0.0f);
  ok.assign(kn, 0.0f);
  ones.assign(capacity, 1);
  rows.assign(num_lights, nullptr);
  marks.assign(num_lights, nullptr);
  next_rows.assign(num_lights, nullptr);
  next_marks.assign(num_lights, nullptr);
  acc.assign(static_cast<size_t>(kNumAcc) * capacity, 0.0);
  light_bad.assign(capacity, 0);
  clipped.assign(capacity, 0.0f);
  all_lights_condition.assign(capacity, 0.0);
}

const SpanKernels& KernelsOf(const SolveJob& job) {
  return job.kernels != nullptr ? *job.kernels : SpanKernelsFor(ActiveKernelIsa());
}

AccumulateSpanFn ChooseAccumulator(bool bayer, bool with_albedo, bool uniform_lights) {
  // Bayer pixels carry one channel: no RGB albedo solves there.
  if (bayer) return uniform_lights ? &AccumulateSpan<true, true, false> : &AccumulateSpan<false, true, false>;
  if (with_albedo) return uniform_lights ? &AccumulateSpan<true, false, true> : &AccumulateSpan<false, false, true>;
  return uniform_lights ? &AccumulateSpan<true, false, false> : &AccumulateSpan<false, false, false>;
}

SpanFits::SpanFits(int span_capacity) : capacity(span_capacity) {
  status.assign(capacity, 0);
  lights_used.assign(capacity, 0);
  normal.assign(static_cast<size_t>(3) * capacity, 0.0);
  albedo.assign(static_cast<size_t>(3) * capacity, 0.0);
  luminance_albedo.assign(capacity, 0.0);
  condition_number.assign(capacity, 0.0);
  residual.assign(capacity, 0.0);
}

PixelFit SpanFits::Fit(int i) const {
  PixelFit fit;
  fit.status = static_cast<PixelStatus>(status[i]);
  for (int c = 0; c < 3; ++c) {
    fit.normal[c] = normal[c * capacity + i];
    fit.albedo[c] = albedo[c * capacity + i];
  }
  fit.luminance_albedo = luminance_albedo[i];
  fit.lights_used = lights_used[i];
  fit.condition_number = condition_number[i];
  fit.residual = residual[i];
  return fit;
}

namespace {

// StoreFits' loops for a span with a region or skipped pixels (the others
// go to the per-ISA store kernel).
void StoreFitRows(const SolveJob& job, const SpanFits& fits, const Span& span, const uint8_t* skip,
                  std::array<size_t, kNumSolvePaths>* pixels_by_path) {
  PhotometricSolution& s = *job.solution;
  const int count = span.count, n = fits.capacity, x0 = span.x0, y = span.y;
  const uint8_t solved_code = static_cast<uint8_t>(PixelStatus::kSolved);
  const uint8_t* __restrict status_in = fits.status.data();
  auto write = [&](int i) { return span.Wanted(i) && (skip == nullptr || skip[i] == 0); };
  {
    float* __restrict out = s.normal_in_table.row(y) + static_cast<size_t>(x0) * 3;
    const double* __restrict n0 = fits.normal.data();
    const double* __restrict n1 = n0 + n;
    const double* __restrict n2 = n0 + 2 * n;
    for (int i = 0; i < count; ++i) {
      if (!write(i)) continue;
      out[3 * i] = static_cast<float>(n0[i]);
      out[3 * i + 1] = static_cast<float>(n1[i]);
      out[3 * i + 2] = static_cast<float>(n2[i]);
    }
  }
  if (job.bayer) {
    float* __restrict out = job.albedo_mosaic->row(y) + x0;
    const double* __restrict length = fits.luminance_albedo.data();
    for (int i = 0; i < count; ++i) {
      if (write(i)) out[i] = status_in[i] == solved_code ? static_cast<float>(length[i]) : 0.0f;
    }
  } else if (job.with_albedo) {
    float* __restrict out = s.albedo.row(y) + static_cast<size_t>(x0) * 3;
    const double* __restrict a0 = fits.albedo.data();
    const double* __restrict a1 = a0 + n;
    const double* __restrict a2 = a0 + 2 * n;
    for (int i = 0; i < count; ++i) {
      if (!write(i)) continue;
      const bool solved = status_in[i] == solved_code;
      out[3 * i] = solved ? static_cast<float>(a0[i]) : 0.0f;
      out[3 * i + 1] = solved ? static_cast<float>(a1[i]) : 0.0f;
      out[3 * i + 2] = solved ? static_cast<float>(a2[i]) : 0.0f;
    }
  }
  {
    uint8_t* __restrict status = s.status.row(y) + x0;
    uint8_t* __restrict lights = s.lights_used.row(y) + x0;
    uint8_t* __restrict path = s.solve_path.row(y) + x0;
    const int* __restrict used = fits.lights_used.data();
    const uint8_t light_path = static_cast<uint8_t>(span.LightPath()), none = static_cast<uint8_t>(SolvePath::kNone);
    size_t solved_count = 0, written = 0;
    for (int i = 0; i < count; ++i) {
      if (!write(i)) continue;
      const bool solved = status_in[i] == solved_code;
      status[i] = status_in[i];
      lights[i] = static_cast<uint8_t>(used[i] < 0 ? 0 : used[i] > 255 ? 255 : used[i]);
      path[i] = solved ? light_path : none;
      solved_count += solved;
      ++written;
    }
    (*pixels_by_path)[light_path] += solved_count;
    (*pixels_by_path)[none] += written - solved_count;
  }
  if (job.with_confidence) {
    float* __restrict condition = s.condition_number.row(y) + x0;
    float* __restrict residual = s.residual.row(y) + x0;
    const double* __restrict condition_in = fits.condition_number.data();
    const double* __restrict residual_in = fits.residual.data();
    const double float_max = std::numeric_limits<float>::max();
    for (int i = 0; i < count; ++i) {
      if (!write(i)) continue;
      const bool solved = status_in[i] == solved_code;
      condition[i] = static_cast<float>(condition_in[i] < float_max ? condition_in[i] : float_max);
      residual[i] = solved ? static_cast<float>(residual_in[i] < 1e30 ? residual_in[i] : 1e30) : 0.0f;
    }
  }
  if (!s.specular.empty()) {
    float* __restrict specular = s.specular.row(y) + static_cast<size_t>(x0) * 2;
    uint8_t* __restrict specular_status = s.specular_status.row(y) + x0;
    const uint8_t unsupported = static_cast<uint8_t>(SpecularStatus::kUnsupported);
    const uint8_t not_solved = static_cast<uint8_t>(SpecularStatus::kNotSolved);
    for (int i = 0; i < count; ++i) {
      if (!write(i)) continue;
      specular[2 * i] = 0.0f, specular[2 * i + 1] = 0.0f;
      specular_status[i] = status_in[i] == solved_code ? unsupported : not_solved;
    }
  }
}

// The span's stretch of the next row of every result image, asked of the
// memory now: the images were filled before the solve and have long left the
// caches, and each line is read before it is written. The next row's
// samples are summed in the meantime.
template <typename T>
void PrefetchForWrite(const Image<T>& image, int x0, int count, int y) {
  if (image.empty() || y >= image.height()) return;
  const char* first = reinterpret_cast<const char*>(image.row(y) + static_cast<size_t>(x0) * image.channels());
  const size_t bytes = static_cast<size_t>(count) * image.channels() * sizeof(T);
  for (size_t offset = 0; offset < bytes; offset += 64) __builtin_prefetch(first + offset, 1);
  __builtin_prefetch(first + bytes - 1, 1);
}

void PrefetchNextFits(const SolveJob& job, const Span& span) {
  const PhotometricSolution& s = *job.solution;
  const int x0 = span.x0, count = span.count, y = span.y + 1;
  PrefetchForWrite(s.normal_in_table, x0, count, y);
  if (job.bayer) {
    PrefetchForWrite(*job.albedo_mosaic, x0, count, y);
  } else if (job.with_albedo) {
    PrefetchForWrite(s.albedo, x0, count, y);
  }
  PrefetchForWrite(s.status, x0, count, y);
  PrefetchForWrite(s.lights_used, x0, count, y);
  PrefetchForWrite(s.solve_path, x0, count, y);
  if (job.with_confidence) {
    PrefetchForWrite(s.condition_number, x0, count, y);
    PrefetchForWrite(s.residual, x0, count, y);
  }
  PrefetchForWrite(s.specular, x0, count, y);
  PrefetchForWrite(s.specular_status, x0, count, y);
}

}  // namespace

// Store's values, a row of one image at a time (each a short contiguous run
// instead of eight interleaved ones per pixel).
void PixelWriter::StoreFits(const SpanFits& fits, const Span& span, const uint8_t* skip) {
  if (span.region == nullptr && skip == nullptr) {
    // Every pixel written: the per-ISA kernel's loops.
    PhotometricSolution& s = *job_.solution;
    const int x0 = span.x0, y = span.y;
    StoreArgs a;
    a.count = span.count;
    a.capacity = fits.capacity;
    a.solved = static_cast<uint8_t>(PixelStatus::kSolved);
    a.light_path = static_cast<uint8_t>(span.LightPath());
    a.no_path = static_cast<uint8_t>(SolvePath::kNone);
    a.unsupported = static_cast<uint8_t>(SpecularStatus::kUnsupported);
    a.not_solved = static_cast<uint8_t>(SpecularStatus::kNotSolved);
    a.status = fits.status.data();
    a.lights_used = fits.lights_used.data();
    a.normal = fits.normal.data();
    a.albedo = fits.albedo.data();
    a.luminance_albedo = fits.luminance_albedo.data();
    a.condition = fits.condition_number.data();
    a.residual = fits.residual.data();
    a.normal_out = s.normal_in_table.row(y) + static_cast<size_t>(x0) * 3;
    if (job_.bayer) {
      a.mosaic_out = job_.albedo_mosaic->row(y) + x0;
    } else if (job_.with_albedo) {
      a.albedo_out = s.albedo.row(y) + static_cast<size_t>(x0) * 3;
    }
    a.status_out = s.status.row(y) + x0;
    a.lights_out = s.lights_used.row(y) + x0;
    a.path_out = s.solve_path.row(y) + x0;
    if (job_.with_confidence) {
      a.condition_out = s.condition_number.row(y) + x0;
      a.residual_out = s.residual.row(y) + x0;
    }
    if (!s.specular.empty()) {
      a.specular_out = s.specular.row(y) + static_cast<size_t>(x0) * 2;
      a.specular_status_out = s.specular_status.row(y) + x0;
    }
    const int solved = KernelsOf(job_).store(a);
    pixels_by_path_[a.light_path] += solved;
    pixels_by_path_[a.no_path] += span.count - solved;
  } else {
    StoreFitRows(job_, fits, span, skip, &pixels_by_path_);
  }
  PrefetchNextFits(job_, span);
}

void GatherSamples(const Span& span, int i, bool with_rgb, PixelSamples* samples) {
  const SpanBuffers& b = *span.buffers;
  const int n = b.capacity;
  const bool uniform = span.lights == TileLights::kUniform;
  samples->Clear();
  for (int k = 0; k < b.num_lights; ++k) {
    const size_t at = static_cast<size_t>(k) * n + i;
    if (!(b.ok[at] > 0)) continue;
    double d[3];
    for (int c = 0; c < 3; ++c) {
      d[c] = uniform ? span.shared->dir[3 * k + c] : b.dir[static_cast<size_t>(3 * k + c) * n + i];
    }
    const double value = b.lum[at];
    double rgb[3] = {0, 0, 0};
    if (with_rgb) {
      for (int c = 0; c < 3; ++c) rgb[c] = b.rgb[static_cast<size_t>(3 * k + c) * n + i];
    }
    samples->Add(d[0], d[1], d[2], value, rgb[0], rgb[1], rgb[2]);
  }
}

void CheckRgbRefinementInput(const char* pass, const PhotometricSolverInput& input,
                             const PhotometricSolution* solution) {
  const std::string name(pass);
  if (solution == nullptr) throw std::invalid_argument(name + ": solution is null");
  if (input.light_field == nullptr) throw std::invalid_argument(name + ": light_field is null");
  const int width = input.light_field->width(), height = input.light_field->height();
  if (static_cast<int>(input.images.size()) != input.light_field->num_lights()) {
    throw std::invalid_argument(name + ": " + std::to_string(input.images.size()) + " images for a light field of " +
                                std::to_string(input.light_field->num_lights()) + " lights; they must match");
  }
  for (size_t k = 0; k < input.images.size(); ++k) {
    if (input.images[k] == nullptr || input.images[k]->channels() != 3 ||
        !input.images[k]->SameSize(width, height)) {
      throw std::invalid_argument(name + ": image " + std::to_string(k) + " must be a 3-channel image of " +
                                  std::to_string(width) + " x " + std::to_string(height));
    }
  }
  if (!input.sample_valid.empty() && input.sample_valid.size() != input.images.size()) {
    throw std::invalid_argument(name + ": " + std::to_string(input.sample_valid.size()) + " sample masks for " +
                                std::to_string(input.images.size()) + " images");
  }
}

namespace {

int NumBlocks(int width, int height, int block_size) {
  return ((width + block_size - 1) / block_size) * ((height + block_size - 1) / block_size);
}

}  // namespace

SolveJob RgbSolveJob(const PhotometricSolverOptions& options, const PhotometricSolverInput& input,
                     PhotometricSolution* solution, bool with_albedo, bool with_confidence) {
  SolveJob job;
  job.options = &options;
  job.field = input.light_field;
  job.images = &input.images;
  job.sample_valid = &input.sample_valid;
  job.region = input.region;
  job.num_lights = input.light_field->num_lights();
  job.with_albedo = with_albedo;
  job.with_confidence = with_confidence;
  job.solution = solution;
  return job;
}

int BlockPassWorkers(int requested_threads, int width, int height, int block_size) {
  return std::clamp(ResolveThreadCount(requested_threads), 1, std::max(1, NumBlocks(width, height, block_size)));
}

void RunBlockPass(int width, int height, int block_size, int num_workers, const BlockRefine& refine_block,
                  const ProgressCallback& progress, AlgorithmSummary* summary) {
  const int blocks_x = (width + block_size - 1) / block_size;
  const int num_blocks = NumBlocks(width, height, block_size);
  std::atomic<int> blocks_done{0};
  const bool finished = ParallelFor(
      num_blocks, num_workers, 4,
      [&](int first, int last, int worker) {
        for (int b = first; b < last; ++b) {
          const int bx = b % blocks_x, by = b / blocks_x;
          refine_block(bx * block_size, by * block_size, std::min(width, (bx + 1) * block_size),
                       std::min(height, (by + 1) * block_size), worker);
          ++blocks_done;
        }
      },
      progress ? std::function<bool(int)>([&](int done) { return progress(double(done) / num_blocks); })
               : std::function<bool(int)>());
  if (!finished) {
    summary->SetCancelled("cancelled after " + std::to_string(blocks_done.load()) + " of " +
                          std::to_string(num_blocks) + " blocks");
  } else {
    summary->termination = Termination::kSuccess;
    if (progress) progress(1.0);
  }
}

}  // namespace scanbench::tiled
