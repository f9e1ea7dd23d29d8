# Sourced by every demo section (scripts/demo/NN_*.sh <bin> <out>): strict mode, the paths every section uses, the
# shared output folders, and `timed NAME command...`, which runs a command and appends its wall time to
# <out>/timings.txt (the report's timing table).
set -euo pipefail
bin=${1:-build/bin}
out=${2:-out/demo}
bareskin="$bin/bareskin"
py=/usr/bin/python3
mkdir -p "$out/img" "$out/sections"
timed() {
  local name=$1 start=$EPOCHREALTIME
  shift
  "$@"
  printf '%-12s %7.1f s\n' "$name" "$($py -c "import sys; print(float(sys.argv[2]) - float(sys.argv[1]))" \
    "$start" "$EPOCHREALTIME")" >> "$out/timings.txt"
}
