"""Every value set before initialization carries its source in the compiled system (issue #33).

``run.json`` writes ``parameters`` from these fields; nothing is reconstructed from the file.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import fmionnx
from fmionnx.compile.ir import CompiledSystem
from fmionnx.compile.overrides import override_parameter
from fmionnx.compile.studyir import Setting, apply_setting
from fmionnx.core.types import ValueSource


def _system(tmp_path: Path, fixture_fmu: Callable[[str], Path]) -> Path:
    path = tmp_path / "system.yaml"
    path.write_text(
        "fmionnx: 1\nname: g\nrun: {stop: 0.1, step: 0.05}\ncomponents:\n"
        f"  g: {{kind: fmu, path: {fixture_fmu('Gain')}, parameters: {{k: 3.0}}}}\n"
    )
    return path


def _sources(compiled: CompiledSystem) -> dict[str, tuple[object, ValueSource]]:
    return {p.port: (p.value[0], p.source) for p in compiled.component("g").parameters}


def test_a_system_file_value_then_an_override_then_a_study_setting(
    tmp_path: Path, fixture_fmu: Callable[[str], Path]
) -> None:
    compiled = fmionnx.load(_system(tmp_path, fixture_fmu)).compiled
    assert _sources(compiled) == {"k": (3.0, ValueSource.SYSTEM_FILE)}
    overridden = override_parameter(compiled, "g.u", 2.0)
    assert _sources(overridden) == {
        "k": (3.0, ValueSource.SYSTEM_FILE),
        "u": (2.0, ValueSource.COMMAND_LINE),
    }
    studied = apply_setting(overridden, Setting("g.k", "parameter", 5.0))
    assert _sources(studied) == {
        "u": (2.0, ValueSource.COMMAND_LINE),
        "k": (5.0, ValueSource.STUDY),
    }
