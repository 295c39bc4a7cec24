#!/usr/bin/env bash
# The libFuzzer harnesses of tests/fuzz (docs/robustness.md, "Fuzzing"), in a
# clang build folder of their own (build-fuzz, -DSCANBENCH_FUZZ=ON).
#
#   scripts/fuzz.sh build              configure build-fuzz and build every harness
#   scripts/fuzz.sh ci                 build, then ctest -L fuzz: each harness replays its
#                                      committed corpus and runs briefly (what scripts/test.sh runs)
#   scripts/fuzz.sh run [-t SECONDS] [HARNESS...]
#                                      long runs, one harness after another (default 600 s each,
#                                      every harness), at nice 19, on a working corpus in
#                                      build-fuzz/corpus/<harness> seeded from the committed one;
#                                      crashes land in build-fuzz/findings/<harness>/ and the run
#                                      goes on (libFuzzer's -fork=1 -ignore_crashes=1). Prints
#                                      libFuzzer's last figures (execs, cov, ft, crashes) per harness.
#   scripts/fuzz.sh seeds              rewrite tests/fuzz/corpus's seeds with make_seeds
#
# A crash found: fix it, then copy the input into tests/fuzz/corpus/<harness>/ as
# regression-<what>, so that ctest replays it from then on.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${SCANBENCH_FUZZ_BUILD:-build-fuzz}
harnesses=(raw_decode session_json rig_json calibration_set dataset_folder result_map led_host)
# Leaks inside Debian's libraries, each with its reason (tests/fuzz/lsan.supp).
export LSAN_OPTIONS="suppressions=$PWD/tests/fuzz/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"

find_clang() {
  for cxx in clang++-14 clang++; do
    if command -v "$cxx" >/dev/null; then echo "$cxx"; return; fi
  done
  echo "fuzz: no clang++ (scripts/install-deps.sh installs clang-14)" >&2
  exit 1
}

configure_and_build() {
  local cxx
  cxx=$(find_clang)
  cmake -S . -B "$build" -G Ninja -DSCANBENCH_FUZZ=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo \
        -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_C_COMPILER="${cxx/++/}" >/dev/null
  local targets=(make_seeds)
  for h in "${harnesses[@]}"; do targets+=("${h}_fuzz"); done
  cmake --build "$build" -j2 --target "${targets[@]}"
}

run_long() {
  local seconds=600
  if [ "${1:-}" = "-t" ]; then seconds=$2; shift 2; fi
  local chosen=("$@")
  [ ${#chosen[@]} -eq 0 ] && chosen=("${harnesses[@]}")
  for h in "${chosen[@]}"; do
    local work="$build/corpus/$h" findings="$build/findings/$h" log="$build/findings/$h.log"
    mkdir -p "$work" "$findings"
    # shellcheck disable=SC2046  # the options file holds several words
    (cd "$findings" && nice -n 19 "../../tests/fuzz/${h}_fuzz" $(cat "../../tests/fuzz/${h}_fuzz.args") \
        -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
        -fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
        "../../corpus/$h" "../../../tests/fuzz/corpus/$h") >"$log" 2>&1 || true
    echo "== $h ($seconds s): $(grep -E '^#[0-9]+' "$log" | tail -1)"
    # The coverage the corpus reached, replayed without fork mode (whose cov
    # counts differ): libFuzzer's INITED line, comparable between harnesses.
    # shellcheck disable=SC2046
    echo "   corpus replayed: $(cd "$findings" && "../../tests/fuzz/${h}_fuzz" $(cat "../../tests/fuzz/${h}_fuzz.args") \
        -runs=0 "../../corpus/$h" "../../../tests/fuzz/corpus/$h" 2>&1 | grep -E 'INITED' | tail -1)"
    local found=("$findings"/crash-* "$findings"/leak-* "$findings"/timeout-* "$findings"/oom-*)
    local kept=()
    for f in "${found[@]}"; do [ -e "$f" ] && kept+=("   ${f##*/}"); done
    if [ ${#kept[@]} -eq 0 ]; then echo "   no crash, leak, timeout or OOM"; else printf '%s\n' "${kept[@]}"; fi
  done
}

case "${1:-}" in
  build) configure_and_build ;;
  ci)
    configure_and_build
    ctest --test-dir "$build" -L fuzz -j2 --output-on-failure ;;
  run) shift; run_long "$@" ;;
  seeds)
    configure_and_build
    "$build/tests/fuzz/make_seeds" tests/fuzz/corpus ;;
  *) sed -n '2,18p' "$0"; exit 2 ;;
esac
