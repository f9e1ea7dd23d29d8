#!/usr/bin/env bash
# bareskin train recon / bareskin recon: a tiny F on face shards and two toy model files written here (Python: an
# independent safetensors, PNG and tar writer), a photo through detect → align → net, and bad input: a checkpoint of
# another model file, a file that is no checkpoint, resuming with another arch, a photo without a face, a corrupt image
# (one line, exit ≠ 0, no output), a folder with --keep-going.
source "$(dirname "$0")/lib.sh" "$@"

"$py" - "$work" "$here/../python" <<'PY'
import io, json, os, struct, sys, tarfile, zlib
import numpy as np
root = sys.argv[1]
sys.path.insert(0, sys.argv[2])
from spec_writers import png, safetensors
rng = np.random.default_rng(3)

def toy_model(path, kid, kexp, kapp, n=16, R=16):
    ys, xs = np.mgrid[0:n, 0:n] / (n - 1.0)
    x, y = xs * 120 - 60, ys * 150 - 75
    z = 50 * np.clip(1 - (x / 70) ** 2 - (y / 85) ** 2, 0, None)
    V = np.stack([x, y, z], -1).reshape(-1, 3).astype(np.float32)
    uv = np.stack([xs, ys], -1).reshape(-1, 2).astype(np.float32)
    tri = []
    for j in range(n - 1):
        for i in range(n - 1):
            a = j * n + i
            tri += [[a, a + 1, a + n + 1], [a, a + n + 1, a + n]]
    tri = np.array(tri, np.int32)
    def basis(k, cols):
        q, _ = np.linalg.qr(rng.standard_normal((cols, k)))
        return q.T.astype(np.float32)
    Nv = V.shape[0]
    t = {"shape_mean": ("F32", V), "shape_basis": ("F32", basis(kid, 3 * Nv).reshape(kid, Nv, 3)),
         "shape_stddev": ("F32", np.full(kid, 100, np.float32)),
         "expression_basis": ("F32", basis(kexp, 3 * Nv).reshape(kexp, Nv, 3)),
         "expression_stddev": ("F32", np.full(kexp, 50, np.float32)),
         "appearance_mean": ("F32", np.full((R, R, 3), 0.5, np.float32)),
         "appearance_basis": ("F32", basis(kapp, 3 * R * R).reshape(kapp, R, R, 3)),
         "appearance_stddev": ("F32", np.full(kapp, 1, np.float32)),
         "appearance_mask": ("U8", np.ones((R, R), np.uint8)), "triangles": ("I32", tri), "uvs": ("F32", uv),
         "uv_triangles": ("I32", tri), "landmark_vertices": ("I32", rng.choice(Nv, 68, replace=False).astype(np.int32)),
         "vertex_region": ("U8", np.zeros(Nv, np.uint8)), "procrustes": ("F32", np.eye(4, dtype=np.float32)[None])}
    safetensors(path, t, {"format": "bareskin.morphable_model", "format_version": "1", "units": "mm",
                          "region_names": json.dumps(["cheeks_jaw"])})

toy_model(f"{root}/model.safetensors", 3, 2, 2)
toy_model(f"{root}/other.safetensors", 4, 2, 2)
os.makedirs(f"{root}/faces/train")
with tarfile.open(f"{root}/faces/train/faces-000000.tar", "w") as tar:
    for i in range(4):
        coeffs = {"alpha": rng.standard_normal(3).tolist(), "beta": rng.standard_normal(2).tolist(),
                  "delta": rng.standard_normal(2).tolist(), "rotation": [0, 0.1, 0], "translation": [0, 0, 0],
                  "gamma": [0.8] + [0] * 8 + [0.8] + [0] * 8 + [0.8] + [0] * 8}
        meta = {"subject": f"mm/{i}", "split": "train", "has_truth": True, "coefficients": coeffs,
                "landmarks": (rng.random((68, 2)) * 24 + 4).tolist()}
        for member, data in (("before.png", png(rng.random((32, 32, 3)))), ("skin.png", png(np.ones((32, 32)))),
                             ("json", json.dumps(meta).encode())):
            info = tarfile.TarInfo(f"{i:08d}.{member}")
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
data = open(f"{root}/faces/train/faces-000000.tar", "rb").read()
json.dump({"format": "bareskin-shards/1", "samples": 4, "metadata": {},
           "shards": [{"name": "faces-000000.tar", "samples": 4, "crc32": zlib.crc32(data), "bytes": len(data)}]},
          open(f"{root}/faces/train/manifest.json", "w"))
