// Main-memory bandwidth of this machine, STREAM-like: read (a sum), copy,
// and triad (a = b + s * c) over arrays far larger than the caches, on 1
// and 2 threads. The solver's bandwidth limit in docs/solver.md is derived
// from these figures (bytes per pixel / GB/s).
//
//   build/benchmarks/memory_bandwidth_benchmark
//
// Figures, not pass/fail: bytes_per_second counts the bytes each kernel
// reads and writes (not the write-allocate reads of the destination).
#include <cstddef>
#include <vector>

#include <benchmark/benchmark.h>

namespace scanbench {
namespace {

// 64 Mi floats (256 MB) an array: 3 of them are many times any cache.
constexpr size_t kFloats = size_t(64) << 20;

struct Arrays {
  Arrays() : a(kFloats, 1.0f), b(kFloats, 2.0f), c(kFloats, 3.0f) {}
  std::vector<float> a, b, c;
};

Arrays& Data() {
  static Arrays arrays;
  return arrays;
}

// This thread's share [begin, end) of the arrays.
void Share(const benchmark::State& state, size_t* begin, size_t* end) {
  const size_t part = kFloats / state.threads();
  *begin = part * state.thread_index();
  *end = *begin + part;
}

void BM_Read(benchmark::State& state) {
  Arrays& d = Data();
  size_t begin, end;
  Share(state, &begin, &end);
  for (auto _ : state) {
    // Eight partial sums: a reduction the compiler may vectorise without -ffast-math.
    float sums[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    for (size_t i = begin; i < end; i += 8) {
      for (int j = 0; j < 8; ++j) sums[j] += d.a[i + j];
    }
    benchmark::DoNotOptimize(sums);
  }
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(end - begin) * int64_t(sizeof(float)));
}

void BM_Copy(benchmark::State& state) {
  Arrays& d = Data();
  size_t begin, end;
  Share(state, &begin, &end);
  for (auto _ : state) {
    float* __restrict out = d.c.data();
    const float* __restrict in = d.a.data();
    for (size_t i = begin; i < end; ++i) out[i] = in[i];
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(end - begin) * int64_t(2 * sizeof(float)));
}

void BM_Triad(benchmark::State& state) {
  Arrays& d = Data();
  size_t begin, end;
  Share(state, &begin, &end);
  for (auto _ : state) {
    float* __restrict out = d.a.data();
    const float* __restrict x = d.b.data();
    const float* __restrict y = d.c.data();
    for (size_t i = begin; i < end; ++i) out[i] = x[i] + 3.0f * y[i];
    benchmark::ClobberMemory();
  }
  state.SetBytesProcessed(int64_t(state.iterations()) * int64_t(end - begin) * int64_t(3 * sizeof(float)));
}

BENCHMARK(BM_Read)->Threads(1)->Threads(2)->UseRealTime()->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK(BM_Copy)->Threads(1)->Threads(2)->UseRealTime()->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK(BM_Triad)->Threads(1)->Threads(2)->UseRealTime()->Unit(benchmark::kMillisecond)->MinTime(1.0);

}  // namespace
}  // namespace scanbench
