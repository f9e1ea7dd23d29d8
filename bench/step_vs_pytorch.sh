#!/usr/bin/env bash
# Training speed side by side: the C++ Trainer's step (train_step_bench) against the same step in PyTorch eager
# (step_vs_pytorch.py, Debian's /usr/bin/python3 with its torch 1.13) for each net and size of the CPU profile, with the
# same thread count and OMP_WAIT_POLICY=PASSIVE for both. The two sides run alternately per config (C++ first in odd
# rounds, Python first in even ones) so that both see the same load; each side's median is over all its timed steps,
# in wall time and in the process's CPU time (all threads; what other jobs on the machine inflate least).
# The parameter counts of the two sides must match (exit 1 otherwise). Prints a Markdown table.
# --same-malloc gives Python the C++ side's allocator settings (apps/cli.cc's mallopt: no mmap for large blocks, no
# trimming) through GLIBC_TUNABLES, to tell how much of a difference is the allocator's.
#   bench/step_vs_pytorch.sh BUILD_BIN [--threads 2] [--steps 20] [--warmup 5] [--rounds 2] [--batch 8]
#       [--f-widths 8,16] [--g-widths 16,32] [--sizes 64,128] [--ndf 16] [--n-layers 2] [--coeffs 80,64,80]
#       [--same-malloc]
set -euo pipefail
bin=${1:?usage: bench/step_vs_pytorch.sh BUILD_BIN [--threads T] [--steps N] ...}
shift
threads=2 steps=20 warmup=5 rounds=2 batch=8 f_widths=8,16 g_widths=16,32 sizes=64,128 ndf=16 n_layers=2
coeffs=80,64,80 py_malloc=""
while [ $# -gt 0 ]; do
  case "$1" in
    --same-malloc) py_malloc=glibc.malloc.mmap_max=0:glibc.malloc.trim_threshold=1073741824; shift; continue ;;
    --threads) threads=$2 ;; --steps) steps=$2 ;; --warmup) warmup=$2 ;; --rounds) rounds=$2 ;;
    --batch) batch=$2 ;; --f-widths) f_widths=$2 ;; --g-widths) g_widths=$2 ;; --sizes) sizes=$2 ;;
    --ndf) ndf=$2 ;; --n-layers) n_layers=$2 ;; --coeffs) coeffs=$2 ;;
    *) echo "step_vs_pytorch.sh: unknown flag $1; see the usage at the top of the script" >&2; exit 2 ;;
  esac
  shift 2
done
here=$(cd "$(dirname "$0")" && pwd)
cpp="$bin/train_step_bench"
[ -x "$cpp" ] || { echo "step_vs_pytorch.sh: $cpp is missing; build the target train_step_bench" >&2; exit 3; }
export OMP_WAIT_POLICY=PASSIVE
results=$(mktemp)
trap 'rm -f "$results"' EXIT
common=(--steps "$steps" --warmup "$warmup" --threads "$threads" --batch "$batch" --ndf "$ndf" --n-layers "$n_layers"
        --coeffs "$coeffs")
run_side() {  # side net width size
  local load; load=$(cut -d' ' -f1 /proc/loadavg)
  if [ "$1" = c++ ]; then
    "$cpp" --net "$2" --width "$3" --size "$4" "${common[@]}"
  else
    ${py_malloc:+env GLIBC_TUNABLES=$py_malloc} /usr/bin/python3 "$here/step_vs_pytorch.py" --net "$2" --width "$3" --size "$4" "${common[@]}"
  fi | sed "s/}\$/, \"load\": $load}/" >> "$results"
}
load_start=$(cut -d' ' -f1-3 /proc/loadavg)
for round in $(seq 1 "$rounds"); do
  for net in F G; do
    widths=$f_widths; [ "$net" = G ] && widths=$g_widths
    for width in ${widths//,/ }; do
      for size in ${sizes//,/ }; do
        if [ $((round % 2)) = 1 ]; then order="c++ pytorch"; else order="pytorch c++"; fi
        for side in $order; do run_side "$side" "$net" "$width" "$size"; done
      done
    done
  done
done
load_end=$(cut -d' ' -f1-3 /proc/loadavg)
/usr/bin/python3 - "$results" "$load_start" "$load_end" "$(nproc)" "${py_malloc:-glibc defaults}" <<'PY'
import collections, json, sys
rows = [json.loads(line) for line in open(sys.argv[1])]
by = collections.defaultdict(lambda: collections.defaultdict(list))
for r in rows:
    by[(r["net"], r["width"], r["size"])][r["side"]].append(r)
first = rows[0]
print(f"{first['threads']} threads, batch {first['batch']}, OMP_WAIT_POLICY {first['omp_wait_policy']}, "
      f"{len(rows) // (2 * len(by))} round(s) per side; {sys.argv[4]} CPUs; load average at start {sys.argv[2]}, "
      f"at end {sys.argv[3]}; Python's malloc: {sys.argv[5]}\n")
print("| net | config | params | C++ ms/step | PyTorch ms/step | ratio | C++ CPU ms/step | PyTorch CPU ms/step | "
      "CPU ratio | load (1 min) |\n|---|---|---|---|---|---|---|---|---|---|")
bad = []
def median(v):
    return sorted(v)[len(v) // 2]
for (net, width, size), sides in by.items():
    cpp, py = sides["c++"], sides["pytorch"]
    params_c, params_p = cpp[0]["params"], py[0]["params"]
    if params_c != params_p:
        bad.append(f"{net} width {width} {size}²: C++ {params_c}, PyTorch {params_p}")
    c = median([m for r in cpp for m in r["ms"]])
    p = median([m for r in py for m in r["ms"]])
    cc = median([m for r in cpp for m in r["cpu_ms"]])
    pcpu = median([m for r in py for m in r["cpu_ms"]])
    loads = sorted(r["load"] for r in cpp + py)
    params = " + ".join(f"{k} {v:,}" for k, v in sorted(params_c.items()))
    label = f"width {width}" if net == "F" else f"ngf {width}"
    print(f"| {net} | {label}, {size}² | {params} | {c:.1f} | {p:.1f} | {c / p:.2f} | {cc:.1f} | {pcpu:.1f} | {cc / pcpu:.2f} | {loads[0]:.2f}–{loads[-1]:.2f} |")
if bad:
    sys.exit("step_vs_pytorch.sh: the parameter counts differ: " + "; ".join(bad))
PY
