# fmionnx: the two commands are `make demo` and `make test`; everything else is a step of them.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
BUILD := build
DEMO_OUT := out/demo

.PHONY: help setup system-deps models demo test lint typecheck schema bench docs clean

help:
	@echo "make demo   - set up, build the models, run the reference scenario"
	@echo "make test   - set up, build the models, run linters and the whole test suite"
	@echo "make bench  - run the benchmarks and print their tables"
	@echo "make schema - regenerate schemas/system.schema.json"

setup: $(STAMP)

# Debian packages the project needs at run time: EGL/Mesa for headless MuJoCo rendering, a C
# toolchain and cmake for building FMUs from source. Installed only when missing (needs root).
system-deps:
	@bash tools/system-deps.sh

# Installing also builds the native kernel (setup.py): its inputs make the stamp stale too.
NATIVE_KERNEL := setup.py fmionnx/runtime/native/fmi2_group.c fmionnx/runtime/native/manifest.py

$(STAMP): pyproject.toml $(NATIVE_KERNEL) | system-deps
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[test]'
	@# ROS 2's rosidl-parser wheel needs the old `lark-parser`, which ships the same `lark`
	@# package as fmpy's `lark` 1.x: whichever pip unpacks last wins. Make it lark 1.x.
	$(PY) -m pip install --quiet --no-deps --force-reinstall \
	  "lark==$$($(PY) -c 'from importlib.metadata import version; print(version("lark"))')"
	touch $(STAMP)

models: $(STAMP)
	$(PY) models/build.py --out $(BUILD)/models

demo: models
	$(VENV)/bin/fmionnx run systems/sign_follower.yaml --out $(DEMO_OUT)

lint: $(STAMP)
	$(VENV)/bin/ruff check fmionnx tests models benchmarks
	$(VENV)/bin/mypy

schema: $(STAMP)
	$(VENV)/bin/fmionnx schema -o schemas/system.schema.json

test: models lint
	$(VENV)/bin/pytest -q -p no:cacheprovider

bench: models
	$(PY) benchmarks/run.py

docs: $(STAMP)
	$(PY) -m pip install --quiet mkdocs
	$(VENV)/bin/mkdocs build --strict

clean:
	rm -rf $(BUILD) out .pytest_cache .mypy_cache .ruff_cache
