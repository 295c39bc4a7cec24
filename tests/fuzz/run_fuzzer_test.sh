#!/usr/bin/env bash
# ctest's fuzz_<harness>: an empty scratch corpus (where libFuzzer writes what it
# finds), then the harness on scratch + the committed corpus with the options given.
#   run_fuzzer_test.sh <fuzzer> <scratch folder> <committed corpus> <libFuzzer options...>
set -euo pipefail
fuzzer=$1 scratch=$2 corpus=$3
shift 3
rm -rf "$scratch"
mkdir -p "$scratch"
cd "$scratch/.."  # crash-* and leak-* files land beside the scratch folder, not in the source tree
exec "$fuzzer" "$@" "$scratch" "$corpus"
