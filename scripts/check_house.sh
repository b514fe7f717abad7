#!/usr/bin/env bash
# The house, drawn from the includes, and the rules it keeps (README, "Architecture"):
#   apps/biodyn -> apps/viewer -> apps/scenarios -> controllers | mocap_io -> models -> sim
#   1. layers: a file includes headers of its own module or of modules below it, nothing upward,
#      and controllers and mocap_io not each other;
#   2. no function longer than MAX_FUNCTION_LINES (pmccabe's line count, tests excluded);
#   3. the sources are formatted as .clang-format says (clang-format --dry-run).
# Prints the module graph it found. Exit 0 when every rule holds, 1 otherwise (each breach is
# named: file, line, rule). Usage: scripts/check_house.sh [--no-format]
set -uo pipefail
cd "$(dirname "$0")/.."
MAX_FUNCTION_LINES=150
check_format=1
[ "${1:-}" = "--no-format" ] && check_format=0
status=0

# The module of a path, and its layer (higher may include lower).
module_of() {
  case "$1" in
    sim/*) echo sim ;;
    models/*) echo models ;;
    controllers/*) echo controllers ;;
    mocap_io/*) echo mocap_io ;;
    apps/scenarios/*) echo scenarios ;;
    apps/viewer/*) echo viewer ;;
    apps/biodyn/*) echo biodyn ;;
    *) echo "" ;;
  esac
}
layer_of() {
  case "$1" in
    sim) echo 0 ;; models) echo 1 ;; controllers | mocap_io) echo 2 ;;
    scenarios) echo 3 ;; viewer) echo 4 ;; biodyn) echo 5 ;; *) echo -1 ;;
  esac
}

sources=$(git ls-files 'sim/*.h' 'sim/*.cc' 'models/*.h' 'models/*.cc' 'controllers/*.h' 'controllers/*.cc' \
  'mocap_io/*.h' 'mocap_io/*.cc' 'apps/*.h' 'apps/*.cc')

# 1. Layers.
declare -A edges
for f in $sources; do
  from=$(module_of "$f")
  while IFS=: read -r line inc; do
    to=$(echo "$inc" | sed -E 's|.*"biodyn/([a-z_]+)/.*|\1|')
    [ "$to" = "$from" ] && continue
    edges["$from -> $to"]=$(( ${edges["$from -> $to"]:-0} + 1 ))
    lf=$(layer_of "$from") lt=$(layer_of "$to")
    if [ "$lt" -lt 0 ] || [ "$lt" -ge "$lf" ]; then
      echo "$f:$line: layers: $from includes $to (upward or sideways): ${inc#*#include }"
      status=1
    fi
  done < <(grep -n '#include "biodyn/' "$f" | sed -E 's/^([0-9]+):/\1:/')
done
echo "house (module -> module it includes: number of includes):"
for e in "${!edges[@]}"; do echo "  $e: ${edges[$e]}"; done | sort

# 2. Function length (pmccabe reads C++98 namespaces: `namespace a::b` is spelled a__b for it).
if command -v pmccabe > /dev/null; then
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
  longest=0
  for f in $(echo "$sources" | grep '\.cc$'); do
    sed -E '/^namespace /s/::/__/g' "$f" > "$tmp/unit.cc"
    while read -r _ _ _ first lines where; do
      [ "$lines" -gt "$longest" ] && longest=$lines
      if [ "$lines" -gt "$MAX_FUNCTION_LINES" ]; then
        echo "$f:$first: function length: ${where#*: } has $lines lines (at most $MAX_FUNCTION_LINES)"
        status=1
      fi
    done < <(pmccabe "$tmp/unit.cc" 2> /dev/null)
  done
  echo "longest function: $longest lines (at most $MAX_FUNCTION_LINES)"
else
  echo "function length: pmccabe is missing (scripts/install_deps.sh installs it)"
  status=1
fi

# 3. Formatting.
if [ "$check_format" = 1 ]; then
  if command -v clang-format > /dev/null; then
    all=$(git ls-files '*.h' '*.cc')
    if ! clang-format --dry-run --Werror $all 2> "${tmp:-/tmp}/format.txt"; then
      grep -E '^[^ ].*: (error|warning):' "${tmp:-/tmp}/format.txt" | cut -d: -f1 | sort | uniq -c |
        awk '{print $2 ": format: " $1 " places differ from .clang-format (clang-format -i fixes them)"}'
      status=1
    else
      echo "format: every source as .clang-format says"
    fi
  else
    echo "format: clang-format is missing (scripts/install_deps.sh installs it)"
    status=1
  fi
fi
exit $status
