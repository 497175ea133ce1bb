from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from fmionnx.core.diagnostics import Diagnostic, Span
from fmionnx.core.types import Causality, ComponentInterface, DType, Port
from fmionnx.lock.diff import LockContext, compare
from tests.lock.conftest import GAIN, with_port, write_and_read

SPAN = Span(Path("system.yaml"), 5, 3)


def check(tmp_path: Path, now: ComponentInterface, kind: str = "fmu") -> Diagnostic | None:
    loaded = write_and_read(tmp_path, GAIN)
    entry = loaded.lock.components["gain"]
    return compare("gain", kind, entry, now, SPAN, LockContext(loaded, "gain"))


def notes(diagnostic: Diagnostic | None) -> list[str]:
    assert diagnostic is not None
    return [f"{n.span.line if n.span else 0}: {n.message}" for n in diagnostic.notes]


def test_identical_interface_and_hash_is_silent(tmp_path: Path) -> None:
    assert check(tmp_path, GAIN) is None


def test_unit_change_is_e080_pointing_at_the_component_and_the_lock_line(tmp_path: Path) -> None:
    found = check(tmp_path, with_port(GAIN, "y", unit="mm"))
    assert found is not None
    assert found.code == "E080"
    assert found.span == SPAN
    assert found.message == (
        "component `gain`: the interface of `Gain.fmu` changed since it was locked in "
        "`system.fmionnx.lock` (1 change)"
    )
    assert notes(found) == ["19: `y`: unit changed from `m` to `mm`"]
    assert found.notes[0].span is not None
    assert found.notes[0].span.file.name == "system.fmionnx.lock"


def test_causality_type_and_shape_changes_are_each_named(tmp_path: Path) -> None:
    now = with_port(GAIN, "w", causality=Causality.INPUT, dtype=DType.FLOAT32, shape=(4,))
    assert notes(check(tmp_path, now)) == [
        "18: `w`: causality changed from output to input",
        "18: `w`: type changed from float64 to float32",
        "18: `w`: shape changed from [3] to [4]",
    ]


def test_output_becoming_local_is_a_causality_change_not_a_removal(tmp_path: Path) -> None:
    now = with_port(GAIN, "y", causality=Causality.LOCAL)
    assert notes(check(tmp_path, now)) == ["19: `y`: causality changed from output to local"]


def test_added_and_removed_ports(tmp_path: Path) -> None:
    kept = [p for p in GAIN.ports if p.name != "k"]
    ports = (*kept, Port("reset", Causality.INPUT, DType.BOOL))
    assert notes(check(tmp_path, replace(GAIN, ports=ports))) == [
        "16: `k` removed (was parameter float64)",
        "15: `reset` added (input bool)",
    ]


def test_one_removed_and_one_added_with_the_same_signature_looks_renamed(tmp_path: Path) -> None:
    now = with_port(GAIN, "u", name="u_in")
    assert notes(check(tmp_path, now)) == [
        "17: `u` removed and `u_in` added, both input float64 (m): renamed?"
    ]


def test_added_local_variables_do_not_change_the_interface(tmp_path: Path) -> None:
    now = replace(GAIN, ports=(*GAIN.ports, Port("tmp", Causality.LOCAL, DType.INT32)))
    assert check(tmp_path, now) is None


def test_fmi_version_change_is_an_interface_change(tmp_path: Path) -> None:
    now = replace(
        GAIN, facts=(("fmiVersion", "3.0"), ("guid", "{1234}"), ("interfaceTypes", "cs,me"))
    )
    assert notes(check(tmp_path, now)) == ["12: fmiVersion changed from `2.0` to `3.0`"]


def test_kind_change_is_an_interface_change(tmp_path: Path) -> None:
    assert notes(check(tmp_path, GAIN, kind="onnx")) == ["8: kind changed from `fmu` to `onnx`"]


def test_new_binary_with_same_interface_is_i080_with_what_changed(tmp_path: Path) -> None:
    now = replace(
        GAIN,
        content_hash="b" * 64,
        facts=(("fmiVersion", "2.0"), ("guid", "{5678}"), ("interfaceTypes", "cs,me")),
    )
    found = check(tmp_path, now)
    assert found is not None
    assert found.code == "I080"
    assert found.message == (
        "component `gain`: `Gain.fmu` changed since it was locked in `system.fmionnx.lock`, "
        "its interface did not"
    )
    assert notes(found) == [
        "10: sha256 changed from aaaaaaaaaaaa… to bbbbbbbbbbbb…",
        "13: guid changed from `{1234}` to `{5678}`",
    ]
