#!/usr/bin/env bash
# Both directions against numpy, which knows nothing of our code: numpy writes a file per the specification and our
# reader must report the same tensors; our template writer's file must parse with numpy and match its OBJ twin.
source "$(dirname "$0")/lib.sh" "$@"
set -e
oracle=$2
/usr/bin/python3 "$oracle" --write "$work/ref.safetensors" > "$work/expected.json"
"$bin" inspect --json --stats "$work/ref.safetensors" > "$work/ours.json"
/usr/bin/python3 - "$work/expected.json" "$work/ours.json" <<'PY'
import json, sys
expected = json.load(open(sys.argv[1]))
ours = {t["name"]: t for t in json.load(open(sys.argv[2]))["tensors"]}
assert set(ours) == set(expected), (set(ours), set(expected))
for name, e in expected.items():
    o = ours[name]
    assert o["shape"] == e["shape"], name
    for k in ("min", "max", "mean"):
        assert abs(o[k] - e[k]) <= 1e-6 * max(1.0, abs(e[k])), (name, k, o[k], e[k])
print(f"numpy-written file: {len(expected)} tensors read identically")
PY
"$bin" template -q --vertices 6000 -o "$work/template"
/usr/bin/python3 "$oracle" "$work/template"
echo "2 passed, 0 failed"
