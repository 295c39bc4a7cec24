#!/usr/bin/env bash
# Saves a screenshot of every page of scanbench-gui (and its export dialog) into docs/images/
# (gui-*.png): builds the GUI, starts it under a virtual X server (xvfb-run)
# and lets its --screenshot-dir tour capture and solve a session on the
# simulated bench. Usage: scripts/gui-screenshots.sh [OUTPUT_DIR] [BUILD_DIR]
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
output="${1:-$root/docs/images}"
build="${2:-$root/build}"

"$root/scripts/install-deps.sh"
cmake -S "$root" -B "$build" -G Ninja >/dev/null
cmake --build "$build" --target scanbench-gui -j"$(nproc)"

# -a: a free display number, so that parallel runs never collide.
xvfb-run -a -s "-screen 0 1400x900x24" \
  "$build/app/gui/scanbench-gui" --screenshot-dir "$output" --screenshot-size 640x424
ls -l "$output"/gui-*.png