open(f"{root}/grey.png", "wb").write(png(np.full((128, 128, 3), 0.5)))
open(f"{root}/corrupt.png", "wb").write(png(np.full((64, 64, 3), 0.5))[:60])
PY
[ -f "$work/model.safetensors" ] || fail "the Python fixture writer failed"

"$bin" -q --threads 1 train recon --arch resnet18 --width 4 --data "$work/faces" --model "$work/model.safetensors" \
  -o "$work/F" --steps 2 --batch 2 --checkpoint-every 2 --eval-every 0 --sample-every 0 --log-every 1 \
  --gamma on --loss '{"identity": 0}' || fail "train recon failed"
[ -f "$work/F/checkpoint.safetensors" ] || fail "no checkpoint"
grep -q '"arch": "resnet18"' "$work/F/config.json" || fail "the run's config does not name its arch"
for term in F/truth F/photo F/landmark F/reg F/gamma; do
  grep -q "$term" "$work/F/metrics.csv" || fail "the losses lack $term: $(head -3 "$work/F/metrics.csv")"
done
# A run made before the shape term, the pooling grid and the gradient clip existed (its checkpoint's configuration
# lacks "shape", "pool_grid" and "clip_grad_norm") resumes; it is refused once its weights differ from the ones given.
"$py" - "$work/F/checkpoint.safetensors" <<'PY' || fail "could not rewrite the checkpoint's configuration"
import json, struct, sys
raw = open(sys.argv[1], "rb").read()
n = struct.unpack("<Q", raw[:8])[0]
header = json.loads(raw[8:8 + n])
meta = json.loads(header["__metadata__"]["bareskin.checkpoint"])
del meta["config"]["loss"]["shape"], meta["config"]["net"]["pool_grid"], meta["config"]["clip_grad_norm"]
del meta["config"]["colour_jitter"]
header["__metadata__"]["bareskin.checkpoint"] = json.dumps(meta, separators=(",", ":"))
text = json.dumps(header, separators=(",", ":")).encode()
open(sys.argv[1], "wb").write(struct.pack("<Q", len(text)) + text + raw[8 + n:])  # offsets count from the data
PY
"$bin" -q --threads 1 train recon --arch resnet18 --width 4 --data "$work/faces" --model "$work/model.safetensors" \
  -o "$work/F" --steps 3 --batch 2 --checkpoint-every 1 --eval-every 0 --sample-every 0 --log-every 1 \
  --gamma on --loss '{"identity": 0}' --resume \
  || fail "a run from before the shape term, pool_grid, clip_grad_norm and colour_jitter did not resume"
grep -q '^3,' "$work/F/metrics.csv" || fail "the resumed run did not reach step 3: $(tail -2 "$work/F/metrics.csv")"
expect_failure 3 "loss" "" -- "$bin" -q train recon --arch resnet18 --width 4 --data "$work/faces" \
  --model "$work/model.safetensors" -o "$work/F" --steps 4 --batch 2 --gamma on --loss '{"identity": 0, "shape": 1}' --resume
expect_failure 3 "clip_grad_norm" "" -- "$bin" -q train recon --arch resnet18 --width 4 --data "$work/faces" \
  --model "$work/model.safetensors" -o "$work/F" --steps 4 --batch 2 --gamma on --loss '{"identity": 0}' \
  --clip-grad-norm 1 --resume
