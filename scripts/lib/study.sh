# Sourced by the study scripts (scripts/*_study.sh, sweep.sh): what each needs before its runs.
#
#   source "$(dirname "$0")/lib/study.sh"   # sets $root, the checkout
#   need_polyrad                             # sets $POLYRAD, unless given: a Release build
#   rays=$(report_value out/x.json gather rays)
#
# The build goes through scripts/deps.sh and scripts/build.sh, as ./scripts/test.sh does, so a
# study runs on a fresh machine too.

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"

need_polyrad() {
  [ -n "${POLYRAD:-}" ] && return 0
  "$root/scripts/deps.sh"
  POLYRAD="$root/$(cd "$root" && BUILD_TYPE=Release ./scripts/build.sh | tail -n 1)/src/polyrad"
}

# report_value REPORT KEY...: the value at that path of keys in a JSON report.
report_value() {
  /usr/bin/python3 -c 'import json, sys
v = json.load(open(sys.argv[1]))
for k in sys.argv[2:]: v = v[k]
print(v)' "$@"
}
