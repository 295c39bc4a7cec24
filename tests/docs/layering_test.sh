#!/usr/bin/env bash
# The layers of docs/architecture.md, checked against the includes: a library's
# sources (and headers) include only from its own folder and the layers below it.
#   core <- solver <- calibration;  core <- maps;  calibration, maps <- pipeline
#   pipeline <- app/io <- app/session;  calibration <- app/sim;  app/* <- app/controllers <- app/cli, app/gui
# Heavy dependencies (OpenCV, LibRaw, gphoto2, OIIO, ...) stay out of public
# headers (Qt is the GUI's own API). Usage: layering_test.sh REPO_ROOT
set -euo pipefail
cd "$1"

# folder | the include prefixes it may use besides its own (space separated)
rules=(
  "core|"
  "solver|core"
  "calibration|core solver"
  "maps|core"
  "pipeline|core solver calibration maps"
  "app/io|core solver calibration maps pipeline"
  "app/session|core solver calibration maps pipeline app/io"
  "app/sim|core solver calibration"
  "app/devices|core solver calibration maps pipeline app/io app/sim firmware/protocol"
  "app/controllers|core solver calibration maps pipeline app/io app/session app/sim app/devices"
  "app/cli|core solver calibration maps pipeline app/io app/session app/sim app/devices app/controllers firmware/protocol"
  "app/gui|core solver calibration maps pipeline app/io app/session app/sim app/devices app/controllers"
  "firmware|"
)

failures=0
for rule in "${rules[@]}"; do
  folder=${rule%%|*}
  allowed="$folder ${rule#*|}"
  while IFS= read -r hit; do
    [ -n "$hit" ] || continue
    file=${hit%%:*}
    included=$(sed -E 's/.*#include "([^"]+)".*/\1/' <<< "${hit#*:}")
    ok=0
    for prefix in $allowed; do
      case "$included" in "$prefix"/*) ok=1 ;; esac
    done
    # generated headers and the library's own neighbours without a folder
    case "$included" in */*) ;; *) ok=1 ;; esac
    if [ $ok = 0 ]; then
      echo "layering: $file includes \"$included\": $folder may include only from: $allowed"
      failures=$((failures + 1))
    fi
  done < <(grep -rHE '^\s*#\s*include "' "$folder" --include='*.h' --include='*.cc' --include='*.cpp' || true)
done

# A folder named by no rule is a layer the docs do not know.
for folder in core solver calibration maps pipeline app/* firmware; do
  [ -d "$folder" ] || continue
  known=0
  for rule in "${rules[@]}"; do [ "${rule%%|*}" = "$folder" ] && known=1; done
  if [ $known = 0 ]; then echo "layering: $folder has no rule here (add it, and to docs/architecture.md)"; failures=$((failures + 1)); fi
done

# Heavy dependencies stay private: a header that includes one is a library's
# own (included only by the .cc files of its folder and by tests), never a public one.
heavy='#\s*include <(opencv2|libraw|gphoto2|OpenImageIO|Imath|OpenEXR|tiffio|libusb|simavr|libserialport|openssl|nlohmann|matio)'
while IFS= read -r header; do
  [ -n "$header" ] || continue
  folder=$(dirname "$header")
  while IFS= read -r user; do
    [ -n "$user" ] || continue
    if [ "$(dirname "$user")" != "$folder" ] || [[ "$user" == *.h ]]; then
      echo "layering: $user includes $header, which includes a heavy dependency: keep it out of public headers"
      failures=$((failures + 1))
    fi
  done < <(grep -rlE "#\s*include \"$header\"" core solver calibration maps pipeline app firmware --include='*.h' --include='*.cc' | grep -v "^$header\$" || true)
done < <(grep -rlE "$heavy" core solver calibration maps pipeline app firmware --include='*.h' | grep -v '^app/gui/' || true)

if [ $failures -gt 0 ]; then
  echo "layering: $failures include(s) against the layers of docs/architecture.md"
  exit 1
fi
echo "layering: every include follows the layers"
