#!/usr/bin/env bash
# Speed against accuracy: runs `polyrad sweep` with the given arguments, then draws the
# charts from the sweep's CSV with scripts/charts.py.
#
#   ./scripts/sweep.sh SCENE --out DIR [sweep flags, e.g. --quick]
#
# The charts go to DIR/charts, or to $CHARTS_DIR. $POLYRAD names the polyrad binary to use;
# without it, the missing packages are installed and a Release build is made (scripts/build.sh).
set -euo pipefail
source "$(dirname "$0")/lib/study.sh"

out=""
args=("$@")
for ((i = 0; i < ${#args[@]}; i++)); do
  case "${args[i]}" in
    --out) out="${args[i + 1]:-}" ;;
    --out=*) out="${args[i]#--out=}" ;;
  esac
done
if [ -z "$out" ]; then
  echo "sweep.sh: usage: scripts/sweep.sh SCENE --out DIR [polyrad sweep flags]" >&2
  exit 2
fi

need_polyrad
"$POLYRAD" sweep "$@"
"${PYTHON:-/usr/bin/python3}" "$root/scripts/charts.py" "$out" --out "${CHARTS_DIR:-$out/charts}"
