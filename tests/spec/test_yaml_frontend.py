"""The YAML front end: positions, schema errors, and no traceback for any malformed file."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from fmionnx.cli.app import app
from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.spec.yaml import load_yaml_system

HEADER = "fmionnx: 1\nname: demo\n"


def _load(tmp_path: Path, text: str | bytes) -> tuple[object, list[tuple[str, int, int, str]]]:
    path = tmp_path / "system.yaml"
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    bag = DiagnosticBag()
    loaded = load_yaml_system(path, bag)
    found = [
        (d.code, d.span.line if d.span else 0, d.span.col if d.span else 0, d.message)
        for d in bag.sorted()
    ]
    return loaded.spec, found


@pytest.mark.parametrize(
    ("text", "code", "line", "col", "fragment"),
    [
        pytest.param("fmionnx: 1\nname: [x\n", "E001", 2, 7, "invalid YAML", id="unclosed-flow"),
        pytest.param("fmionnx: 1\n  name: x\n", "E001", 2, 7, "invalid YAML", id="bad-indent"),
        pytest.param(
            HEADER + "name: again\ncomponents: {}\n",
            "E007",
            3,
            1,
            "duplicate key",
            id="duplicate-key",
        ),
        pytest.param(
            HEADER + "components: {}\nconections: []\n",
            "E002",
            4,
            1,
            "unknown key `conections`",
            id="unknown-top-key",
        ),
        pytest.param(
            HEADER + "components:\n  a: {kind: fmu, path: a.fmu, perod: 1}\n",
            "E002",
            4,
            31,
            "unknown key `perod`",
            id="unknown-component-key",
        ),
        pytest.param(
            HEADER + "components:\n  a: {kind: fmu, path: a.fmu, cameras: {}}\n",
            "E002",
            4,
            31,
            "unknown key `cameras`",
            id="option-of-other-kind",
        ),
        pytest.param(
            HEADER + "components:\n  a: {kind: fmuu, path: a.fmu}\n",
            "E014",
            4,
            13,
            "unknown component kind `fmuu`",
            id="unknown-kind",
        ),
        pytest.param(
            HEADER + "components:\n  a: {path: a.fmu}\n",
            "E004",
            4,
            3,
            "has no `kind`",
            id="missing-kind",
        ),
        pytest.param(
            "fmionnx: 1\ncomponents: {}\n", "E004", 1, 1, "missing key `name`", id="missing-name"
        ),
        pytest.param(
            "fmionnx: 2\nname: x\ncomponents: {}\n",
            "E005",
            1,
            10,
            "format version `2` is not supported",
            id="future-format",
        ),
        pytest.param(
            HEADER + "components:\n  a: {kind: fmu, path: a.fmu, period: -1}\n",
            "E003",
            4,
            39,
            "greater than 0",
            id="negative-period",
        ),
        pytest.param(
            HEADER + "components:\n  a: {kind: fmu, path: a.fmu, period: fast}\n",
            "E003",
            4,
            39,
            "valid number",
            id="period-not-number",
        ),
        pytest.param(
            HEADER + "components: {}\nrun: {stop: !!python/object:os.system 1}\n",
            "E003",
            4,
            13,
            "tag",
            id="python-tag",
        ),
        pytest.param("- just\n- a list\n", "E003", 1, 1, "must be a mapping", id="not-a-mapping"),
        pytest.param("", "E004", 1, 1, "empty", id="empty-file"),
        pytest.param(
            HEADER + "components:\n  bad name: {kind: fmu, path: a.fmu}\n",
            "E003",
            4,
            3,
            "component name `bad name`",
            id="bad-component-name",
        ),
        pytest.param(b"fmionnx: 1\nname: caf\xe9\n", "E006", 2, 10, "not UTF-8", id="latin1"),
    ],
)
def test_malformed_files_give_one_positioned_diagnostic(
    tmp_path: Path, text: str | bytes, code: str, line: int, col: int, fragment: str
) -> None:
    spec, found = _load(tmp_path, text)
    assert spec is None
    assert found, "expected a diagnostic"
    first = found[0]
    assert (first[0], first[1], first[2]) == (code, line, col), found
    assert fragment in first[3]


def test_several_schema_errors_are_reported_together(tmp_path: Path) -> None:
    text = (
        HEADER
        + "components:\n  a: {kind: fmu, path: a.fmu, perod: 1}\n  b: {kind: onx, path: b}\nrun: {stpo: 1}\n"
    )
    _, found = _load(tmp_path, text)
    assert [f[0] for f in found] == ["E002", "E014", "E002"]


def test_unknown_key_suggests_the_closest_key(tmp_path: Path) -> None:
    path = tmp_path / "system.yaml"
    path.write_text(HEADER + "components: {}\nrun: {stpo: 1}\n", encoding="utf-8")
    bag = DiagnosticBag()
    load_yaml_system(path, bag)
    (diagnostic,) = bag.sorted()
    assert diagnostic.hint == "did you mean `stop`?"


def test_a_valid_file_keeps_positions_of_every_entry(tmp_path: Path) -> None:
    path = tmp_path / "system.yaml"
    path.write_text(
        HEADER + "components:\n  a: {kind: fmu, path: a.fmu}\nconnections:\n  - a.y -> a.u\n",
        encoding="utf-8",
    )
    bag = DiagnosticBag()
    loaded = load_yaml_system(path, bag)
    assert loaded.spec is not None
    assert not list(bag)
    span = loaded.sources.value(("connections", 0))
    assert (span.line, span.col) == (6, 5)
    assert loaded.sources.value(("components", "a", "path")).line == 4


@pytest.mark.parametrize(
    ("setup", "code"),
    [
        pytest.param(lambda p: None, "E010", id="missing"),
        pytest.param(lambda p: p.mkdir(), "E011", id="directory"),
    ],
)
def test_unreadable_system_files_exit_1_without_traceback(
    tmp_path: Path, setup: object, code: str
) -> None:
    path = tmp_path / "system.yaml"
    setup(path)  # type: ignore[operator]
    result = CliRunner().invoke(app, ["validate", str(path)], catch_exceptions=False)
    assert result.exit_code == 1
    assert f"error[{code}" in result.output
    assert "Traceback" not in result.output


def test_unknown_suffix_is_reported(tmp_path: Path) -> None:
    path = tmp_path / "system.toml"
    path.write_text("x = 1\n", encoding="utf-8")
    result = CliRunner().invoke(app, ["validate", str(path)], catch_exceptions=False)
    assert result.exit_code == 1
    assert "E013" in result.output


def test_usage_error_exits_2() -> None:
    result = CliRunner().invoke(app, ["validate", "--format", "xml", "x.yaml"])
    assert result.exit_code == 2
