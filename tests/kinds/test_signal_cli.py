"""The `signal` kind through the CLI: located diagnostics, run, lock, graph, SSP round trip."""

from __future__ import annotations

import json
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import fmionnx
from fmionnx.cli.app import app
from tests.ssp.test_roundtrip import compiled, fingerprint, round_trip

HEADER = "fmionnx: 1\nname: stimuli\nrun: {stop: 1, step: 0.1}\ncomponents:\n"


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """``tmp_path`` as the working directory, so messages name `system.yaml`."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "200")
    return tmp_path


def _cli(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(app, list(args))
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    assert "Traceback" not in result.output
    return result.exit_code, result.output


def _errors(output: str) -> list[tuple[str, int, int, str]]:
    """(code, line, column, message) of every error of a text report on `system.yaml`."""
    pattern = r"^system\.yaml:(\d+):(\d+): error\[(\w+) [\w-]+\]: (.*)$"
    return [
        (code, int(line), int(col), message)
        for line, col, code, message in re.findall(pattern, output, flags=re.MULTILINE)
    ]


def _validate(folder: Path, components: str) -> list[tuple[str, int, int, str]]:
    (folder / "system.yaml").write_text(HEADER + components, encoding="utf-8")
    code, output = _cli("validate", "system.yaml")
    assert code == 1, output
    return _errors(output)


def test_bad_entries_are_located(folder: Path) -> None:
    found = _validate(
        folder,
        "  s:\n"
        "    kind: signal\n"
        "    outputs:\n"
        "      a: {sawtooth: {frequency: 1}}\n"
        "      b: {step: {time: soon}}\n"
        "      c: {sine: {frequncy: 1}}\n"
        "      d: {ramp: {slope: 1, final: 2}}\n"
        "      e: {}\n"
        "      f: {constant: .inf}\n",
    )
    assert [(code, line, col) for code, line, col, _ in found] == [
        ("E002", 8, 11),  # the unknown key
        ("E003", 9, 24),  # the value
        ("E004", 10, 11),  # the mapping missing `frequency`
        ("E002", 10, 18),
        ("E003", 11, 17),
        ("E003", 12, 10),
        ("E003", 13, 21),
    ]
    messages = [m for _, _, _, m in found]
    assert messages[0] == "unknown key `sawtooth` in components.s.outputs.a"
    assert "a ramp takes either `slope`, or `final` and `duration`" in messages[4]
    assert "exactly one waveform" in messages[5]


def test_unknown_waveform_hint_lists_the_waveforms(folder: Path) -> None:
    (folder / "system.yaml").write_text(
        HEADER + "  s: {kind: signal, outputs: {a: {sine_wave: {frequency: 1}}}}\n",
        encoding="utf-8",
    )
    _, output = _cli("validate", "system.yaml")
    assert "hint: did you mean `sine`?" in output


def _column(line: str, needle: str) -> int:
    """1-based column of ``needle`` in ``line``."""
    return line.index(needle) + 1


@pytest.mark.parametrize(
    ("entry", "at", "expected"),
    [
        (
            "{kind: signal, path: t.csv, outputs: {q: {constant: 1}}}",
            "{q:",
            ("E003", "component `s`: has both `outputs:` and a table at `path:`"),
        ),
        (
            "{kind: signal}",
            "signal}",
            (
                "E004",
                "component `s`: needs `outputs:` (waveforms by port name) or `path:` (a CSV table)",
            ),
        ),
        (
            "{kind: signal, outputs: {q: {constant: 1}}, interpolation: hold}",
            "hold",
            (
                "E003",
                "component `s`: `interpolation` applies to a table (`path:`), not to `outputs:`",
            ),
        ),
        (
            "{kind: signal, outputs: {9q: {constant: 1}}}",
            "{9q",
            (
                "E003",
                "`components.s.outputs`: output name `9q` is not a port name: use letters, "
                "digits and `_`, not starting with a digit",
            ),
        ),
        (
            "{kind: signal, path: missing.csv}",
            "missing.csv",
            ("E010", "component `s`: `missing.csv` does not exist"),
        ),
        ("{kind: signal, path: .}", ".}", ("E011", "component `s`: `.` is not a file")),
    ],
)
def test_entry_problems_point_at_their_key(
    folder: Path, entry: str, at: str, expected: tuple[str, str]
) -> None:
    (folder / "t.csv").write_text("time,a\n0,1\n", encoding="utf-8")
    line = f"  s: {entry}"
    code, message = expected
    assert _validate(folder, line + "\n") == [(code, 5, _column(line, at), message)]


TABLE_ENTRY = "  s: {kind: signal, path: t.csv}"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "`t.csv` is empty"),
        ("\n\n", "`t.csv` is empty"),
        ("time,a\n", "`t.csv` has a header but no rows"),
        ("0,1\n1,2\n", "`t.csv:1`: the first line holds numbers, not column names"),
        ("time\n0\n", "`t.csv:1`: the table has no value column"),
        ("time,a b\n0,1\n", "`t.csv:1`: column name `a b` is not a port name"),
        ("time,a,a\n0,1,2\n", "`t.csv:1`: column `a` appears twice"),
        ("time,a\n0,1\n1,x\n", "`t.csv:3`: column `a`: `x` is not a number"),
        ("time,a\n0,1\n1,\n", "`t.csv:3`: column `a` is empty"),
        ("time,a\n0,nan\n", "`t.csv:2`: column `a`: `nan` is not a finite number"),
        ("time,a\n0,-Infinity\n", "`t.csv:2`: column `a`: `-Infinity` is not a finite number"),
        ("time,a\n0,1_000\n", "`t.csv:2`: column `a`: `1_000` is not a number"),
        ("time,a\n0_1,1\n", "`t.csv:2`: column `time`: `0_1` is not a number"),
        ("time,a\n0,0x10\n", "`t.csv:2`: column `a`: `0x10` is not a number"),
        ("time,a\n0,1\n1,2,3\n", "`t.csv:3`: 3 fields, but the header names 2"),
        (
            "time,a\n0,1\n2,2\n\n2,3\n",
            "`t.csv:5`: time 2 is not after 2 (line 3); times must increase strictly",
        ),
        ("time,a\n0,1\n-1,2\n", "`t.csv:3`: time -1 is not after 0 (line 2)"),
        ('time,a\n0,"1\n', "`t.csv:2`: unexpected end of data"),
    ],
)
def test_bad_tables_are_named_by_file_and_line(folder: Path, text: str, message: str) -> None:
    (folder / "t.csv").write_text(text, encoding="utf-8")
    found = _validate(folder, TABLE_ENTRY + "\n")
    assert len(found) == 1, found
    code, line, col, text_found = found[0]
    assert (code, line, col) == ("E012", 5, _column(TABLE_ENTRY, "t.csv"))
    assert text_found.startswith(f"component `s`: {message}"), text_found


def test_a_table_that_is_not_utf8_is_e012(folder: Path) -> None:
    (folder / "t.csv").write_bytes(b"time,a\n0,\xff\n")
    found = _validate(folder, TABLE_ENTRY + "\n")
    column = _column(TABLE_ENTRY, "t.csv")
    assert found == [("E012", 5, column, "component `s`: `t.csv` is not UTF-8 text")]


def test_run_on_bad_input_exits_non_zero_without_a_traceback(folder: Path) -> None:
    (folder / "t.csv").write_text("time,a\n1,1\n0,2\n", encoding="utf-8")
    (folder / "system.yaml").write_text(
        HEADER + "  s: {kind: signal, path: t.csv}\n", encoding="utf-8"
    )
    code, output = _cli("run", "system.yaml", "--out", "out")
    assert code == 1
    assert "`t.csv:3`: time 0 is not after 1 (line 2)" in output


def test_a_table_broken_after_validation_is_a_run_fault(folder: Path) -> None:
    (folder / "t.csv").write_text("time,a\n0,1\n", encoding="utf-8")
    system = folder / "system.yaml"
    system.write_text(HEADER + "  s: {kind: signal, path: t.csv}\n", encoding="utf-8")
    loaded = fmionnx.load(system)
    (folder / "t.csv").write_text("time,b\n0,1\n", encoding="utf-8")
    result = loaded.run(isolate="none")
    assert result.status.value == "fault"
    assert result.error is not None
    assert "the columns of `t.csv` changed since it was checked" in str(result.error)


SYSTEM = f"""{HEADER}\
  stim:
    kind: signal
    outputs:
      v: {{sine: {{amplitude: 0.5, frequency: 0.25, phase: 0.1}}, unit: m}}
      w: {{ramp: {{time: 0.2, final: 1, duration: 0.5}}}}
  table: {{kind: signal, path: profile.csv, interpolation: hold, period: 0.2}}
  gain: {{kind: fmu, path: GAIN}}
