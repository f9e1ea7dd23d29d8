#!/usr/bin/env bash
# Times `scan synth` (geometry + four maps) per subject at 2K and, for one subject, at 16K, with peak memory.
# Usage: bench/scan_synth.sh [build/bin] [template dir] [subjects at 2K]
set -euo pipefail
bin=${1:-build/bin}
template=${2:-out/demo/template}
count=${3:-8}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
[ -f "$template/face.obj" ] || "$bin/bareskin" template -q -o "$template"
measure() {  # measure LABEL args...: prints wall seconds and peak RSS
  local label=$1
  shift
  /usr/bin/time -f "%e %M" -o "$work/time" "$bin/bareskin" scan synth -q --template "$template" "$@"
  read -r wall rss < "$work/time"
  printf '%-34s %8.1f s wall %8.0f MB peak RSS\n' "$label" "$wall" "$((rss / 1024))"
  echo "$wall"  > "$work/last"
}
measure "$count subjects, 2048² PNG16" --count "$count" --res 2048 -o "$work/a"
per=$(/usr/bin/python3 -c "import sys; print(f'{float(sys.argv[1]) / int(sys.argv[2]):.2f}')" "$(cat "$work/last")" "$count")
echo "per subject (2 in parallel on 2 cores): $per s; 180 subjects ≈ $(/usr/bin/python3 -c "print(f'{180 * $per / 60:.1f}')") min"
measure "1 subject, geometry only" --count 1 --res 0 -o "$work/b"
measure "1 subject, 2048² PNG16" --count 1 --res 2048 -o "$work/c"
measure "1 subject, 16384² PNG16" --count 1 --res 16384 -o "$work/d"
du -sh "$work/d/subject_0000"/*.png | sed 's/^/  /'
