#!/usr/bin/env bash
# scan synth maps: readable by oiiotool (an independent reader) in each format, truth maps, kill -9 + resume gives the
# same bytes as an uninterrupted run, bad map options get one line and exit 3.
source "$(dirname "$0")/lib.sh" "$@"
passed=0
ok() { passed=$((passed + 1)); }
"$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
synth() { "$bin" scan synth -q --template "$work/t" --vertices 3000 "$@"; }

synth --count 2 --res 256 --holes --truth-res 128 -o "$work/png" || fail "scan synth png"
for s in subject_0000 subject_0001; do
  for m in diffuse normal; do
    oiiotool --info "$work/png/$s/$m.png" | grep -q "256 x  *256, 3 channel, uint16 png" || fail "$s/$m.png: $(oiiotool --info "$work/png/$s/$m.png")"
  done
  for m in roughness specular; do
    oiiotool --info "$work/png/$s/$m.png" | grep -q "256 x  *256, 1 channel, uint16 png" || fail "$s/$m.png"
  done
  oiiotool --info "$work/png/$s/truth/maps/diffuse.png" | grep -q "128 x  *128, 3 channel" || fail "$s truth maps"
done
# Normals point out of the surface: the mean of the stored z ((n+1)/2) is close to 1 in the charts and outside them.
avg=$(oiiotool --stats "$work/png/subject_0000/normal.png" | sed -n 's/.*Stats Avg: *\([0-9.]*\) *\([0-9.]*\) *\([0-9.]*\).*/\3/p')
/usr/bin/python3 -c "import sys; sys.exit(0 if float(sys.argv[1]) > 0.95 * 65535 else 1)" "$avg" || fail "normal z average $avg"
ok

synth --count 1 --res 128 --map-format exr -o "$work/exr" || fail "scan synth exr"
oiiotool --info -v "$work/exr/subject_0000/diffuse.exr" | grep -q "3 channel, half openexr" || fail "exr diffuse"
oiiotool --info -v "$work/exr/subject_0000/diffuse.exr" | grep -qi "colorspace.*linear" || fail "exr diffuse is not tagged linear"
"$bin" inspect "$work/exr/subject_0000/roughness.exr" > /dev/null || fail "our reader on exr roughness"
ok

# kill -9 in the middle, rerun: finished subjects are kept, the rest made again, all bytes as an uninterrupted run.
# The kill must land mid-run: the process still running when killed (SIGKILL is what ended it), at least one subject
# finished and at least one not, else the resume would prove nothing.
synth --count 3 --res 512 -o "$work/ref" || fail "reference run"
"$bin" scan synth -q --template "$work/t" --vertices 3000 --count 3 --res 512 -o "$work/killed" &  # not the function: see
# cli/texgen_faces.sh (kill -9 must end the binary, not a subshell around it)
pid=$!
for _ in $(seq 1 600); do [ -d "$work/killed/subject_0000" ] && break; sleep 0.05; done
kill -9 $pid 2> /dev/null || fail "the run had ended before kill -9"
wait $pid 2> /dev/null
[ $? -eq 137 ] || fail "the run was not ended by kill -9"
finished=$(find "$work/killed" -maxdepth 1 -name 'subject_*' | wc -l)
[ "$finished" -ge 1 ] && [ "$finished" -lt 3 ] || fail "kill -9 did not land mid-run: $finished of 3 subjects finished"
synth --count 3 --res 512 -o "$work/killed" || fail "resumed run"
for f in $(cd "$work/ref" && find subject_* -type f | sort); do
  cmp -s "$work/ref/$f" "$work/killed/$f" || fail "$f differs after kill -9 and resume"
done
[ -z "$(find "$work/killed" -name '.*partial*')" ] || fail "a partial subject was left behind"
ok

expect_failure 3 "map format" "$work/bad" -- synth --count 1 --res 128 --map-format bmp -o "$work/bad"
expect_failure 3 "--res" "$work/bad" -- synth --count 1 --res 5 -o "$work/bad"
ok
echo "$passed passed, 0 failed"
