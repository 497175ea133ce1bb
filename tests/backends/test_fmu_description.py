"""The model description of an FMU is parsed once and shared by compiling and every instance."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from pathlib import Path

import fmpy
import fmpy.model_description
import pytest

import fmionnx
from fmionnx.kinds.cache import clear_cache
from fmionnx.kinds.fmu.description import clear_descriptions
from fmionnx.runtime.result import RunStatus


@pytest.fixture
def parses(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[str]]:
    """Each fmpy parse of a model description, counted from empty caches.

    fmpy exports the function from its package and from the module that defines it; both
    names are counted, so a caller using either is seen.
    """
    clear_cache()
    clear_descriptions()
    seen: list[str] = []
    original = fmpy.model_description.read_model_description

    def counting(filename: object, *args: object, **kwargs: object) -> object:
        seen.append(str(filename))
        return original(filename, *args, **kwargs)

    monkeypatch.setattr(fmpy.model_description, "read_model_description", counting)
    monkeypatch.setattr(fmpy, "read_model_description", counting)
    yield seen
    clear_cache()
    clear_descriptions()


def _two_instances(write_system, fmu: Path, interface: str) -> Path:
    return write_system(
        f"""
fmionnx: 1
name: twins
run: {{stop: 0.1, step: 0.01}}
components:
  a: {{kind: fmu, path: {fmu}, interface: {interface}, parameters: {{u: 1.5}}}}
  b: {{kind: fmu, path: {fmu}, interface: {interface}}}
connections:
  - a.y -> b.u
"""
    )


@pytest.mark.parametrize("interface", ["cs", "me"])
def test_two_instances_of_one_fmu_parse_its_description_once(
    fixture_fmu, write_system, parses: list[str], interface: str
) -> None:
    system = fmionnx.load(_two_instances(write_system, fixture_fmu("Gain"), interface))
    assert len(parses) == 1  # compiling
    assert system.run(isolate="none").status is RunStatus.COMPLETED
    assert len(parses) == 1  # both instances reuse the compile-time parse
    clear_descriptions()  # as in a process that did not compile the system
    assert system.run(isolate="none").status is RunStatus.COMPLETED
    assert len(parses) == 2  # one parse for the run, shared by both instances


def test_a_single_fmu_is_parsed_once_for_its_interface_run_and_column_names(
    fixture_fmu, parses: list[str]
) -> None:
    system = fmionnx.load(fixture_fmu("Vector3"), step=0.1)
    assert system.run(isolate="none", stop_time=0.2).status is RunStatus.COMPLETED
    assert len(parses) == 1


def test_a_changed_fmu_is_parsed_again(
    fixture_fmu, write_system, parses: list[str], tmp_path: Path
) -> None:
    fmu = tmp_path / "Gain.fmu"
    shutil.copy(fixture_fmu("Gain"), fmu)
    system = fmionnx.load(_two_instances(write_system, fmu, "cs"))
    assert system.run(isolate="none").status is RunStatus.COMPLETED
    assert len(parses) == 1
    os.utime(fmu, ns=(1, 1))  # same content, new identity
    assert system.run(isolate="none").status is RunStatus.COMPLETED
    assert len(parses) == 2
