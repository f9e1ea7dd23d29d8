#!/usr/bin/env bash
# Both directions against numpy, which knows nothing of our code: numpy writes a file per the specification and our
# reader must report the same tensors, element by element in row-major order (a transposed or shifted read fails;
# min/max/mean alone would not see it); our template writer's file must parse with numpy and match its OBJ twin.
source "$(dirname "$0")/lib.sh" "$@"
set -e
oracle=$2
/usr/bin/python3 "$oracle" --write "$work/ref.safetensors" > "$work/expected.json"
"$bin" inspect --json --stats --values "$work/ref.safetensors" > "$work/ours.json"
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
    assert len(o["values"]) == len(e["values"]), name
    # Exact: every dtype here converts to double without loss, in both readers.
    diff = [i for i, (a, b) in enumerate(zip(o["values"], e["values"])) if a != b]
    assert not diff, (name, "first element that differs", diff[0], o["values"][diff[0]], e["values"][diff[0]])
# The check must be able to fail: a transposed read of the 3x4 tensor differs.
import numpy as np
a = np.array(expected["a_f32"]["values"]).reshape(3, 4)
assert list(a.T.ravel()) != ours["a_f32"]["values"]
print(f"numpy-written file: {len(expected)} tensors read identically, element by element")
PY
"$bin" template -q --vertices 6000 -o "$work/template"
/usr/bin/python3 "$oracle" "$work/template"
echo "2 passed, 0 failed"
