# fmionnx: the two commands are `make demo` and `make test`; everything else is a step of them.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
# pytest workers of `make test` (pytest-xdist): CI machines have 2 cores. Each test file runs on
# one worker, every DDS test on one, every Zenoh test on one (tests/conftest.py's scheduler).
TEST_WORKERS ?= 2
# One set-up path, two sets of extras, one stamp each: the demo needs the package alone; the
# tests add `.[test]` (pytest, linters, libcosimpy, and ROS 2 Jazzy's rclpy wheels, whose
# bootstrapper re-executes every Python process of the venv). `.[test]` includes the demo's
# set, so installing it renews the demo stamp too.
DEMO_STAMP := $(VENV)/.installed-demo
# setuptools announces every editable install with a boxed warning about folders named like
# the package (`fmionnx/` is the package here: nothing to act on). pip passes the variable
# to the build backend; the filter matches that one message and no other warning.
QUIET_EDITABLE := PYTHONWARNINGS="ignore:Editable installation"
TEST_STAMP := $(VENV)/.installed-test
BUILD := build
DEMO_OUT := out/demo

.PHONY: help setup setup-demo setup-test system-deps bytecode models demo examples test lint typecheck schema bench fuzz soak docs clean

help:
	@echo "make demo   - set up (the package alone), build the models, run the reference scenario"
	@echo "make test   - set up (with the test extras), build the models, run linters and the whole test suite"
	@echo "make examples - run every example in examples/ (one line each: name, pass/fail, time)"
	@echo "make bench  - run the benchmarks and print their tables"
	@echo "make fuzz   - run the fuzzers (tests/fuzz) with the long budget: thousands of inputs each"
	@echo "make soak   - run the reference scenario for a simulated hour, watching RSS, files, threads"
	@echo "make schema - regenerate schemas/system.schema.json and study.schema.json"

setup-demo: $(DEMO_STAMP)
setup-test: $(TEST_STAMP)
setup: setup-test

# Debian packages the project needs at run time: EGL/Mesa for headless MuJoCo rendering, a C
# toolchain and cmake for building FMUs from source. Installed only when missing (needs root).
system-deps:
	@bash tools/system-deps.sh

# Installing also builds the native kernel (setup.py): its inputs make the stamp stale too.
NATIVE_KERNEL := setup.py fmionnx/runtime/native/fmi2_group.c fmionnx/runtime/native/manifest.py

INSTALL_INPUTS := pyproject.toml $(NATIVE_KERNEL)

$(PY): | system-deps
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(DEMO_STAMP): $(INSTALL_INPUTS) | $(PY)
	$(QUIET_EDITABLE) $(PY) -m pip install --quiet -e .
	touch $(DEMO_STAMP)

$(TEST_STAMP): $(INSTALL_INPUTS) | $(PY)
	$(QUIET_EDITABLE) $(PY) -m pip install --quiet -e '.[test]'
	@# ROS 2's rosidl-parser wheel needs the old `lark-parser`, which ships the same `lark`
	@# package as fmpy's `lark` 1.x: whichever pip unpacks last wins. Make it lark 1.x.
	$(PY) -m pip install --quiet --no-deps --force-reinstall \
	  "lark==$$($(PY) -c 'from importlib.metadata import version; print(version("lark"))')"
	touch $(TEST_STAMP) $(DEMO_STAMP)

# Byte-compile the package: an editable install leaves that to the first import, and where
# PYTHONDONTWRITEBYTECODE is set (CI images, containers) no import writes the cache, so every
# fmionnx process (each ROS 2 node, study worker and isolated model) compiled the package's
# sources again: 0.2 s of CPU a process. compileall rewrites only what changed.
bytecode: $(DEMO_STAMP)
	@$(PY) -m compileall -q -j 0 fmionnx

models: $(DEMO_STAMP) bytecode
	$(PY) models/build.py --out $(BUILD)/models

demo: models
	$(VENV)/bin/fmionnx run systems/sign_follower.yaml --out $(DEMO_OUT)

# Every example's README commands, outputs in build/examples/ (about two minutes on
# 2 cores), and the READMEs' tables and pictures compared with the run; the examples
# need the package alone, so the demo's set-up suffices.
examples: models
	$(PY) examples/run_all.py

lint: $(TEST_STAMP)
	$(VENV)/bin/ruff check fmionnx tests models benchmarks examples tools
	$(VENV)/bin/ruff format --check fmionnx tests models benchmarks examples tools docs README.md
	$(VENV)/bin/mypy
	$(VENV)/bin/mypy examples

schema: $(DEMO_STAMP)
	$(VENV)/bin/fmionnx schema -o schemas/system.schema.json
	$(VENV)/bin/fmionnx schema --study -o schemas/study.schema.json

test: $(TEST_STAMP) models lint examples
	$(VENV)/bin/pytest -q -p no:cacheprovider -n $(TEST_WORKERS) --dist loadscope -m "not slow" --durations=30

bench: $(TEST_STAMP) models
	$(PY) benchmarks/run.py

# `make test` runs the same fuzzers with a short, derandomized budget (tests/fuzz/conftest.py).
fuzz: $(TEST_STAMP) models
	FMIONNX_FUZZ=long $(VENV)/bin/pytest -q -p no:cacheprovider tests/fuzz

soak: $(TEST_STAMP) models
	$(VENV)/bin/pytest -q -p no:cacheprovider -m slow
	$(PY) benchmarks/soak.py

docs: $(DEMO_STAMP)
	$(PY) -m pip install --quiet mkdocs
	$(VENV)/bin/mkdocs build --strict

clean:
	rm -rf $(BUILD) out .pytest_cache .mypy_cache .ruff_cache
