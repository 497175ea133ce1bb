"""``fmionnx lock`` and ``validate --locked`` on real models rebuilt from changed sources."""

from __future__ import annotations

import re
import shutil
from collections.abc import Callable
from pathlib import Path

import onnx
import pytest
from onnx import TensorProto, helper
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.kinds.fmu.build import build_fmu
from tests.conftest import FIXTURES, build_fixture_fmu

SYSTEM = """\
fmionnx: 1
name: locked
run: {stop: 1, step: 0.01}
components:
  gain: {kind: fmu, path: Gain.fmu}
  integ: {kind: fmu, path: Integrator.fmu}
  net: {kind: onnx, path: net.onnx}
connections:
  - gain.y -> integ.u
  - integ.x -> net.x
"""


def make_onnx(path: Path, name: str = "x", shape: tuple[int, ...] = (1,)) -> None:
    """``y = input``: float64 tensors, opset 17."""
    graph = helper.make_graph(
        [helper.make_node("Identity", [name], ["y"])],
        "net",
        [helper.make_tensor_value_info(name, TensorProto.DOUBLE, list(shape))],
        [helper.make_tensor_value_info("y", TensorProto.DOUBLE, list(shape))],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, path)


@pytest.fixture(scope="session")
def gain_fmu() -> Path:
    return build_fixture_fmu("Gain")