# --clip-grad-norm: the norm before clipping is logged; a negative norm is one line, nothing written. The colour
# jitter rides along (its pairing of photo and light: recon_test's ReconData.ColourJitterKeepsPhotoAndLightAPair).
"$bin" -q --threads 1 train recon --arch resnet18 --width 4 --data "$work/faces" --model "$work/model.safetensors" \
  -o "$work/Fclip" --steps 1 --batch 2 --eval-every 0 --sample-every 0 --log-every 1 --loss '{"identity": 0}' \
  --clip-grad-norm 0.5 --colour-jitter 0.2 || fail "train recon --clip-grad-norm --colour-jitter failed"
grep -q '"colour_jitter": 0.2' "$work/Fclip/config.json" || fail "the run's config lacks its colour_jitter"
grep -q "^1,E/grad_norm," "$work/Fclip/metrics.csv" \
  || fail "no E/grad_norm logged (resnet18: E): $(head -3 "$work/Fclip/metrics.csv")"
grep -q '"clip_grad_norm": 0.5' "$work/Fclip/config.json" || fail "the run's config lacks its clip_grad_norm"
expect_failure 3 "--clip-grad-norm" "$work/Fneg" -- "$bin" -q train recon --data "$work/faces" \
  --model "$work/model.safetensors" -o "$work/Fneg" --clip-grad-norm -1
expect_failure 3 "--colour-jitter" "$work/Fneg" -- "$bin" -q train recon --data "$work/faces" \
  --model "$work/model.safetensors" -o "$work/Fneg" --colour-jitter 2

# A real face photo through detect → align → the (untrained) net: every output, the confidence in the coefficients.
photo=/usr/lib/python3/dist-packages/skimage/data/astronaut.png
if [ -f "$photo" ]; then
  "$bin" -q --threads 1 recon "$photo" --run "$work/F" -o "$work/out" || fail "recon on a face photo failed"
  for f in coefficients.json mesh.obj overlay.png aligned.png landmarks.json; do
    [ -s "$work/out/$f" ] || fail "recon did not write $f"
  done
  "$py" -c "import json,sys; c=json.load(open(sys.argv[1])); assert len(c['alpha'])==3 and len(c['gamma'])==27 \
and 0 <= c['confidence'] <= 1 and c['landmark_residual_px'] > 0, c" "$work/out/coefficients.json" \
    || fail "coefficients.json lacks the coefficients or the confidence"
fi

expect_failure 3 "K_id 3" "$work/o1" -- "$bin" recon "$work/grey.png" --run "$work/F" --model "$work/other.safetensors" -o "$work/o1"
expect_failure 3 "not a training checkpoint" "$work/o2" -- "$bin" recon "$work/grey.png" --run "$work/model.safetensors" \
  --model "$work/model.safetensors" -o "$work/o2"
expect_failure 3 "no face was found" "$work/o3" -- "$bin" recon "$work/grey.png" --run "$work/F" -o "$work/o3"
expect_failure 3 "corrupt.png" "$work/o4" -- "$bin" recon "$work/corrupt.png" --run "$work/F" -o "$work/o4"
expect_failure 4 "nothing.png" "$work/o5" -- "$bin" recon "$work/nothing.png" --run "$work/F" -o "$work/o5"
expect_failure 3 "arch" "" -- "$bin" -q train recon --arch resnet50 --width 4 --data "$work/faces" \
  --model "$work/model.safetensors" -o "$work/F" --steps 4 --batch 2 --gamma on --loss '{"identity": 0}' --resume
expect_failure 3 "unknown" "" -- "$bin" train recon --data "$work/faces" --model "$work/model.safetensors" \
  -o "$work/F2" --loss '{"phot": 1}'

# A folder: without --keep-going the first bad photo stops the run; with it, both are reported and the exit is 3.
mkdir -p "$work/photos" && cp "$work/grey.png" "$work/corrupt.png" "$work/photos/"
"$bin" recon "$work/photos" --run "$work/F" -o "$work/o6" --keep-going 2> "$work/err6"
[ $? -eq 3 ] || fail "a folder of failing photos with --keep-going should exit 3"
[ "$(grep -c '^error:' "$work/err6")" -eq 3 ] || fail "expected a line per photo and a summary: $(cat "$work/err6")"
grep -q "2 of 2 photos failed" "$work/err6" || fail "no summary line: $(cat "$work/err6")"
echo "recon CLI: ok"
