#!/usr/bin/env bash
# Which LibTorch configure takes (cmake/BareSkinTorch.cmake, the module the whole tool's configure includes), run on
# its own through tests/cmake/torch_probe into one temporary build folder:
# 1. the default (Debian's libtorch-dev): version, CPU/CUDA and ABI printed;
# 2. a second location, TORCH=<folder> (Debian's LibTorch laid out under a temporary prefix, as an unzipped LibTorch
#    would sit beside libtorch-dev): taken, and every library the tool would link is that folder's, not the system's;
# 3. a LibTorch built with the pre-cxx11 ABI: refused in one line that names the download to take;
# 4. a LibTorch whose configuration does not state its ABI: a link check finds it;
# 5. Debian's python3-torch folder (no CMake files) and a folder with no LibTorch: refused in one line.
# Usage: torch_config.sh SOURCE_DIR/tests/cmake/torch_probe
set -u
probe=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
debian=/usr/lib/$(gcc -print-multiarch)
[ -f "$debian/cmake/Torch/TorchConfig.cmake" ] || fail "no $debian/cmake/Torch/TorchConfig.cmake: install libtorch-dev (make deps)"

# configure [TORCH]: the probe into $work/b, output in $work/log; returns configure's exit code.
configure() {
  cmake -S "$probe" -B "$work/b" -G Ninja -DBARESKIN_TORCH="${1:-}" > "$work/log" 2>&1
}
# refused NEEDLE...: configure failed and exactly one line of its output holds every NEEDLE.
refused() {
  local line
  line=$(grep -F -- "$1" "$work/log")
  [ "$(printf '%s\n' "$line" | grep -c .)" -eq 1 ] || return 1
  for n in "$@"; do printf '%s' "$line" | grep -qF -- "$n" || return 1; done
  echo "ok   refused:$line"
}
# layout PREFIX: Debian's LibTorch under PREFIX with Debian's layout, its CMake files copied (so a test may edit them),
# its libraries and headers linked.
layout() {
  local lib=$1/lib/$(gcc -print-multiarch)
  mkdir -p "$lib/cmake" || fail "mkdir $lib"
  cp -r "$debian/cmake/Torch" "$debian/cmake/Caffe2" "$lib/cmake/" || fail "copy the CMake files"
  ln -s /usr/include "$1/include"
  for f in "$debian"/lib{c10,torch,torch_cpu}.so*; do ln -s "$f" "$lib/"; done
}

# 1. The default.
configure || fail "default LibTorch: $(tail -5 "$work/log")"
grep -qE -- "-- LibTorch [0-9.]+, (CPU only|with CUDA[0-9. ]*), C\+\+ ABI cxx11 \(_GLIBCXX_USE_CXX11_ABI=1, TORCH_CXX_FLAGS\): $debian/cmake/Torch\$" \
  "$work/log" || fail "default: no LibTorch line naming $debian/cmake/Torch: $(grep LibTorch "$work/log")"

# 2. A second location, in the same build folder (the cached first LibTorch must not leak into the second).
layout "$work/lt"
configure "$work/lt" || fail "TORCH=$work/lt: $(tail -5 "$work/log")"
grep -qE -- "-- LibTorch [0-9.]+, CPU only, C\+\+ ABI cxx11 .*: $work/lt/lib/[^/]+/cmake/Torch\$" "$work/log" \
  || fail "TORCH=$work/lt: not taken: $(grep LibTorch "$work/log")"
linked=$(sed -n 's/^-- linked: //p' "$work/log")
for l in $(printf '%s' "$linked" | tr ';' ' '); do
  case $l in
    /*) [[ $l == "$work/lt/"* ]] || fail "TORCH=$work/lt links $l, from outside it";;
  esac
done
[[ $linked == "$work/lt/"*libtorch_cpu* ]] || fail "TORCH=$work/lt: torch_cpu is not its own: $linked"
echo "ok   second location: $(grep -- '-- LibTorch' "$work/log")"

# 3. The pre-cxx11 ABI.
layout "$work/old"
sed -i 's/_GLIBCXX_USE_CXX11_ABI=1/_GLIBCXX_USE_CXX11_ABI=0/' "$work"/old/lib/*/cmake/Torch/TorchConfig.cmake
configure "$work/old" && fail "a pre-cxx11 LibTorch was accepted"
refused "pre-cxx11 C++ ABI (_GLIBCXX_USE_CXX11_ABI=0" "take the cxx11-ABI LibTorch zip" "make build TORCH=" \
  || fail "pre-cxx11: not one line naming the download: $(cat "$work/log")"

# 4. No ABI flag in the configuration: the link check decides (cxx11 here, as Debian's library is).
layout "$work/noflag"
sed -i 's/set(TORCH_CXX_FLAGS "-D_GLIBCXX_USE_CXX11_ABI=1")/set(TORCH_CXX_FLAGS "")/' \
  "$work"/noflag/lib/*/cmake/Torch/TorchConfig.cmake
configure "$work/noflag" || fail "no ABI flag: $(tail -5 "$work/log")"
grep -qF "C++ ABI cxx11 (_GLIBCXX_USE_CXX11_ABI=1, link check)" "$work/log" \
  || fail "no ABI flag: the link check did not run: $(grep LibTorch "$work/log")"
echo "ok   $(grep -- '-- LibTorch' "$work/log")"

# 5. Folders without a LibTorch's CMake files.
pytorch=$(/usr/bin/python3 -c 'import os, torch; print(os.path.dirname(torch.__file__))' 2> /dev/null)
if [ -n "$pytorch" ] && [ ! -e "$pytorch/share/cmake/Torch" ]; then
  configure "$pytorch" && fail "TORCH=$pytorch (no CMake files) was accepted"
  refused "TORCH=$pytorch: no TorchConfig.cmake" "libtorch-dev" "make build TORCH=" \
    || fail "TORCH=$pytorch: $(cat "$work/log")"
fi
configure "$work/nowhere" && fail "TORCH=$work/nowhere was accepted"
refused "TORCH=$work/nowhere: no TorchConfig.cmake" "LibTorch zip" || fail "TORCH=$work/nowhere: $(cat "$work/log")"
echo "LibTorch selection: all cases passed"
