#!/usr/bin/env bash
# Repository hygiene that no compiler sees: merge-conflict markers left in tracked files, and
# links in the Markdown docs that point at a missing file or a missing heading.
set -uo pipefail
root="${1:?usage: repo_hygiene_test.sh <source dir>}"
cd "$root" || exit 1
failures=0

if [ -d .git ] || [ -f .git ]; then
  mapfile -t files < <(git ls-files | grep -v '^third_party/')
else
  mapfile -t files < <(find . -type f -not -path './third_party/*' -not -path './build*' \
                         -not -path '*/node_modules/*' | sed 's|^\./||')
fi

# 1. Conflict markers: a line that is exactly a marker (the ======= line alone is a Markdown
#    heading underline, so only the <<<<<<< and >>>>>>> lines count).
for f in "${files[@]}"; do
  [ -f "$f" ] || continue
  if grep -nE '^(<<<<<<<|>>>>>>>)( |$)' "$f" >/tmp/hygiene.$$ 2>/dev/null; then
    while IFS= read -r line; do
      echo "FAIL: $f:${line%%:*}: merge-conflict marker left in the file"
    done </tmp/hygiene.$$
    failures=$((failures + 1))
  fi
done
rm -f /tmp/hygiene.$$

# GitHub's heading anchor: lower case, punctuation other than '-' and '_' dropped, spaces to '-'.
anchors_of() {
  grep -E '^#{1,6} ' "$1" | sed -E 's/^#+ +//; s/[[:space:]]+$//' | tr '[:upper:]' '[:lower:]' |
    sed -E 's/[^a-z0-9 _-]//g; s/ /-/g'
}

# 2. Relative links in Markdown: the file exists, and a #fragment names a heading of it.
for f in "${files[@]}"; do
  case "$f" in *.md) ;; *) continue ;; esac
  [ -f "$f" ] || continue
  dir=$(dirname "$f")
  while IFS= read -r link; do
    target="${link%%#*}"
    fragment=""
    [[ "$link" == *"#"* ]] && fragment="${link#*#}"
    case "$target" in http:*|https:*|mailto:*) continue ;; esac
    if [ -z "$target" ]; then path="$f"; else path="$dir/$target"; fi
    if [ ! -e "$path" ]; then
      echo "FAIL: $f: link '$link' points at a missing file ($path)"
      failures=$((failures + 1))
      continue
    fi
    if [ -n "$fragment" ] && [[ "$path" == *.md ]]; then
      if ! anchors_of "$path" | grep -qxF "$fragment"; then
        echo "FAIL: $f: link '$link': $path has no heading with anchor '#$fragment'"
        failures=$((failures + 1))
      fi
    fi
  done < <(grep -oE '\]\([^) ]+\)' "$f" | sed -E 's/^\]\(//; s/\)$//' | grep -vE '^(https?|mailto):')
done

if [ "$failures" -gt 0 ]; then
  echo "$failures hygiene problem(s)"
  exit 1
fi
echo "repository hygiene: ${#files[@]} files, no conflict markers, every Markdown link resolves"
