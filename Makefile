# Thicket: every target sets up what it needs (venv with Blender's bpy module,
# maturin, the native wheel). Needs only Rust (cargo) and Python 3.11.

PYTHON ?= python3.11
BPY_VERSION ?= 5.0.1
BPY_LTS_VERSION ?= 4.2.0
BENCH_FLAGS ?=
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.thicket-$(BPY_VERSION)
# Blender 4.2 LTS, the oldest supported version: the Python suites run on it too, and
# fixtures are saved with it so every supported Blender can open them.
VENV_LTS := .venv-lts
PY_LTS := $(VENV_LTS)/bin/python
STAMP_LTS := $(VENV_LTS)/.thicket-$(BPY_LTS_VERSION)
RUFF_VERSION ?= 0.17.6
RUST_SOURCES := Cargo.toml $(shell find rust shaders -name '*.rs' -o -name '*.wgsl' -o -name '*.pyi' -o -name Cargo.toml -o -name pyproject.toml 2>/dev/null)
WHEEL_STAMP := build/site/.stamp
ADDON_SOURCES := $(shell find addon -type f -not -path '*/__pycache__/*' 2>/dev/null)

.PHONY: far-perf setup wheel extension test test-rust test-python lint format demo bench fixtures clean vulkan

setup: $(STAMP) $(WHEEL_STAMP)

$(STAMP):
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install -q --upgrade pip
	$(VENV)/bin/pip install -q "bpy==$(BPY_VERSION)" "maturin>=1.5,<2" pytest
	touch $@

$(STAMP_LTS):
	$(PYTHON) -m venv $(VENV_LTS)
	$(VENV_LTS)/bin/pip install -q --upgrade pip
	$(VENV_LTS)/bin/pip install -q "bpy==$(BPY_LTS_VERSION)" pytest
	touch $@

# The native module is built once per source change and installed into build/site
# (not into the venv, so the extension-install test proves the zip's own wheel works).
$(WHEEL_STAMP): $(STAMP) $(RUST_SOURCES)
	rm -rf build/wheels build/site
	$(VENV)/bin/maturin build --release --quiet -m rust/py/Cargo.toml -o build/wheels
	$(VENV)/bin/pip install -q --no-deps --target build/site build/wheels/thicket_native-*.whl
	touch $@

wheel: $(WHEEL_STAMP)

extension: $(WHEEL_STAMP) $(ADDON_SOURCES)
	rm -rf dist
	$(PY) addon/build_extension.py build/wheels dist

# A Vulkan driver for the GPU renderer's tests: Mesa's lavapipe (Vulkan on the CPU)
# where the machine has no Vulkan driver at all.
vulkan:
	@if ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json 2>/dev/null | grep -q .; then :; else \
		echo "== no Vulkan driver: installing Mesa's lavapipe (mesa-vulkan-drivers)"; \
		SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
		$$SUDO apt-get update -qq && \
		$$SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mesa-vulkan-drivers; \
	fi

test-rust: vulkan
	cargo test --release -p thicket-core
	cargo test --release -p thicket-render

test-python: vulkan setup extension $(STAMP_LTS)
	@echo "== Python tests in Blender $(BPY_VERSION)"
	$(PY) -m pytest tests -q -p no:cacheprovider
	@echo "== Python tests in Blender $(BPY_LTS_VERSION) LTS"
	$(PY_LTS) -m pytest tests -q -p no:cacheprovider

test: test-rust test-python

# Lint: formatting (rustfmt.toml, ruff.toml: 160 columns), clippy on every target
# with warnings as errors, ruff on the add-on, tests and fixtures. Installed here if
# missing. `make format` rewrites what the checks would refuse.
PY_LINTED := addon tests blend_fixtures rust/py/thicket_native.pyi

lint: $(STAMP)
	@cargo fmt --version >/dev/null 2>&1 || rustup component add rustfmt
	@cargo clippy --version >/dev/null 2>&1 || rustup component add clippy
	cargo fmt --all -- --check
	cargo clippy --all-targets -q -- -D warnings
	@$(VENV)/bin/ruff --version 2>/dev/null | grep -q "$(RUFF_VERSION)" || $(VENV)/bin/pip install -q "ruff==$(RUFF_VERSION)"
	$(VENV)/bin/ruff format --check $(PY_LINTED)
	$(VENV)/bin/ruff check $(PY_LINTED)

format: $(STAMP)
	@$(VENV)/bin/ruff --version 2>/dev/null | grep -q "$(RUFF_VERSION)" || $(VENV)/bin/pip install -q "ruff==$(RUFF_VERSION)"
	cargo fmt --all
	$(VENV)/bin/ruff format $(PY_LINTED)

fixtures: setup $(STAMP_LTS)
	$(PY_LTS) blend_fixtures/make_fixtures.py

demo: setup
	$(PY) blend_fixtures/demo.py blend_fixtures/demo.blend out

# The benchmarks' own venv for peers that Blender's does not need (scikit-image: the
# marching-cubes peer of issue 17's field mesh), so bpy's numpy is never upgraded.
VENV_BENCH := .venv-bench
STAMP_BENCH := $(VENV_BENCH)/.thicket-bench
$(STAMP_BENCH):
	$(PYTHON) -m venv $(VENV_BENCH)
	$(VENV_BENCH)/bin/pip install -q --upgrade pip
	$(VENV_BENCH)/bin/pip install -q "scikit-image>=0.22,<1" numpy
	touch $@

# OpenSubdiv's own far_perf, the subdivision benchmark's peer, where apt can install it
# (the benchmark says so and goes on where it cannot).
far-perf:
	@command -v far_perf >/dev/null || { SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo -n); \
		$$SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq opensubdiv-tools >/dev/null 2>&1 || \
		echo "== far_perf (opensubdiv-tools) could not be installed: the subdivision benchmark runs without it"; }

bench: vulkan setup $(STAMP_BENCH) far-perf
	$(PY) tests/bench/bench_offset.py
	$(PY) tests/bench/bench_shell.py
	$(PY) tests/bench/bench_render.py
	$(PY) tests/bench/bench_subdivision.py
	cargo run --release -q -p thicket-core --example detail_bench -- --runs 3
	cargo run --release -q -p thicket-core --features test-support --example shell_bench
	cargo run --release -q -p thicket-core --features test-support --example cards_scaling -- --n 2000,8000,32000 $(BENCH_FLAGS)
	cargo run --release -q -p thicket-core --features test-support --example bake_bench
	cargo run --release -q -p thicket-core --example field_mesh_bench
	cargo run --release -q -p thicket-core --example implicit_mesh_bench -- --runs 3
	$(VENV_BENCH)/bin/python tests/bench/bench_field_peers.py
	cargo run --release -q -p thicket-peers
	cargo run --release -q -p thicket-core --example field_trace_bench
	cargo run --release -q -p thicket-render --example field_trace_gpu_bench
	cargo run --release -q -p thicket-render --example bake_fidelity
	cargo run --release -q -p thicket-render --example render_bench
	cargo run --release -q -p thicket-render --example shell_texturing_bench

clean:
	rm -rf build dist out target $(VENV) $(VENV_LTS) $(VENV_BENCH)
