#!/usr/bin/env bash
# Fetches the pinned npm packages of scripts/assets.lock, checks their sha256, and extracts the few files we use
# into assets/ (ignored by git), with their licence notices. Skips what is already there and verified.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
assets="${BARESKIN_ASSETS:-$root/assets}"
cache="$root/.cache/npm"
mkdir -p "$assets" "$cache"

fetch() {  # fetch NAME@VERSION SHA256 -> path of the verified tarball
  local spec=$1 sha=$2
  local file="$cache/$(echo "${spec#@}" | tr '/@' '--').tgz"
  if [ ! -f "$file" ] || ! echo "$sha  $file" | sha256sum -c --quiet - 2>/dev/null; then
    local tmp
    tmp=$(mktemp -d)
    (cd "$tmp" && npm pack --silent "$spec" >/dev/null)
    mv "$tmp"/*.tgz "$file"
    rm -rf "$tmp"
    if ! echo "$sha  $file" | sha256sum -c --quiet -; then
      echo "assets: $spec does not match its pinned sha256 ($file); refusing to use it" >&2
      rm -f "$file"
      exit 1
    fi
  fi
  echo "$file"
}

while read -r spec sha; do
  case "$spec" in ''|'#'*) continue ;; esac
  tarball=$(fetch "$spec" "$sha")
  case "$spec" in
    @mediapipe/face_mesh@*)
      out="$assets/mediapipe_face_mesh"
      mkdir -p "$out"
      tar -xzf "$tarball" -C "$out" --strip-components=1 \
        package/face_mesh_solution_packed_assets.data package/face_mesh_solution_packed_assets_loader.js package/package.json
      cat > "$out/NOTICE" <<NOTICE
MediaPipe Face Mesh assets, from npm $spec (sha256 $sha).
Copyright Google LLC. Licensed under the Apache License, Version 2.0 (package.json: "license": "Apache-2.0");
https://www.apache.org/licenses/LICENSE-2.0. We use the canonical face mesh of
geometry_pipeline_metadata_landmarks.binarypb, decoded and refined by 'bareskin template'.
NOTICE
      ;;
    @vladmandic/human@*)
      out="$assets/human"
      mkdir -p "$out"
      tar -xzf "$tarball" -C "$out" --strip-components=3 package/src/face/facemeshcoords.ts
      tar -xzf "$tarball" -C "$out" --strip-components=1 package/LICENSE
      ;;
    @vladmandic/face-api@*)
      # The 68-point landmark net and the tiny face detector (tfjs manifests + uint8 weights) for 'bareskin landmarks',
      # and the face recognition net (128-d descriptors) for the identity and perceptual losses of training/;
      # the package's own JavaScript bundle is the oracle of tests/node/*.mjs.
      out="$assets/face_api"
      mkdir -p "$out"
      tar -xzf "$tarball" -C "$out" --strip-components=2 \
        package/model/face_landmark_68_model.bin package/model/face_landmark_68_model-weights_manifest.json \
        package/model/tiny_face_detector_model.bin package/model/tiny_face_detector_model-weights_manifest.json \
        package/model/face_recognition_model.bin package/model/face_recognition_model-weights_manifest.json
      tar -xzf "$tarball" -C "$out" --strip-components=1 package/LICENSE package/dist/face-api.esm.js
      ;;
    three@*)
      # three.js for the avatar's offline viewer (viewer.html): the core module, the glTF loader and its one helper,
      # inlined into each page by makeup/viewer.cc.
      out="$assets/three"
      mkdir -p "$out"
      tar -xzf "$tarball" -C "$out" --strip-components=2 package/build/three.module.min.js
      tar -xzf "$tarball" -C "$out" --strip-components=4 package/examples/jsm/loaders/GLTFLoader.js \
        package/examples/jsm/utils/BufferGeometryUtils.js
      tar -xzf "$tarball" -C "$out" --strip-components=1 package/LICENSE
      ;;
  esac
  echo "assets: $spec ok"
done < "$root/scripts/assets.lock"
