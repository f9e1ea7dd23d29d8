#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, ASan + UBSan, no Torch) into build-fuzz/ and runs each for SECONDS on its
# committed seeds (tests/fuzz/seeds/<t>), its kept crashes (tests/fuzz/regressions/<t>) and the corpus it grew before
# (build-fuzz/corpus/<t>). A crash, a hang (-timeout) or an allocation over the limit fails the run; its input is
# copied to tests/fuzz/regressions/<t>/ (commit it: from then on every run replays it) and the message says where.
# Targets run JOBS at a time (default: every core). `make test` runs this with 15 s per target, `make fuzz
# FUZZ_SECONDS=600` for the long runs; docs/reliability.md.
# Usage: scripts/fuzz.sh SECONDS [target ...]   (targets: all of tests/fuzz/CMakeLists.txt by default)
set -uo pipefail
seconds=${1:-15}
shift || true
root=$(cd "$(dirname "$0")/.." && pwd)
build=${FUZZ_BUILD:-$root/build-fuzz}
jobs=${JOBS:-$(nproc)}
cd "$root"
bash scripts/install_deps.sh clang libclang-rt-14-dev >/dev/null || exit 1
start=$(date +%s)
if [ ! -f "$build/build.ninja" ]; then
  mkdir -p "$build"
  cmake -S . -B "$build" -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DBARESKIN_FUZZ=ON -DBARESKIN_WITH_TORCH=OFF \
    -DBARESKIN_TESTS=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo >"$build/configure.log" 2>&1 ||
    { cat "$build/configure.log"; echo "fuzz: configure failed"; exit 1; }
fi
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  read -r -a targets <<<"$(sed -n 's/^set(BARESKIN_FUZZ_TARGETS \(.*\)$/\1/p' tests/fuzz/CMakeLists.txt)"
fi
cmake --build "$build" -j "$jobs" --target "${targets[@]/#/fuzz_}" || { echo "fuzz: build failed"; exit 1; }
built=$(date +%s)
echo "fuzz: built ${#targets[@]} targets in $((built - start)) s; running each for $seconds s"

summary=$build/summary.tsv
# One target: runs it, keeps a crash's input, writes its summary row to $build/summary_<t>.tsv; exit 1 on a failure.
fuzz_one() {
  local t=$1 corpus=$build/corpus/$1 crashes=$build/crashes/$1 regressions=tests/fuzz/regressions/$1
  mkdir -p "$corpus" "$crashes"
  rm -f "$crashes"/*
  local dirs=("$corpus" "tests/fuzz/seeds/$t")
  [ -d "$regressions" ] && dirs+=("$regressions")
  local log=$build/fuzz_$t.log rc execs cov ft units result=ok
  # Each target's scratch files in a folder of its own, the same on every machine (an OBJ's "mtllib" once named
  # a file beside them).
  mkdir -p "$build/tmp/$t"
  TMPDIR=$build/tmp/$t "$build/bin/fuzz_$t" -max_total_time="$seconds" -print_final_stats=1 -timeout=10 \
    -rss_limit_mb=2048 -artifact_prefix="$crashes/" "${dirs[@]}" >"$log" 2>&1
  rc=$?
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  cov=$(grep -oE 'cov: [0-9]+' "$log" | tail -1 | cut -d' ' -f2)
  ft=$(grep -oE 'ft: [0-9]+' "$log" | tail -1 | cut -d' ' -f2)
  units=$(find "$corpus" -type f | wc -l)
  if [ $rc -ne 0 ]; then
    result=CRASH
    mkdir -p "$regressions"
    for f in "$crashes"/*; do
      [ -f "$f" ] || continue
      cp "$f" "$regressions/"
      echo "fuzz: fuzz_$t failed (exit $rc); its input is saved as $regressions/$(basename "$f") (commit it); log: $log"
    done
    grep -m1 -E "ERROR|SUMMARY|==[0-9]+==" "$log" | sed 's/^/fuzz:   /'
    ls "$crashes"/* >/dev/null 2>&1 || echo "fuzz: fuzz_$t failed (exit $rc) without an input; log: $log"
  fi
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$t" "$seconds" "${execs:-0}" "${cov:-0}" "${ft:-0}" "$units" "$result" \
    >"$build/summary_$t.tsv"
  [ $rc -eq 0 ]
}
# $jobs targets at a time (each fuzzer is one process on one core), so `make test` spends SECONDS x targets / jobs.
failed=0
running=0
for t in "${targets[@]}"; do
  if [ $running -ge "$jobs" ]; then
    wait -n || failed=1
    running=$((running - 1))
  fi
  fuzz_one "$t" &
  running=$((running + 1))
done
while [ $running -gt 0 ]; do
  wait -n || failed=1
  running=$((running - 1))
done
printf 'target\tseconds\texecutions\tcoverage\tfeatures\tcorpus\tresult\n' >"$summary"
for t in "${targets[@]}"; do cat "$build/summary_$t.tsv" >>"$summary"; done
column -t "$summary"
echo "fuzz: $(( $(date +%s) - start )) s in all (build $((built - start)) s)"
exit $failed
