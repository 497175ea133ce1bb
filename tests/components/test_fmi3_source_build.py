"""``fmionnx build-fmu`` on an FMI 3 source FMU laid out like the Reference FMUs (issue #13).

``Scale3`` ships its own ``fmi3Functions.h`` under ``sources/include`` (an ``IncludeDirectory``)
and a ``config.h`` that defines ``FMI3_FUNCTION_PREFIX``; its gain and offset come from two
``PreprocessorDefinition`` elements (one with a value, one without). A build that follows the
standard exports unprefixed names and honours the definitions: ``y = 3*u + 0.5``.
"""

from __future__ import annotations

import csv
import shutil
import zipfile
from pathlib import Path

from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.kinds.fmu.elfsymbols import exported_symbols
from tests.conftest import FIXTURES

SCALE3 = FIXTURES / "fmus" / "Scale3"
LIBRARY = "binaries/x86_64-linux/Scale3.so"

SYSTEM = """\
fmionnx: 1
name: scale
run: {stop: 0.03, step: 0.01}
record: [a.y, b.y]
components:
  a: {kind: fmu, path: Scale3.fmu, parameters: {u: 2.0}}
  b: {kind: fmu, path: Scale3.fmu}
connections:
  - a.y -> b.u
"""


def _cli(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, list(args), env={"COLUMNS": "1000"})
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    return result.exit_code, result.output


def test_the_built_fmi3_library_exports_unprefixed_names(tmp_path: Path) -> None:
    out = tmp_path / "Scale3.fmu"
    code, output = _cli("build-fmu", str(SCALE3), "-o", str(out))
    assert code == 0, output
    names = exported_symbols(zipfile.ZipFile(out).read(LIBRARY))
    assert {"fmi3InstantiateCoSimulation", "fmi3DoStep", "fmi3GetFloat64"} <= names
    assert not any(name.startswith("Scale3_") for name in names)


def test_a_built_fmi3_source_fmu_runs_with_its_own_definitions(tmp_path: Path) -> None:
    code, output = _cli("build-fmu", str(SCALE3), "-o", str(tmp_path / "Scale3.fmu"))
    assert code == 0, output
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    code, output = _cli("run", str(tmp_path / "system.yaml"), "--out", str(tmp_path / "out"))
    assert code == 0, output
    with (tmp_path / "out" / "results.csv").open(encoding="utf-8") as file:
        rows = list(csv.DictReader(file))
    assert len(rows) == 4
    assert all(float(row["a.y"]) == 3.0 * 2.0 + 0.5 for row in rows)  # gain 3, offset 0.5
    assert all(float(row["b.y"]) == 3.0 * 6.5 + 0.5 for row in rows[1:])  # b.u from a.y


def test_a_definition_that_is_not_a_c_identifier_is_refused(tmp_path: Path) -> None:
    source = tmp_path / "Scale3"
    shutil.copytree(SCALE3, source)
    build = source / "sources" / "buildDescription.xml"
    build.write_text(build.read_text().replace('name="SCALE3_WITH_OFFSET"', 'name="A B"'))
    code, output = _cli("build-fmu", str(source), "-o", str(tmp_path / "x.fmu"))
    assert code == 1
    assert "E012" in output
    assert "not a C identifier" in output
    assert "Traceback" not in output
