#!/usr/bin/env bash
# The two executables (apps/CMakeLists.txt): `bareskin`, built without LibTorch, runs the light commands itself and
# hands the others to `bareskin-torch` beside it. Checked: bareskin loads no LibTorch; --help, a Torch-side command's
# --help, its usage error and a bad input's line and exit code are the same through bareskin as from bareskin-torch;
# a command link (scan) reaches the Torch side too; a --config file with a section for a Torch-side command still
# works for a light command, and a misspelt key in that section is still refused; without bareskin-torch beside it,
# a Torch-side command is one line and exit 4 while the light commands run.
source "$(dirname "$0")/lib.sh" "$@"
torch=$(dirname "$bin")/bareskin-torch
if [ ! -x "$torch" ]; then
  echo "executables.sh: no bareskin-torch (built without the Torch side): one executable, nothing to check"
  exit 0
fi
! ldd "$bin" | grep -qi torch || fail "bareskin loads LibTorch: $(ldd "$bin" | grep -i torch | head -2)"
ldd "$torch" | grep -qi torch || fail "bareskin-torch does not load LibTorch"

same() {  # same NAME ARGS...: stdout, stderr and exit code equal from both executables
  local name=$1
  shift
  "$bin" "$@" > "$work/$name.a.out" 2> "$work/$name.a.err"
  local a=$?
  "$torch" "$@" > "$work/$name.b.out" 2> "$work/$name.b.err"
  local b=$?
  [ "$a" = "$b" ] || fail "$name: exit $a through bareskin, $b from bareskin-torch"
  cmp -s "$work/$name.a.out" "$work/$name.b.out" || fail "$name: stdout differs: $(diff "$work/$name.a.out" "$work/$name.b.out" | head -5)"
  cmp -s "$work/$name.a.err" "$work/$name.b.err" || fail "$name: stderr differs: $(diff "$work/$name.a.err" "$work/$name.b.err" | head -5)"
}
same help --help
same version --version
same scan_help scan synth --help
same global_before -q --threads 1 scan synth --help
same mm_help mm-build --help
same train_help train --help
same usage scan synth --count
same unknown nosuchcommand
same nan scan synth --count nan
same bad_input mm-build -q "$work/no_such_folder" -o "$work/model.safetensors"
same makeup_help makeup apply --help
grep -q "^  scan " "$work/help.a.out" || fail "--help does not list scan: $(cat "$work/help.a.out")"

# A config with a section for a Torch-side command: a light command still runs (the section's flags are checked
# by the executable that has them), and a misspelt key there is refused as before.
echo '{"quiet": true, "template": {"vertices": 1500}, "scan": {"synth": {"count": 2}}}' > "$work/cfg.json"
"$bin" --config "$work/cfg.json" template -o "$work/t" || fail "template with a config naming scan"
[ -f "$work/t/face.obj" ] || fail "template with a config naming scan wrote nothing"
echo '{"template": {"vertices": 1500}, "scan": {"synth": {"cuont": 2}}}' > "$work/bad.json"
expect_failure 2 "cuont" "$work/t2" -- "$bin" --config "$work/bad.json" template -o "$work/t2"

# Through the command link: the scan link points at bareskin, which hands `scan ...` over.
ln -s "$bin" "$work/scan"
"$work/scan" synth -q --template "$work/t" --count 1 --vertices 3000 --res 32 --truth-res 32 -o "$work/s" > /dev/null 2>&1 \
  || fail "the scan link did not run scan synth"
[ -f "$work/s/manifest.json" ] || fail "scan synth through the link wrote no manifest"


# Without its sibling: the light commands run, a Torch-side command says what is missing.
mkdir "$work/alone" && cp "$bin" "$work/alone/bareskin"
"$work/alone/bareskin" --version > /dev/null || fail "bareskin alone: --version"
"$work/alone/bareskin" makeup list > /dev/null || fail "bareskin alone: makeup list"
expect_failure 4 "bareskin-torch" "" -- "$work/alone/bareskin" scan synth --help
echo "executables.sh: passed"
