#!/usr/bin/env bash
# Whole mm-build on already-registered subjects (maps at 1K), with the time per stage and the peak memory.
# Subjects: SUBJECTS identities of the `scan synth` model on the default template, each moved by a random rigid motion,
# written as registered meshes (mesh.ply); their diffuse maps are the demo's transferred 1K maps, cycled (so the
# appearance model has at most as many components as the demo has subjects, minus one).
# Usage: bench/mm_build.sh [build/bin] [template dir] [registered demo dir] [subjects]
set -euo pipefail
bin=${1:-build/bin}
template=${2:-out/demo/template}
demo=${3:-out/demo/registered}
subjects=${4:-180}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
[ -d "$demo" ] || { echo "run 'make demo' first (needs $demo)"; exit 1; }
"$bin/mm_pca_bench" "$template" "$subjects" "$work" 1 --write-registered > /dev/null
maps=("$demo"/subject_*/diffuse.png)
i=0
for d in "$work"/registered/subject_*; do
  ln -s "$(realpath "${maps[$((i % ${#maps[@]}))]}")" "$d/diffuse.png"
  i=$((i + 1))
done
k=$(( ${#maps[@]} - 1 ))
/usr/bin/time -v "$bin/bareskin" mm-build -q --template "$template" --registered "$work/registered" \
  -o "$work/model.safetensors" --appearance-components "$k" 2> "$work/time.txt"
peak=$(grep "Maximum resident" "$work/time.txt" | awk '{print $NF}')
/usr/bin/python3 - "$work/model.build.json" "$peak" <<'PY'
import json, sys
b = json.load(open(sys.argv[1]))
s = b["seconds"]
print(f"mm-build, {b['subjects']} registered subjects (65k vertices, 1K diffuse maps), {b['components']} components: "
      f"{s['total']:.1f} s wall, peak RSS {int(sys.argv[2]) / 1024:.0f} MB")
print("  " + ", ".join(f"{k} {v:.2f} s" for k, v in s.items() if k != "total"))
PY
