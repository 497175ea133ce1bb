"""The kind table imports a kind's module when the kind is first used (issue #14).

A run of one FMU uses one kind; the table must still list every kind by name, in its order,
and give the same kind objects as before.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from fmionnx.kinds.registry import COMPONENT_KINDS, KIND_LIBRARIES, KIND_SUFFIXES

KIND_MODULES = ("fmionnx.kinds.fmu.kind", "fmionnx.kinds.onnx.kind", "fmionnx.kinds.mujoco.kind")
KIND_MODULES += ("fmionnx.kinds.signal.kind",)


def loaded_after(code: str) -> list[str]:
    """The kind modules imported after running ``code`` in a fresh interpreter."""
    probe = (
        f"import sys\n{code}\nprint(','.join(m for m in {KIND_MODULES!r} if m in sys.modules))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True, timeout=60
    )
    return [m for m in done.stdout.strip().split(",") if m]


def test_the_table_alone_imports_no_kind() -> None:
    code = (
        "from fmionnx.kinds.registry import COMPONENT_KINDS as K\n"
        "assert list(K) == ['fmu', 'onnx', 'mujoco', 'signal'] and len(K) == 4\n"
        "assert 'onnx' in K and 'nope' not in K and K.get('nope') is None"
    )
    assert loaded_after(code) == []


def test_asking_for_a_kind_imports_that_kind_only() -> None:
    code = "from fmionnx.kinds.registry import COMPONENT_KINDS as K\nK['fmu'].resolve"
    assert loaded_after(code) == ["fmionnx.kinds.fmu.kind"]


def test_listing_the_kinds_imports_them_all() -> None:
    code = "from fmionnx.kinds.registry import COMPONENT_KINDS as K\nlist(K.values())"
    assert loaded_after(code) == list(KIND_MODULES)


@pytest.mark.parametrize("name", list(COMPONENT_KINDS))
def test_each_entry_is_the_kind_of_its_name(name: str) -> None:
    kind = COMPONENT_KINDS[name]
    assert kind.name == name
    assert COMPONENT_KINDS[name] is kind  # imported once


def test_the_libraries_run_json_versions_are_the_kinds_own() -> None:
    assert list(KIND_LIBRARIES) == list(COMPONENT_KINDS)
    assert {n: k.libraries for n, k in COMPONENT_KINDS.items()} == dict(KIND_LIBRARIES)


def test_the_suffixes_lone_models_are_found_by_are_the_kinds_own() -> None:
    assert list(KIND_SUFFIXES) == list(COMPONENT_KINDS)
    assert {n: k.suffixes for n, k in COMPONENT_KINDS.items()} == dict(KIND_SUFFIXES)


def test_a_lone_model_imports_its_own_kind_only() -> None:
    code = (
        "from pathlib import Path\n"
        "from fmionnx.kinds.registry import kind_for_path\n"
        "assert kind_for_path(Path('model.fmu')).name == 'fmu'"
    )
    assert loaded_after(code) == ["fmionnx.kinds.fmu.kind"]


def test_an_unknown_kind_is_a_key_error() -> None:
    with pytest.raises(KeyError):
        COMPONENT_KINDS["nope"]
