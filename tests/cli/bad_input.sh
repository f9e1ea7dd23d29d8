#!/usr/bin/env bash
# Bad input through the real command line: each case must exit with the documented code, print exactly one line on
# stderr that names the file, and leave no output behind.
source "$(dirname "$0")/lib.sh" "$@"
cd "$work"
failures=0 passed=0

# expect CODE NEEDLE OUTPUT -- command...: error_ok (tests/cli/lib.sh), counted; the cases go on after a failure.
expect() {
  if error_ok "$@"; then
    passed=$((passed + 1))
  else
    echo "FAIL: ${*:5} -> exit $error_code (want $1), $(grep -c . "$work/err") stderr lines, output '$3' $( [ -e "$3" ] && echo exists)"
    sed 's/^/    /' "$work/err"
    failures=$((failures + 1))
  fi
}

# A valid mesh and image to cut up.
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nf 1/1 2/2 3/3\nf 2/2 4/4 3/3\n' > good.obj
"$bin" render good.obj -o good.png --size 64 -q
"$bin" render good.obj -o good.exr --size 64 -q
head -c 300 good.png > cut.png
head -c 300 good.exr > cut.exr
printf 'v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n' > nan.obj
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/5 3/1\n' > uvrange.obj
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n' > range.obj
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\nf 2/2 4/' > cut.obj
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 3\nf 2 1 3\n' > dropped.obj
printf 'ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n' > cut.ply
printf '{"points": [[1, 2, 3], [4, 5' > cut.json
printf '{"points": [[1, 2, 3]]}' > short.json
printf '\x40\x00\x00\x00\x00\x00\x00\x00{"a":{"dtype":"F32","shape":[4],"data_offsets":[0,16]}}' > cut.safetensors
printf 'version: 1\nn_points: 68\n{\n1 2\n' > cut.pts

for f in cut.obj dropped.obj nan.obj uvrange.obj range.obj cut.ply cut.png cut.exr cut.json short.json cut.safetensors cut.pts; do
  expect 3 "$f" "" -- "$bin" inspect "$f"
done
expect 4 "missing.obj" "" -- "$bin" inspect missing.obj
expect 3 "nan.obj" "out.png" -- "$bin" render nan.obj -o out.png
expect 4 "/nonexistent_dir" "" -- "$bin" render good.obj -o /nonexistent_dir/out.png
expect 3 "out.xyz" "out.xyz" -- "$bin" render good.obj -o out.xyz
expect 2 "--size" "out.png" -- "$bin" render good.obj -o out.png --size 3
expect 2 "unknown command 'nosuchcommand'" "" -- "$bin" nosuchcommand
expect 3 "--vertices" "tpl" -- "$bin" template --vertices 10 -o tpl
expect 4 "nowhere" "tpl" -- "$bin" template --assets nowhere -o tpl
expect 4 "nowhere/face.obj" "scans" -- "$bin" scan synth --template nowhere -o scans --count 1
expect 3 "--count" "scans" -- "$bin" scan synth --count 0 -o scans
printf '{"render": {"size": "big"}}' > bad_config.json
expect 2 "size" "out.png" -- "$bin" --config bad_config.json render good.obj -o out.png
printf '{"render": {"sise": 64}}' > misspelt_config.json  # an unknown key was ignored: the run went on with defaults
expect 2 "misspelt_config.json: 'render.sise' is not a flag" "out.png" -- "$bin" --config misspelt_config.json render good.obj -o out.png
expect 3 "cut.json: is not a JSON object" "out.png" -- "$bin" --config cut.json render good.obj -o out.png

# An output never replaces an input or a folder bareskin did not write (a folder output would replace all inside it),
# and no flag takes NaN (CLI11's range checks let it through).
cp good.png good_before.png
mkdir -p mine dir.png && echo keep > mine/notes.txt
expect 3 "good.png: is also an input (good.png)" "" -- "$bin" uvtools unwarp good.png --mesh good.obj -o good.png
expect 3 "would replace a folder that holds an input (mine)" "" -- "$bin" uvtools bake mine -o .
expect 4 "dir.png: is a folder" "" -- "$bin" render good.obj -o dir.png
expect 2 "'nan' is not a finite number" "out.png" -- "$bin" render good.obj -o out.png --size nan
expect 2 "'--size=-inf' is not a finite number" "out.png" -- "$bin" render good.obj -o out.png --size=-inf
cmp -s good.png good_before.png && [ "$(cat mine/notes.txt)" = keep ] && passed=$((passed + 1)) \
  || { echo "FAIL: an input or the user's folder changed"; failures=$((failures + 1)); }

# --device, one parser for every command that runs networks (those built: they need the Torch side): anything but cpu,
# cuda or cuda:N is refused naming the flag and the forms, and a CUDA device this machine lacks (cuda:99 anywhere) in
# one line, both before any input is read or the output (the last word) written; the inputs named here do not exist.
for cmd in "landmarks detect good.png -o dev.json" "recon good.png --run F -o dev" "demakeup good.png --run bsn -o dev" \
           "run good.png --model m --texture tex --no-bareskin -o dev" \
           "evaluate --faces faces --model m --texture tex --bareskin bsn -o dev" "train recon --data faces --model m -o dev" \
           "train bareskin --data faces -o dev" "train texture --data tex -o dev" "train upscale --data tex -o dev"; do
  read -ra words <<< "$cmd"
  probe=("${words[0]}")
  [[ ${words[0]} == train || ${words[0]} == landmarks ]] && probe+=("${words[1]}")
  "$bin" "${probe[@]}" --help > /dev/null 2>&1 || continue
  expect 3 "--device: 'gpu' is not a device; give cpu, cuda or cuda:N" "${words[-1]}" -- "$bin" "${words[@]}" --device gpu
  expect 3 "--device cuda:99: CUDA " "${words[-1]}" -- "$bin" "${words[@]}" --device cuda:99
done

# An options struct's check() runs first where its library takes it: a value out of range is one line naming the flag,
# exit 3, before the inputs that do not exist here are looked for and before anything is written. One case per family;
# those of the Torch side only where it is built.
for case in "--depth-tolerance|uv.png|uvtools unwarp good.png --mesh good.obj -o uv.png --depth-tolerance 0" \
            "--appearance-components|fit.json|mm-fit good.png --model none.safetensors --landmarks none.json -o fit.json --appearance-components -1" \
            "--heat-max|reg|scan register --scans noscans -o reg --heat-max 0" \
            "--input-size|lm.json|landmarks detect good.png -o lm.json --input-size 33" \
            "PSNR|dev|recon good.png --run none -o dev --flag-psnr -1" \
            "--log-every|dev|train recon --data nofaces --model none.safetensors -o dev --log-every 0" \
            "--eval-samples|dev|train bareskin --data nofaces -o dev --eval-samples -1"; do
  IFS='|' read -r needle output cmd <<< "$case"
  read -ra words <<< "$cmd"
  probe=("${words[0]}")
  [[ ${words[0]} == train || ${words[0]} == landmarks ]] && probe+=("${words[1]}")
  "$bin" "${probe[@]}" --help > /dev/null 2>&1 || continue
  expect 3 "$needle" "$output" -- "$bin" "${words[@]}"
done

echo "$passed passed, $failures failed"
[ "$failures" -eq 0 ]
