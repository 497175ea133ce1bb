"""FMI 3 unsigned integers' ``min``/``max`` (a leftover of a bug hunt): fmpy reads the bounds
of ``Float*`` and ``Int*`` variables only, so a ``UInt32`` port declared ``max="9"`` had none
and a value above it was set on the model without a word. fmionnx reads them from the XML.

The FMU is the real ``Types3`` fixture (built from C), unpacked, with bounds added to its
unsigned inputs' declarations.
"""

from __future__ import annotations

import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest

import fmionnx
from fmionnx.core.errors import DiagnosticError

BuildFmu = Callable[[str], Path]


def _bounded_types3(folder: Path, fixture_fmu: BuildFmu) -> Path:
    unpacked = folder / "T"
    with zipfile.ZipFile(fixture_fmu("Types3")) as archive:
        archive.extractall(unpacked)
    description = unpacked / "modelDescription.xml"
    text = description.read_text("utf-8")
    for name, bounds in (
        ("u_u8", 'min="2" max="200"'),
        ("u_u32", 'max="9"'),
        ("u_u64", 'min="5" max="18446744073709551615"'),
    ):
        text = text.replace(f'name="{name}"', f'name="{name}" {bounds}', 1)
    description.write_text(text, "utf-8")
    return unpacked


def _system(folder: Path, fmu: Path, parameters: str) -> Path:
    path = folder / "system.yaml"
    path.write_text(
        "fmionnx: 1\nname: bounded\nrun: {stop: 0.2, step: 0.1}\ncomponents:\n"
        f"  t: {{kind: fmu, path: {fmu}, parameters: {parameters}}}\n",
        encoding="utf-8",
    )
    return path


def test_unsigned_ports_have_the_bounds_their_xml_declares(
    tmp_path: Path, fixture_fmu: BuildFmu
) -> None:
    fmu = _bounded_types3(tmp_path, fixture_fmu)
    compiled = fmionnx.load(_system(tmp_path, fmu, "{u_u8: 2, u_u32: 9, u_u64: 5}")).compiled
    ports = {p.name: p for p in compiled.component("t").interface.ports}
    assert ports["u_u8"].bounds == (2, 200)
    assert ports["u_u32"].bounds == (None, 9)
    assert ports["u_u64"].bounds == (5, 2**64 - 1)
    assert ports["u_i32"].bounds == (None, None)  # none declared: none made up


@pytest.mark.parametrize(
    ("parameters", "said"), [("{u_u32: 10}", "t.u_u32"), ("{u_u8: 1}", "t.u_u8")]
)
def test_a_value_outside_an_unsigned_ports_bounds_is_e043(
    tmp_path: Path, fixture_fmu: BuildFmu, parameters: str, said: str
) -> None:
    fmu = _bounded_types3(tmp_path, fixture_fmu)
    with pytest.raises(DiagnosticError) as refused:
        fmionnx.load(_system(tmp_path, fmu, parameters))
    (error,) = refused.value.diagnostics
    assert error.code == "E043"
    assert said in error.message
