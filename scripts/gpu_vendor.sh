#!/usr/bin/env bash
# The GPU machine has no package registry and no spdlog/fmt, nor libarchive's headers (its CMake brings the library,
# libarchive.so.13): unpack Debian's header packages into .gpu-vendor/
# (ignored by git), which travels with the working tree; `make gpu` points CMAKE_PREFIX_PATH there.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
(cd "$tmp" && apt-get download libspdlog-dev libfmt-dev libarchive-dev >/dev/null)
rm -rf "$root/.gpu-vendor"
for deb in "$tmp"/*.deb; do dpkg -x "$deb" "$root/.gpu-vendor"; done
# Keep headers only: the compiled libraries are Debian's, not the GPU machine's.
find "$root/.gpu-vendor" -name '*.so*' -delete -o -name '*.a' -delete
echo "gpu-vendor: $(du -sh "$root/.gpu-vendor" | cut -f1) of headers in .gpu-vendor/"
