#!/usr/bin/env bash
# The house, drawn from the includes, and the rules it keeps (README, "Architecture"):
#   apps/biodyn -> apps/viewer -> apps/scenarios -> capture (mocap_io/capture) ->
#   controllers | mocap_io -> muscles -> models -> sim
#   1. layers: a file includes headers of its own module or of modules below it, nothing upward,
#      and controllers and mocap_io not each other; OpenCV only in mocap_io/capture;
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

sources=$(git ls-files 'sim/*.h' 'sim/*.cc' 'models/*.h' 'models/*.cc' 'muscles/*.h' 'muscles/*.cc' \
  'controllers/*.h' 'controllers/*.cc' \
  'mocap_io/*.h' 'mocap_io/*.cc' 'apps/*.h' 'apps/*.cc')

# 1. Layers: every '#include "biodyn/<module>/...' of a source, its module and layer (one awk pass).
layers=$(grep -n '#include "biodyn/' $sources | awk -F: '
  function module_of(path) {
    if (path ~ /^apps\/scenarios\//) return "scenarios"
    if (path ~ /^apps\/viewer\//) return "viewer"
    if (path ~ /^apps\/biodyn\//) return "biodyn"
    if (path ~ /^mocap_io\/capture\//) return "capture"
    split(path, part, "/"); return part[1]
  }
  BEGIN { layer["sim"] = 0; layer["models"] = 1; layer["muscles"] = 2; layer["controllers"] = 3
          layer["mocap_io"] = 3; layer["capture"] = 3.5; layer["scenarios"] = 4; layer["viewer"] = 5; layer["biodyn"] = 6 }
  {
    from = module_of($1); inc = $0; sub(/^[^#]*#include /, "", inc)
    to = inc; sub(/^"biodyn\//, "", to); sub(/\/.*/, "", to)
    if (to == from) next
    edges[from " -> " to]++
    if (!(to in layer) || layer[to] >= layer[from]) {
      print $1 ":" $2 ": layers: " from " includes " to " (upward or sideways): " inc; bad = 1
    }
  }
  END {
    print "house (module -> module it includes: number of includes):"
    for (e in edges) print "  " e ": " edges[e] | "sort"
    close("sort")
    exit bad
  }')
[ $? -ne 0 ] && status=1
echo "$layers"
opencv=$(grep -n '#include <opencv2/' $sources | grep -v '^mocap_io/capture/' | sed 's/$/: layers: OpenCV outside mocap_io\/capture/')
[ -n "$opencv" ] && { echo "$opencv"; status=1; }

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
