from __future__ import annotations

from pathlib import Path

import pytest

from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.lock.model import lock_path, yaml_str
from fmionnx.lock.read import read_lock
from tests.lock.conftest import GAIN, write_and_read

EXPECTED = """\
# Interface lock of system.yaml, written by `fmionnx lock`.
# `fmionnx validate --locked` fails when a model's interface no longer matches it.
# After an intended change: `fmionnx lock system.yaml`, then commit this file.
fmionnx-lock: 1
system: system.yaml
components:
  gain:
    kind: fmu
    path: Gain.fmu
    sha256: "aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa"
    facts:
      fmiVersion: "2.0"
      guid: "{1234}"
      interfaceTypes: "cs,me"
    ports:
      - {name: k, causality: parameter, dtype: float64, shape: []}
      - {name: u, causality: input, dtype: float64, shape: [], unit: m}
      - {name: w, causality: output, dtype: float64, shape: [3], unit: m}
      - {name: y, causality: output, dtype: float64, shape: [], unit: m}
"""


def test_lock_is_sorted_one_port_per_line_without_locals(tmp_path: Path) -> None:
    write_and_read(tmp_path, GAIN)
    assert (tmp_path / "system.fmionnx.lock").read_text(encoding="utf-8") == EXPECTED


def test_lock_file_sits_beside_the_system_named_after_its_stem() -> None:
    assert lock_path(Path("systems/robot.yaml")) == Path("systems/robot.fmionnx.lock")


@pytest.mark.parametrize(
    "text",
    ["plain", "a.b/c-d", "true", "no", "", "x[1]", "a: b", "{x}", "der(x)", "é", "#c", "1e3", "\n"],
)
def test_names_round_trip_through_the_lock(tmp_path: Path, text: str) -> None:
    from tests.lock.conftest import with_port

    weird = with_port(GAIN, "u", name=text, unit=text or None)
    loaded = write_and_read(tmp_path, weird)
    names = [p.name for p in loaded.lock.components["gain"].ports]
    assert text in names
    assert yaml_str(text) == text or yaml_str(text).startswith('"')


def _read(tmp_path: Path, text: str) -> list[str]:
    path = tmp_path / "s.fmionnx.lock"
    path.write_text(text, encoding="utf-8")
    bag = DiagnosticBag()
    assert read_lock(path, tmp_path / "s.yaml", bag) is None
    return [f"{d.code} {d.span.line if d.span else 0}: {d.message}" for d in bag.sorted()]


def test_missing_lock_is_e081_on_the_system_file(tmp_path: Path) -> None:
    bag = DiagnosticBag()
    assert read_lock(tmp_path / "s.fmionnx.lock", tmp_path / "s.yaml", bag) is None
    (diagnostic,) = bag
    assert diagnostic.code == "E081"
    assert diagnostic.span is not None
    assert diagnostic.span.file == tmp_path / "s.yaml"
    assert (
        diagnostic.hint == f"run `fmionnx lock {tmp_path / 's.yaml'}` and commit `s.fmionnx.lock`"
    )


def test_broken_yaml_in_the_lock_is_e082_at_its_line(tmp_path: Path) -> None:
    found = _read(tmp_path, "fmionnx-lock: 1\nsystem: s.yaml\ncomponents: {a: [}\n")
    assert len(found) == 1
    assert found[0].startswith("E082 3: lock file `s.fmionnx.lock`: invalid YAML")


def test_unknown_lock_version_is_e082(tmp_path: Path) -> None:
    found = _read(tmp_path, "fmionnx-lock: 7\nsystem: s.yaml\ncomponents: {}\n")
    assert found == [
        "E082 1: lock file version `7` is not supported (this release writes `fmionnx-lock: 1`)"
    ]


def test_bad_port_entry_is_e082_at_the_port_line(tmp_path: Path) -> None:
    text = EXPECTED.replace("dtype: float64, shape: [3]", "dtype: float65, shape: [3]")
    found = _read(tmp_path, text)
    assert len(found) == 1
    assert found[0].startswith("E082 18: lock file `s.fmionnx.lock`: ")
    assert "float65" in found[0]
