# BareSkin toolkit front door. `make demo` and `make test` are all a new user needs; both install what is missing.
BUILD      ?= build
BUILD_TYPE ?= RelWithDebInfo
LABEL      ?=
JOBS       ?= $(shell nproc)
# ccache must ignore the precompiled-header defines/timestamps, or PCH builds never hit the cache.
export CCACHE_SLOPPINESS = pch_defines,time_macros,include_file_mtime,include_file_ctime
# Paths below the checkout are hashed relative to it and the build folder's path not at all, so a second clone hits the
# cache the first one filled (its debug info may then name the first clone's files).
export CCACHE_BASEDIR  ?= $(CURDIR)
export CCACHE_NOHASHDIR ?= 1
export BARESKIN_ASSETS  ?= $(CURDIR)/assets
# OpenMP threads that spin while waiting make LibTorch 2-25x slower when tests or jobs share the cores (measured with
# nets_bench on the 2-core machine, where every network also stepped faster with passive waits).
export OMP_WAIT_POLICY ?= PASSIVE

PREFIX     ?= /usr/local

.PHONY: all deps build test demo install gpu gpu-bench gpu-vendor fuzz clean help
all: build

help:
	@echo "make demo    run the pipeline on the built-in synthetic data; writes out/demo/report.html"
	@echo "make test    install what is missing, build, run all tests, then the fuzzers 15 s each (LABEL=unit|cli|torch|fuzz)"
	@echo "make deps    Debian packages + pinned npm assets (idempotent)"
	@echo "make build   configure and build into $(BUILD)/ (TORCH=/path/to/libtorch: against that LibTorch, e.g. CUDA)"
	@echo "make install PREFIX=/usr/local   bareskin on PATH, assets + template + docs in PREFIX/share/bareskin"
	@echo "make gpu     Torch-side build on the GPU machine (see docs/gpu.md)"
	@echo "make gpu-bench  ... then the GPU figures (differentiable render, face networks)"
	@echo "make fuzz    libFuzzer targets (clang) into build-fuzz/, run each FUZZ_SECONDS"

deps:
	@bash scripts/install_deps.sh
	@bash scripts/fetch_assets.sh

# TORCH=/path/to/libtorch (an unzipped LibTorch, a Python torch folder, or `python`): the whole tool against that
# LibTorch, e.g. a CUDA one (docs/gpu.md). Without it, Debian's CPU LibTorch. Configure prints which one it took.
TORCH ?=

$(BUILD)/build.ninja:
	cmake -S . -B $(BUILD) -G Ninja -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) $(if $(TORCH),-DBARESKIN_TORCH=$(TORCH))

build: deps $(BUILD)/build.ninja
	$(if $(TORCH),@grep -qxF 'BARESKIN_TORCH:STRING=$(TORCH)' $(BUILD)/CMakeCache.txt || cmake $(BUILD) -DBARESKIN_TORCH=$(TORCH))
	cmake --build $(BUILD) -j $(JOBS)

# After the tests, every fuzz target runs FUZZ_TEST_SECONDS on its corpus (LABEL=fuzz: only that; FUZZ_TEST_SECONDS=0:
# none). A crash fails `make test` and its input is kept under tests/fuzz/regressions/ (docs/reliability.md).
FUZZ_TEST_SECONDS ?= 15
test: build
	$(if $(filter fuzz,$(LABEL)),,ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS) $(if $(LABEL),-L $(LABEL)))
	@if [ "$(FUZZ_TEST_SECONDS)" != 0 ] && { [ -z "$(LABEL)" ] || [ "$(LABEL)" = fuzz ]; }; then \
	  JOBS=$(JOBS) bash scripts/fuzz.sh $(FUZZ_TEST_SECONDS); fi

demo: build
	@bash scripts/demo.sh $(BUILD)/bin out/demo

# The tool, its assets (with their licences), a default template and the docs under PREFIX (docs/cli.md).
install: build
	cmake --install $(BUILD) --prefix $(PREFIX)

# GPU machine (no package registry): LibTorch from pip torch, spdlog/fmt headers carried in .gpu-vendor/.
GPU_BUILD ?= build-gpu
gpu:
	cmake -S . -B $(GPU_BUILD) -G Ninja -DCMAKE_BUILD_TYPE=Release -DBARESKIN_TORCH_ONLY=ON \
	  -DTorch_DIR=$$(python3 -c 'import torch;print(torch.utils.cmake_prefix_path)')/Torch \
	  -DCMAKE_PREFIX_PATH=$(CURDIR)/.gpu-vendor/usr
	cmake --build $(GPU_BUILD) -j $(JOBS)
	ctest --test-dir $(GPU_BUILD) --output-on-failure

# GPU figures for bench/BENCHMARKS.md: the differentiable render (CUDA events), the face networks, the loader and the
# BareSkinNet-like training step. The template's
# face.safetensors comes from the CPU machine (make demo) with the tree.
GPU_TEMPLATE ?= out/demo/template
gpu-bench: gpu
	$(GPU_BUILD)/bin/render_torch_bench $(GPU_TEMPLATE) 20
	$(GPU_BUILD)/bin/detect_bench
	$(GPU_BUILD)/bin/training_bench --steps 20

# Run on the CPU machine before sending the tree to the GPU machine.
gpu-vendor:
	@bash scripts/gpu_vendor.sh

# The long runs (BENCHMARKS "Reliability": 600 s per target). Exits non-zero on a crash, whose input it keeps.
FUZZ_SECONDS ?= 60
fuzz:
	JOBS=$(JOBS) bash scripts/fuzz.sh $(FUZZ_SECONDS)

clean:
	rm -rf $(BUILD) $(GPU_BUILD) build-fuzz out
