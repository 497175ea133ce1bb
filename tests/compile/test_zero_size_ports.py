"""Array ports of no elements (FMI 3 lets a dimension be 0): a system input, a ``--param``
and plot marks say what such a port holds, and a system input is refused on it (it was
accepted as a port of one element)."""

from __future__ import annotations

import zipfile
from pathlib import Path

import pytest

from fmionnx import api
from fmionnx.api import OverrideError
from tests.conftest import build_fixture_fmu


def _empty_vector(folder: Path) -> Path:
    """Vector3 unpacked, its arrays ``u`` and ``y`` of no elements."""
    with zipfile.ZipFile(build_fixture_fmu("Vector3")) as archive:
        archive.extractall(folder)
    description = folder / "modelDescription.xml"
    text = description.read_text(encoding="utf-8")
    emptied = text.replace('start="0 0 0"', 'start=""').replace(
        '<Dimension start="3"/>', '<Dimension start="0"/>'
    )
    assert emptied.count('<Dimension start="0"/>') == 2
    description.write_text(emptied, encoding="utf-8")
    return folder


def _errors(tmp_path: Path, extra: str) -> list[str]:
    fmu = _empty_vector(tmp_path / "Empty")
    path = tmp_path / "system.yaml"
    path.write_text(
        f"fmionnx: 1\nname: empty\nrun: {{stop: 0.3, step: 0.1}}\n"
        f"components:\n  v: {{kind: fmu, path: {fmu}}}\n{extra}",
        encoding="utf-8",
    )
    result = api.compile_system(path)
    return [f"{d.code} {d.message} | {d.hint}" for d in result.diagnostics if d.code[0] == "E"]


def test_a_system_input_on_a_port_of_no_elements_is_refused(tmp_path: Path) -> None:
    (error,) = _errors(tmp_path, "inputs:\n  level: {to: [v.u], value: 1}\n")
    assert error.startswith(
        "E044 system input `level` reaches `v.u`: a system input sets one value on a port of "
        "one element"
    )


def test_plot_marks_on_a_port_of_no_elements_say_so(tmp_path: Path) -> None:
    (error,) = _errors(tmp_path, "plots:\n  - {y: [v.count], marks: {of: v.y}}\n")
    assert error == (
        "E046 plot marks: follow one signal; `v.y` has 0 elements | follow another signal"
    )


def test_a_param_on_a_port_of_no_elements_takes_no_value(tmp_path: Path) -> None:
    assert _errors(tmp_path, "") == []
    loaded = api.load(tmp_path / "system.yaml")
    with pytest.raises(
        OverrideError, match=r"expected 0 value\(s\) of type float64 \(shape \[0\]\)"
    ):
        loaded.with_overrides(params={"v.u": 1.0})
    assert loaded.with_overrides(params={"v.u": []}).compiled is not None


def test_a_ros2_proxy_of_a_port_of_no_elements_holds_none(tmp_path: Path) -> None:
    """The buffer standing in for another node's output: it had one element."""
    from fmionnx.backends.ros2.node import ProxyRunner

    assert _errors(tmp_path, "") == []
    system = api.compile_system(tmp_path / "system.yaml").system
    assert system is not None
    proxy = ProxyRunner(system.component("v"))
    assert proxy.output_buffer("y").size == 0
    assert proxy.output_buffer("count").size == 1
