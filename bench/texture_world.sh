# Sourced by the texture benches (bench/cpu_reference_texture.sh, bench/texture_4k.sh, bench/texture_run_more.sh):
# the helpers they share. Needs
# $bareskin, $demo, $model, $out, $py, $here and $name (the script's name for its messages) set by the caller.

cpu() {  # cpu NAME command...: runs it, appends NAME, its CPU seconds (user, system) and wall seconds to $out/cpu.txt
  local stage=$1
  shift
  /usr/bin/time -f "$stage %U %S %e" -a -o "$out/cpu.txt" "$@"
}

# texture_world SUBJECTS SEED TRUTH_RES SPLIT_TO_CHECK make-dataset flags...: `scan synth` subjects with true maps at
# TRUTH_RES, "registered" from their truth (tests/python/truth_registered.py: the template on the true
# correspondence, the true maps in the template UV), then `texgen make-dataset` into $out/data. Each step is skipped
# when its output is complete.
texture_world() {
  local subjects=$1 seed=$2 truth_res=$3 check=$4
  shift 4
  if [ ! -f "$out/scans/manifest.json" ]; then
    echo "$name: scan synth ($subjects subjects, true maps at $truth_res)" >&2
    cpu synth "$bareskin" -q --threads 2 scan synth --template "$demo/template" --count "$subjects" --seed "$seed" \
      --vertices 20000 --res 256 --truth-res "$truth_res" --holes -o "$out/scans.tmp"
    rm -rf "$out/scans" && mv "$out/scans.tmp" "$out/scans"
  fi
  if [ ! -f "$out/registered/.complete" ]; then
    $py "$here/../tests/python/truth_registered.py" "$demo/template/face.obj" "$out/scans" "$out/registered" "*.png"
    touch "$out/registered/.complete"
  fi
  if [ ! -f "$out/data/$check/manifest.json" ] || ! grep -q '"complete": true' "$out/data/$check/manifest.json"; then
    echo "$name: texgen make-dataset" >&2
    cpu data "$bareskin" -q --threads 2 texgen make-dataset "$out/registered" --model "$model" -o "$out/data" "$@"
  fi
}

train() {  # train RUN command...: one training, resumed when its checkpoint exists, skipped when it finished
  local run=$1
  shift
  [ -f "$run/.complete" ] && return 0
  local resume=()
  [ -f "$run/checkpoint.safetensors" ] && resume=(--resume)
  echo "$name: $(basename "$run")" >&2
  cpu "$(basename "$run")" "$bareskin" -q --threads 2 "$@" -o "$run" "${resume[@]}"
  touch "$run/.complete"
}

# subject_faces SPLIT PER SEED DEST [test]: `texgen faces` photos (makeup, light, pose, occluders) of the texture
# world's SPLIT subjects ($out/data/SPLIT), PER of each and PER of the one 3DMM identity texgen faces needs beside
# them, all in DEST/train, or the subjects' in DEST/test with "test". Their folders are linked under
# $out/SPLIT_registered. Skipped when DEST is complete.
subject_faces() {
  local split=$1 per=$2 seed=$3 dest=$4 held=${5:-train}
  [ -f "$dest/.complete" ] && return 0
  local subjects n test=0
  subjects=$($py "$here/../scripts/demo/14_texture_find.py" --subjects "$out/data/$split")
  rm -rf "$dest" "$out/${split}_registered" && mkdir -p "$out/${split}_registered"
  for s in $subjects; do ln -s "$(cd "$out/registered/$s" && pwd)" "$out/${split}_registered/$s"; done
  n=$(echo $subjects | wc -w)
  [ "$held" = test ] && test=$n
  cpu "$(basename "$dest")" "$bareskin" -q --threads 2 texgen faces --registered "$out/${split}_registered" \
    --model "$model" --mm-subjects 1 --count $((per * n + per)) --val 0 --test "$test" --seed "$seed" --align truth \
    -o "$dest"
  touch "$dest/.complete"
}