@pytest.fixture
def project(gain_fmu: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A system of real models in ``tmp_path`` (the working directory), locked."""
    shutil.copytree(FIXTURES / "fmus" / "Gain", tmp_path / "src" / "Gain")
    shutil.copy(gain_fmu, tmp_path / "Gain.fmu")
    shutil.copy(build_fixture_fmu("Integrator"), tmp_path / "Integrator.fmu")
    make_onnx(tmp_path / "net.onnx")
    (tmp_path / "system.yaml").write_text(SYSTEM, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "300")
    locked = cli("lock", "system.yaml")
    assert locked.exit_code == 0, locked.output
    return tmp_path


class Run:
    def __init__(self, exit_code: int, output: str) -> None:
        self.exit_code = exit_code
        self.output = output


def cli(*args: str) -> Run:
    result = CliRunner().invoke(app, list(args), catch_exceptions=False)
    return Run(result.exit_code, result.output)


def validate_locked(*extra: str) -> Run:
    return cli("validate", "--locked", "system.yaml", *extra)


def rebuild_gain(project: Path, edit: Callable[[str], str] | None = None) -> None:
    """Edit the Gain source's modelDescription.xml and rebuild Gain.fmu from it."""
    description = project / "src" / "Gain" / "modelDescription.xml"
    if edit is not None:
        text = description.read_text(encoding="utf-8")
        changed = edit(text)
        assert changed != text
        description.write_text(changed, encoding="utf-8")
    build_fmu(project / "src" / "Gain", project / "Gain.fmu")


def test_lock_writes_a_lock_beside_the_system_and_locked_validation_passes(project: Path) -> None:
    text = (project / "system.fmionnx.lock").read_text(encoding="utf-8")
    assert "fmionnx-lock: 1" in text
    assert "      - {name: y, causality: output, dtype: float64, shape: [], unit: m}" in text
    assert '{name: "der(x)"' not in text  # a local variable
    result = validate_locked()
    assert result.exit_code == 0, result.output
    assert "E08" not in result.output
    assert "I080" not in result.output


def test_locking_again_without_changes_leaves_the_file_alone(project: Path) -> None:
    lock = project / "system.fmionnx.lock"
    before = lock.stat().st_mtime_ns
    result = cli("lock", "system.yaml")
    assert result.exit_code == 0
    assert result.output == "up to date: system.fmionnx.lock\n"
    assert lock.stat().st_mtime_ns == before


def test_rebuilding_the_unchanged_source_passes(project: Path) -> None:
    rebuild_gain(project)
    result = validate_locked()
    assert result.exit_code == 0, result.output
    assert "E080" not in result.output


def _unit_mm(text: str) -> str:
    text = text.replace(
        '<Unit name="m"><BaseUnit m="1"/></Unit>',
        '<Unit name="m"><BaseUnit m="1"/></Unit>\n    <Unit name="mm"><BaseUnit m="1" factor="0.001"/></Unit>',
    )
    return text.replace('description="k*u"><Real unit="m"/>', 'description="k*u"><Real unit="mm"/>')


def _k_input(text: str) -> str:
    return text.replace(
        'name="k" valueReference="1" causality="parameter" variability="fixed"',
        'name="k" valueReference="1" causality="input"',
    )


def _y_integer(text: str) -> str:
    # FMI 2: an Integer variable is discrete, never continuous.
    text = text.replace(
        'causality="output" description="k*u"',
        'causality="output" variability="discrete" description="k*u"',
    )
    return text.replace('description="k*u"><Real unit="m"/>', 'description="k*u"><Integer/>')


@pytest.mark.parametrize(
    ("edit", "notes"),
    [
        (_unit_mm, ["`y`: unit changed from `m` to `mm`"]),
        (_k_input, ["`k`: causality changed from parameter to input"]),
        (
            _y_integer,
            ["`y`: type changed from float64 to int32", "`y`: unit changed from `m` to no unit"],
        ),
    ],
    ids=["unit", "causality", "type"],
)
def test_changed_fmu_source_fails_locked_validation_with_the_diff(
    project: Path, edit: Callable[[str], str], notes: list[str]
) -> None:
    rebuild_gain(project, edit)
    result = validate_locked()
    assert result.exit_code == 1, result.output
    assert (
        "system.yaml:5:3: error[E080 lock-interface-changed]: component `gain`: the interface of "
        f"`Gain.fmu` changed since it was locked in `system.fmionnx.lock` ({len(notes)} change"
    ) in result.output
    for note in notes:
        pattern = rf"^  note: system\.fmionnx\.lock:\d+:\d+: {re.escape(note)}$"
        assert re.search(pattern, result.output, re.MULTILINE), result.output
    assert "hint: if the change is intended" in result.output


def test_the_diff_notes_name_the_lock_file_line(project: Path) -> None:
    rebuild_gain(project, _unit_mm)
    lines = (project / "system.fmionnx.lock").read_text(encoding="utf-8").splitlines()
    y_line = next(i for i, line in enumerate(lines, 1) if "{name: y," in line)
    assert f"note: system.fmionnx.lock:{y_line}:9: `y`: unit changed" in validate_locked().output


def test_changed_onnx_shape_fails_locked_validation(project: Path) -> None:
    make_onnx(project / "net.onnx", shape=(2,))
    result = validate_locked()
    assert result.exit_code == 1
    assert "error[E080 lock-interface-changed]: component `net`" in result.output
    assert "`x`: shape changed from [1] to [2]" in result.output
    assert "`y`: shape changed from [1] to [2]" in result.output


def test_renamed_onnx_input_looks_renamed(project: Path) -> None:
    make_onnx(project / "net.onnx", name="x_in")
    result = validate_locked()
    assert result.exit_code == 1
    assert "`x` removed and `x_in` added, both input float64[1]: renamed?" in result.output


def test_json_report_carries_the_lock_diff(project: Path) -> None:
    import json

    rebuild_gain(project, _unit_mm)
    result = validate_locked("--format", "json")
    report = json.loads(result.output)
    (lock_error,) = [d for d in report["files"][0]["diagnostics"] if d["code"] == "E080"]
    assert lock_error["file"] == "system.yaml"
    assert lock_error["notes"][0]["file"] == "system.fmionnx.lock"
    assert lock_error["notes"][0]["message"] == "`y`: unit changed from `m` to `mm`"


def test_missing_lock_is_an_error(project: Path) -> None:
    (project / "system.fmionnx.lock").unlink()
    result = validate_locked()
    assert result.exit_code == 1
    assert (
        "system.yaml: error[E081 lock-missing]: no interface lock `system.fmionnx.lock`"
        in result.output
    )


def test_component_missing_from_the_lock_is_an_error(project: Path) -> None:
    text = SYSTEM.replace("  net:", "  spare: {kind: fmu, path: Integrator.fmu}\n  net:")
    (project / "system.yaml").write_text(text, encoding="utf-8")
    result = validate_locked()
    assert result.exit_code == 1
    assert (
        "system.yaml:7:3: error[E081 lock-missing]: component `spare` is not in the lock"
        in result.output
    )


def test_corrupt_lock_is_an_error_at_its_line(project: Path) -> None:
    lock = project / "system.fmionnx.lock"
    lock.write_text(
        lock.read_text(encoding="utf-8").replace("dtype: float64", "dtype: float65", 1),
        encoding="utf-8",
    )
    result = validate_locked()
    assert result.exit_code == 1
    assert "system.fmionnx.lock:" in result.output
    assert "error[E082 lock-invalid]" in result.output


def test_alias_bomb_in_the_lock_is_an_error_not_a_hang(project: Path) -> None:
    from tests.lock.test_lock_limits import bomb

    lock = project / "system.fmionnx.lock"
    lock.write_text(lock.read_text(encoding="utf-8") + bomb(12), encoding="utf-8")
    result = validate_locked()
    assert result.exit_code == 1
    assert "system.fmionnx.lock:" in result.output
    assert "error[E082 lock-invalid]" in result.output
    assert "aliases expand to more than" in result.output


def test_system_with_errors_is_not_locked(project: Path) -> None:
    (project / "system.fmionnx.lock").unlink()
    (project / "system.yaml").write_text(
        SYSTEM.replace("gain.y ->", "gain.yy ->"), encoding="utf-8"
    )
    result = cli("lock", "system.yaml")
    assert result.exit_code == 1
    assert "error[E021 unknown-port]" in result.output
    assert not (project / "system.fmionnx.lock").exists()


def test_junit_reports_the_lock_check_as_run(project: Path) -> None:
    import xml.etree.ElementTree as ET

    rebuild_gain(project, _unit_mm)
    root = ET.fromstring(validate_locked("--format", "junit").output.encode())
    lock_case = root.find("testsuite/testcase[@name='lock']")
    assert lock_case is not None
    failure = lock_case.find("failure")
    assert failure is not None
    assert failure.get("type") == "E080"
