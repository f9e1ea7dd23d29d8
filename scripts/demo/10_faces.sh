#!/usr/bin/env bash
# Demo §10: texgen faces — the face-image world the recon and BareSkinNet trainings learn from: registered demo
# subjects and 3DMM samples with makeup, SH light + a specular key light, poses, backgrounds and occluders, aligned by
# Deep3DFaceRecon's 5 points and rendered by the canonical camera. A contact sheet of styles × lights × poses, one
# sample's members, the makeup strength (CIELAB ΔE between makeup.png and before.png) per style, and the detector
# check (face-api on the pre-alignment renders). Usage: bash scripts/demo/10_faces.sh <bin> <out>. Skips what exists.
source "$(dirname "$0")/lib.sh"
# Sizes (2 cores, ~90 s for the section): 256² samples as the networks take them; 560 samples from the 10 registered
# subjects and 90 3DMM identities (splits by subject, 10% each for val and test: ~450/55/55), enough for the small
# CPU trainings of recon and BareSkinNet after it. --align truth for those (the detector costs ~0.25 s a sample on 2
# cores); the detector check aligns 40 more samples the way real photos are aligned.
COUNT=${DEMO_FACES_COUNT:-560}
CHECK=${DEMO_FACES_DETECTOR:-40}
THREADS=${THREADS:-2}
if [ ! -f "$out/faces/test/manifest.json" ]; then
  echo "demo §10: texgen faces ($COUNT samples, 256²)" >&2
  timed "faces" "$bareskin" -q --threads "$THREADS" texgen faces --registered "$out/registered" \
    --model "$out/model/model.safetensors" --count "$COUNT" --seed 1 --align truth -o "$out/faces"
fi
if [ "$CHECK" -gt 0 ] && [ ! -f "$out/faces_detector/train/manifest.json" ] && [ -n "$("$bareskin" --help | grep -w landmarks)" ]; then
  echo "demo §10: detector check ($CHECK samples aligned by face-api's landmarks)" >&2
  timed "faces detect" "$bareskin" -q --threads "$THREADS" texgen faces --registered "$out/registered" \
    --model "$out/model/model.safetensors" --count "$CHECK" --seed 2 --align detector --val 0 --test 0 \
    -o "$out/faces_detector"
fi
$py "$(dirname "$0")/10_faces.py" "$out" "$COUNT" "$CHECK" > "$out/sections/10_faces.html"
