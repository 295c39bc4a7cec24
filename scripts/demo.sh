#!/usr/bin/env bash
# The main job: install what is missing, build, and run a scan on the
# simulated rig end to end (simulate -> decode -> solve -> maps + report).
# Usage: scripts/demo.sh [output-folder] [extra `scanbench demo` options]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build build --target scanbench_cli
output="${1:-scanbench-demo}"
shift || true
build/app/cli/scanbench demo --output "$output" "$@"