connections:
  - stim.v -> gain.u
  - {{from: stim.w, to: 'gain.v[0]', factor: 2}}
  - table.speed -> gain.v[1]
record: [stim.v, stim.w, table.speed, table.turn, gain.y]
"""


@pytest.fixture
def system(folder: Path, fixture_fmu) -> Path:
    (folder / "profile.csv").write_text("time,speed,turn\n0,1,0\n0.4,2,1\n", encoding="utf-8")
    path = folder / "system.yaml"
    path.write_text(SYSTEM.replace("GAIN", str(fixture_fmu("Gain"))), encoding="utf-8")
    return path


def test_yaml_ssp_yaml_keeps_a_system_with_signals(system: Path, folder: Path) -> None:
    archive, back = round_trip(system, folder / "trip")
    with zipfile.ZipFile(archive) as members:
        names = members.namelist()
        ssd = members.read("SystemStructure.ssd").decode()
    assert "resources/table.csv" in names
    assert 'name="stim" type="application/x-fmionnx-signal" source=""' in ssd
    assert 'source="resources/table.csv"' in ssd
    assert "path:" not in back.read_text(encoding="utf-8").split("table:")[0]
    original = fingerprint(compiled(system))
    assert fingerprint(compiled(archive)) == original
    assert fingerprint(compiled(back)) == original
    ours = fmionnx.load(system).run(isolate="none")
    for other in (archive, back):
        theirs = fmionnx.load(other).run(isolate="none")
        for name, values in ours.signals.items():
            np.testing.assert_array_equal(theirs.signals[name], values, err_msg=name)


def test_an_empty_source_is_refused_for_a_kind_that_needs_a_model_file(
    system: Path, folder: Path
) -> None:
    archive, _ = round_trip(system, folder / "trip")
    with zipfile.ZipFile(archive) as members:
        files = {n: members.read(n) for n in members.namelist()}
    ssd = files["SystemStructure.ssd"].decode()
    files["SystemStructure.ssd"] = ssd.replace('source="resources/gain.fmu"', 'source=""').encode()
    broken = folder / "broken.ssp"
    with zipfile.ZipFile(broken, "w") as members:
        for name, data in files.items():
            members.writestr(name, data)
    code, output = _cli("validate", str(broken))
    assert code == 1
    assert re.search(r"error\[E072 [\w-]+\]: component `gain` has an empty `source`", output)


def test_lock_records_signals_and_notices_a_changed_entry(system: Path) -> None:
    assert _cli("lock", "system.yaml")[0] == 0
    lock = Path("system.fmionnx.lock").read_text(encoding="utf-8")
    entry = lock.split("  stim:\n")[1].split("  table:\n")[0]
    assert entry.startswith('    kind: signal\n    path: ""\n    facts: {}\n')
    assert "{name: v, causality: output, dtype: float64, shape: [], unit: m}" in entry
    assert 'rows: "2"' in lock
    assert _cli("validate", "--locked", "system.yaml")[0] == 0
    renamed = system.read_text().replace("      w:", "      w2:").replace("stim.w,", "stim.w2,")
    system.write_text(renamed, encoding="utf-8")
    code, output = _cli("validate", "--locked", "system.yaml")
    assert code == 1
    assert (
        "component `stim`: the interface of its entry changed since it was locked in "
        "`system.fmionnx.lock` (1 change)" in output
    )


def test_graph_draws_signals_and_names_where_they_are_defined(system: Path) -> None:
    code, output = _cli("graph", "system.yaml", "--format", "json")
    assert code == 0, output
    nodes = {n["name"]: n for n in json.loads(output)["nodes"]}
    assert (nodes["stim"]["kind"], nodes["stim"]["model"]) == ("signal", "system.yaml")
    assert (nodes["table"]["kind"], nodes["table"]["model"]) == ("signal", "profile.csv")
    code, output = _cli("graph", "system.yaml", "--format", "mermaid")
    assert code == 0, output
    assert 'n_stim[/"stim<br/><small>Signal · 10 Hz</small>"/]' in output


def test_inspect_shows_a_table(folder: Path) -> None:
    (folder / "profile.csv").write_text("time,speed\n0,1\n2,3\n", encoding="utf-8")
    code, output = _cli("inspect", "profile.csv", "--format", "json")
    assert code == 0, output
    data = json.loads(output)
    assert data["kind"] == "signal"
    assert [p["name"] for p in data["ports"]] == ["speed"]
    assert data["facts"] == {"rows": "2", "firstTime": "0.0", "lastTime": "2.0"}
