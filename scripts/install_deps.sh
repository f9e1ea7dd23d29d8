#!/usr/bin/env bash
# Installs the Debian packages the toolkit builds and tests with, plus any named as arguments (e.g. the fuzzing
# toolchain); skips what is present (idempotent).
set -euo pipefail
packages=("$@"

  build-essential cmake ninja-build ccache pkg-config
  libeigen3-dev libspectra-dev libopenmesh-dev libcgal-dev libopenimageio-dev openimageio-tools libopenexr-dev
  libtorch-dev libceres-dev libsuitesparse-dev colmap
  libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev libpng-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libarchive-dev libprotobuf-dev protobuf-compiler libgloo-dev
  python3-numpy python3-skimage python3-torch python3-torchvision
  chromium  # the offline viewer's browser test (tests/cli/viewer.sh), headless
)
missing=()
# npm fetches the pinned assets; the machine may already have Node.js from elsewhere, so test for the command.
command -v npm >/dev/null || missing+=(npm)
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "deps: all ${#packages[@]} Debian packages present"
  exit 0
fi
echo "deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "deps: done"
