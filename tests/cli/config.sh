#!/usr/bin/env bash
# --config: a JSON file sets flags, the command line wins over it, and the resolved config.json written next to the
# outputs reproduces the run when fed back.
source "$(dirname "$0")/lib.sh" "$@"
set -e
vertices() { "$bin" inspect --json "$1/face.obj" | /usr/bin/python3 -c 'import json,sys; print(json.load(sys.stdin)["vertices"])'; }
near() { /usr/bin/python3 -c "import sys; a,b=int(sys.argv[1]),int(sys.argv[2]); sys.exit(abs(a-b) > 0.05*b)" "$1" "$2"; }

echo '{"quiet": true, "template": {"vertices": 2000, "remesh-iterations": 1}}' > "$work/cfg.json"
"$bin" --config "$work/cfg.json" template -o "$work/a"
near "$(vertices "$work/a")" 2000 || { echo "FAIL: config value not applied ($(vertices "$work/a"))"; exit 1; }
grep -q '"remesh-iterations": 1' "$work/a/config.json" || { echo "FAIL: resolved config lacks the value"; exit 1; }

"$bin" --config "$work/cfg.json" template -o "$work/b" --vertices 3000
near "$(vertices "$work/b")" 3000 || { echo "FAIL: command-line flag did not win over the config"; exit 1; }

"$bin" --config "$work/b/config.json" template -o "$work/c" -q
cmp -s "$work/b/face.obj" "$work/c/face.obj" || { echo "FAIL: resolved config did not reproduce the run"; exit 1; }
echo "3 passed, 0 failed"
