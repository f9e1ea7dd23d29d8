#!/usr/bin/env bash
# Shape PCA, ours (Gram matrix, float64) vs numpy's SVD on the same data, side by side: 180 identities of the
# `scan synth` model on the default template (~65k vertices), 120 components. Prints both times, the ratio, the largest
# principal angle between the subspaces and the largest relative difference of the variances.
# Usage: bench/mm_pca.sh [build/bin] [template dir] [subjects] [components]
set -euo pipefail
bin=${1:-build/bin}
template=${2:-out/demo/template}
subjects=${3:-180}
components=${4:-120}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
[ -f "$template/face.obj" ] || "$bin/bareskin" template -q -o "$template"
echo "$(nproc) cores; numpy $(/usr/bin/python3 -c "import numpy; print(numpy.__version__)")"
line=$("$bin/mm_pca_bench" "$template" "$subjects" "$work" "$components")
echo "$line"
ours=$(echo "$line" | sed -E 's/.*ours ([0-9.]+) s.*/\1/')
/usr/bin/python3 "$(dirname "$0")/mm_pca.py" "$work" "$ours"
