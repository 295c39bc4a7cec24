#!/usr/bin/env bash
# compare-builds.sh OLD_BINARY NEW_BINARY WORK_DIR
# Behaviour kept across a change (a refactoring, a faster kernel): solves and
# exports a fixed set of small simulated sessions (made once by OLD_BINARY:
# twill, draped, satin, cloth, a ColorChecker) with every method and the main
# options, and DiLiGenT's ball when ../shared/data is there, with both binaries,
# and compares every result and export file (scripts/compare_outputs.py): maps
# byte for byte (the run stamps and EXR/TIFF DateTime blanked), reports without
# their timings, dates and paths. Prints one line per case and
# "COMPARE: EQUAL" (exit 0) or "COMPARE: DIFFERENT" (exit 1). About 4 min on
# two cores. COMPARE_ONLY=1 compares what WORK_DIR/new already holds; the old
# binary's outputs in WORK_DIR/old are made once and kept.
set -uo pipefail
[ $# -eq 3 ] || { echo "usage: $0 OLD_BINARY NEW_BINARY WORK_DIR" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)
base_bin=$(realpath "$1"); bin=$(realpath "$2"); work=$(realpath -m "$3")
for b in "$base_bin" "$bin"; do [ -x "$b" ] || { echo "compare-builds: $b: not an executable" >&2; exit 2; }; done
ref=$work/old
out=$work/new
sessions=$work/sessions
mkdir -p "$ref" "$out"
lock=$work/.make.lock
diligent=$(realpath -m "$here/../../shared/data/diligent/ballPNG")
# The sessions: made once by the old binary.
(
  flock 9
  if [ ! -f "$sessions/.done" ]; then
    rm -rf "$sessions"; mkdir -p "$sessions"
    "$base_bin" simulate "$sessions/twill" --width 320 --height 212 --seed 3 >/dev/null || exit 1
    "$base_bin" simulate "$sessions/draped" --width 320 --height 212 --seed 4 --fold-amplitude 25 >/dev/null || exit 1
    "$base_bin" simulate "$sessions/satin" --width 320 --height 212 --seed 5 --material satin >/dev/null || exit 1
    "$base_bin" simulate "$sessions/cloth" --width 320 --height 212 --seed 6 --material cloth >/dev/null || exit 1
    "$base_bin" simulate "$sessions/chart" --width 320 --height 212 --seed 7 --sample colorchecker >/dev/null || exit 1
    touch "$sessions/.done"
  fi
) 9>"$lock" || { echo "compare-builds: could not make the sessions with $base_bin"; exit 2; }

# case name | session | solve options | export presets (space separated, "-" = none)
cases=(
  "twill-default|twill||png16 exr gltf unreal unity-hdrp tiff16"
  "twill-tileable|twill|--label t|png16:--tileable"
  "twill-jacobi|twill|--method jacobi_svd|-"
  "twill-normal-eq|twill|--method normal_equations|-"
  "twill-qr|twill|--method qr|-"
  "twill-robust|twill|--method robust_irls|-"
  "twill-sparse|twill|--method sparse_bayesian|-"
  "twill-lobe|twill|--method diffuse_lobe|png16"
  "twill-bayer|twill|--bayer-domain|-"
  "twill-noblend|twill|--no-bayer-blend --no-coherent-lobe|-"
  "twill-f32|twill|--float32-maps|exr"
  "draped-default|draped||png16"
  "draped-nodepth|draped|--no-depth-refine|-"
  "satin-default|satin||gltf"
  "satin-sheen|satin|--sheen|-"
  "cloth-default|cloth||unreal"
  "cloth-sheen|cloth|--sheen --no-coherent-sheen|-"
  "chart-default|chart||png16"
)

run_cases() {  # run_cases BINARY DEST
  local b=$1 dest=$2
  for c in "${cases[@]}"; do
    IFS='|' read -r name session solve_opts exports <<< "$c"
    local d=$dest/$name
    rm -rf "$d"; mkdir -p "$d"
    cp -r "$sessions/$session" "$d/session"
    # shellcheck disable=SC2086
    if ! "$b" solve "$d/session" --threads 2 $solve_opts > "$d/solve.log" 2>&1; then echo "$name: solve failed (see $d/solve.log)"; continue; fi
    if [ "$exports" != "-" ]; then
      local result; result=$(ls -d "$d"/session/results/*/ | head -1)
      for e in $exports; do
        local preset=${e%%:*} extra=""
        [ "$e" != "$preset" ] && extra=${e#*:}
        # shellcheck disable=SC2086
        "$b" export "$result" --preset "$preset" $extra > "$d/export-$preset.log" 2>&1 || echo "$name: export $preset failed (see $d/export-$preset.log)"
      done
    fi
  done
  # DiLiGenT's ball, default method and the least-squares baseline.
  if [ -d "$diligent" ]; then
    rm -rf "$dest/diligent"; mkdir -p "$dest/diligent"
    "$b" solve-dataset "$diligent" --output "$dest/diligent/ball" --lsq-baseline > "$dest/diligent/solve.log" 2>&1 || echo "diligent: solve-dataset failed"
  fi
}

(
  flock 9
  if [ ! -f "$ref/.done" ]; then
    rm -rf "$ref"; mkdir -p "$ref"
    run_cases "$base_bin" "$ref"
    touch "$ref/.done"
  fi
) 9>"$lock"

[ "${COMPARE_ONLY:-0}" = 1 ] || run_cases "$bin" "$out"
status=0
for c in "${cases[@]}" "diligent|"; do
  name=${c%%|*}
  [ -d "$ref/$name" ] || continue
  a=$ref/$name; b=$out/$name
  if [ "$name" != diligent ]; then a=$a/session; b=$b/session; fi
  # frames are copies of the same session; compare results and exports only.
  ok=1; : > "$out/$name.diff"
  if [ "$name" != diligent ]; then
    for sub in results exports; do
      [ -d "$a/$sub" ] || continue
      python3 "$here/compare_outputs.py" "$a/$sub" "$b/$sub" >> "$out/$name.diff" 2>&1 || ok=0
    done
  else
    python3 "$here/compare_outputs.py" "$a" "$b" > "$out/$name.diff" 2>&1 || ok=0
  fi
  if [ $ok = 1 ]; then echo "$name: equal"; else echo "$name: DIFFERENT"; cat "$out/$name.diff"; status=1; fi
done
if [ $status = 0 ]; then echo "COMPARE: EQUAL"; else echo "COMPARE: DIFFERENT"; fi
exit $status
