#!/usr/bin/env bash
# Demo §15: the paper's applications on the astronaut's avatar of §14: every built-in makeup look put on its bare
# maps (before/after sheets under three lights), relighting under the photo's light and two key lights, the light
# exported for engines, and the offline viewer (screenshots from headless Chromium where it is installed).
# Usage: bash scripts/demo/15_applications.sh <bin> <out>. Skipped when §14 made no avatar; redone otherwise (≈ 30 s).
source "$(dirname "$0")/lib.sh"
source "$(dirname "$0")/../demo_applications.sh"
avatar="$out/texture/avatar_astronaut"
if [ ! -f "$avatar/avatar.glb" ]; then
  echo "demo §15: no avatar from §14 ($avatar), skipping the applications" >&2
  exit 0
fi
# The looks' regions are placed on the template the demo's model was built on (§1).
export BARESKIN_TEMPLATE="$out/template"
rm -rf "$out/applications"
timed "applications" demo_applications "$bareskin" "$avatar" "$out/applications" > "$out/sections/15_applications.html.tmp"
mv "$out/sections/15_applications.html.tmp" "$out/sections/15_applications.html"
