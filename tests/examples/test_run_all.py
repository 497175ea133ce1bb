"""``make examples`` (examples/run_all.py): the examples match their READMEs, and the runner fails.

The examples themselves run in ``make examples`` (part of ``make test``); these tests check the
runner, cheaply: a runner that cannot fail would make every example look fine. Each failure
path — a command exiting non-zero, a failed check of a real ``fmionnx run``, a background
command failing, a result the runner's own verification rejects, a README that does not show
a command — must turn the example's line into FAIL and the exit code into 1.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import re
import sys
from pathlib import Path
from types import ModuleType

import pytest

from tests.conftest import REPO

EXAMPLES = REPO / "examples"


def _runner() -> ModuleType:
    spec = importlib.util.spec_from_file_location("run_all", EXAMPLES / "run_all.py")
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["run_all"] = module  # dataclasses look their module up while the class is made
    spec.loader.exec_module(module)
    return module


run_all = _runner()


@pytest.fixture
def scratch(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Examples and their outputs in ``tmp_path``: one folder ``demo`` with a README."""
    monkeypatch.setattr(run_all, "EXAMPLES", tmp_path / "examples")
    monkeypatch.setattr(run_all, "BUILD", tmp_path / "build")
    (tmp_path / "examples" / "demo").mkdir(parents=True)
    return tmp_path


def _example(scratch: Path, *steps: object, readme: str | None = None, **kwargs: object) -> object:
    example = run_all.Example(name="demo", steps=tuple(steps), **kwargs)
    shown = "\n".join(step.command for step in example.steps)  # type: ignore[attr-defined]
    text = readme if readme is not None else f"```sh\n{shown}\n```\n"
    (scratch / "examples" / "demo" / "README.md").write_text(text, encoding="utf-8")
    return example


def test_every_example_has_a_readme_showing_its_commands_and_a_small_picture() -> None:
    examples = [make() for make in run_all.ALL]
    assert {e.name for e in examples} == {p.parent.name for p in EXAMPLES.glob("*/README.md")}
    for example in examples:
        assert run_all.readme_problems(example) == []
        readme = (example.folder / "README.md").read_text(encoding="utf-8")
        pictures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", readme)
        assert pictures, f"{example.name}: the README shows no picture"
        assert set(pictures) == set(example.pictures), example.name  # --refresh redraws each
        for picture in pictures:
            size = (example.folder / picture).stat().st_size
            assert 0 < size <= run_all.PICTURE_LIMIT, f"{example.name}/{picture}: {size} bytes"


def test_every_committed_picture_is_the_one_drawn_from_its_recorded_data() -> None:
    """`make examples` compares a run's data with pictures.json; the PNG beside it must be the
    one drawn from that data (its sha256 was recorded when both were written), so a picture
    cannot be replaced or left behind while the data moves on (issue #34)."""
    for example in (make() for make in run_all.ALL):
        manifest = run_all.read_manifest(example)
        assert set(manifest) == set(example.pictures), example.name
        for name, entry in manifest.items():
            data = (example.folder / name).read_bytes()
            assert hashlib.sha256(data).hexdigest() == entry["sha256"], f"{example.name}/{name}"
            assert entry["data"], f"{example.name}/{name}: no data recorded"


def test_every_generated_readme_block_is_one_make_examples_writes() -> None:
    for example in (make() for make in run_all.ALL):
        text = (example.folder / "README.md").read_text(encoding="utf-8")
        blocks = run_all.readme_blocks(text)
        assert set(blocks) == set(example.blocks), example.name
        assert all(body.strip() for body in blocks.values()), f"{example.name}: an empty block"


def test_the_readmes_name_every_example() -> None:
    """README and examples/README.md said four examples and listed four (issue #34)."""
    names = [make().name for make in run_all.ALL]
    top = (REPO / "README.md").read_text(encoding="utf-8")
    words = {4: "four", 5: "five", 6: "six", 7: "seven"}
    assert f"holds {words[len(names)]} worked examples" in top
    assert all(f"(examples/{name}/)" in top for name in names)
    index = (EXAMPLES / "README.md").read_text(encoding="utf-8")
    assert all(f"[{name}]({name}/)" in index for name in names)
    shown = re.search(r"```text\n(.*?)```", index, re.DOTALL)
    assert shown is not None
    assert [line.split()[0] for line in shown[1].splitlines()[:-1]] == names
    assert f"{len(names)} of {len(names)} examples passed" in shown[1]


def test_a_passing_example_passes(scratch: Path) -> None:
    example = _example(scratch, run_all.Step("python -c pass"))
    run_all.run_example(example, refresh=False)


def test_a_command_that_exits_non_zero_fails_the_example_and_shows_its_output(
    scratch: Path,
) -> None:
    example = _example(scratch, run_all.Step("python -c 'print(\"boom\"); raise SystemExit(3)'"))
    with pytest.raises(run_all.ExampleError, match=r"(?s)exited 3.*boom"):
        run_all.run_example(example, refresh=False)


def test_a_failed_check_of_a_real_run_fails_the_example(scratch: Path) -> None:
    system = scratch / "checked.yaml"
    system.write_text(
        "fmionnx: 1\nname: checked\nrun: {stop: 1, step: 0.1}\n"
        "components:\n  s: {kind: signal, outputs: {y: {constant: 1}}}\n"
        "checks:\n  - name: too high\n    expect: final(s.y) > 5\n",
        encoding="utf-8",
    )
    example = _example(scratch, run_all.Step(f"fmionnx run {system} --no-out"))
    with pytest.raises(run_all.ExampleError, match=r"(?s)exited 1.*too high"):
        run_all.run_example(example, refresh=False)


def test_a_failing_background_command_fails_the_example(scratch: Path) -> None:
    example = _example(
        scratch,
        run_all.Step("python -c 'raise SystemExit(2)'", background=True),
        run_all.Step("python -c pass"),
    )
    with pytest.raises(run_all.ExampleError, match="exited 2"):
        run_all.run_example(example, refresh=False)


def test_results_the_runner_rejects_fail_the_example(scratch: Path) -> None:
    example = _example(
        scratch, run_all.Step("python -c pass"), verify=lambda: ["the robot never moved"]
    )
    with pytest.raises(run_all.ExampleError, match="the robot never moved"):
        run_all.run_example(example, refresh=False)


def test_a_command_the_readme_does_not_show_is_refused(scratch: Path) -> None:
    example = _example(scratch, run_all.Step("python -c pass"), readme="# nothing to run\n")
    with pytest.raises(run_all.ExampleError, match="does not show `python -c pass`"):
        run_all.run_example(example, refresh=False)


def test_main_prints_one_line_per_example_and_exits_1_when_one_fails(
    scratch: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (scratch / "examples" / "bad").mkdir()
    (scratch / "examples" / "bad" / "README.md").write_text("python -c 'raise SystemExit(1)'")
    good = _example(scratch, run_all.Step("python -c pass"))
    bad = run_all.Example(name="bad", steps=(run_all.Step("python -c 'raise SystemExit(1)'"),))
    monkeypatch.setattr(run_all, "ALL", (lambda: good, lambda: bad))
    assert run_all.main([]) == 1
    lines = capsys.readouterr().out.splitlines()
    assert re.fullmatch(r"demo\s+pass\s+[\d.]+ s", lines[0])
    assert re.fullmatch(r"bad\s+FAIL\s+[\d.]+ s", lines[1])
    assert lines[-1].startswith("1 of 2 examples passed")


def _picture(data: object) -> object:
    """A picture whose data is ``data``, drawn as a few bytes."""

    def make(destination: Path) -> None:
        destination.write_bytes(b"png:" + json.dumps(data).encode())

    return run_all.Picture(make, lambda: data)


def test_refresh_records_a_picture_and_its_data_and_a_changed_run_fails(scratch: Path) -> None:
    example = _example(
        scratch, run_all.Step("python -c pass"), pictures={"p.png": _picture({"y": [1.0, 2.0]})}
    )
    with pytest.raises(run_all.ExampleError, match=r"records nothing for `p\.png`"):
        run_all.run_example(example, refresh=False)
    run_all.run_example(example, refresh=True)
    manifest = run_all.read_manifest(example)
    assert manifest["p.png"]["data"] == {"y": [1.0, 2.0]}
    png = (scratch / "examples" / "demo" / "p.png").read_bytes()
    assert manifest["p.png"]["sha256"] == hashlib.sha256(png).hexdigest()
    run_all.run_example(example, refresh=False)  # the same data: passes
    close = _example(
        scratch,
        run_all.Step("python -c pass"),
        pictures={"p.png": _picture({"y": [1.0, 2.0 * (1 + 1e-6)]})},  # within the tolerance
    )
    run_all.run_example(close, refresh=False)
    drifted = _example(
        scratch, run_all.Step("python -c pass"), pictures={"p.png": _picture({"y": [1.0, 2.1]})}
    )
    with pytest.raises(run_all.ExampleError, match=r"(?s)p.png.*other data.*2\.0 became 2\.1"):
        run_all.run_example(drifted, refresh=False)


def test_a_readme_block_that_differs_from_the_run_fails_and_refresh_rewrites_it(
    scratch: Path,
) -> None:
    readme = (
        "```sh\npython -c pass\n```\n\n<!-- make examples: table -->\n| a |\n| 1 |\n"
        "<!-- end make examples -->\nafter\n"
    )
    example = _example(
        scratch,
        run_all.Step("python -c pass"),
        readme=readme,
        blocks={"table": lambda: "| a |\n| 2 |"},
    )
    with pytest.raises(run_all.ExampleError, match=r"(?s)block `table` differs.*\| 1 \|.*\| 2 \|"):
        run_all.run_example(example, refresh=False)
    run_all.run_example(example, refresh=True)
    text = (scratch / "examples" / "demo" / "README.md").read_text(encoding="utf-8")
    assert "| a |\n| 2 |\n<!-- end make examples -->\nafter\n" in text
    run_all.run_example(example, refresh=False)


def test_a_block_the_readme_lacks_fails(scratch: Path) -> None:
    example = _example(scratch, run_all.Step("python -c pass"), blocks={"table": lambda: "x"})
    with pytest.raises(run_all.ExampleError, match="has no block `table`"):
        run_all.run_example(example, refresh=False)


def test_differences_compare_numbers_within_the_tolerance_and_the_rest_exactly() -> None:
    assert run_all.differences({"a": [1.0, float("nan")]}, {"a": [1.0000001, float("nan")]}) == []
    assert run_all.differences({"a": 1.0}, {"a": 1.01}) == [".a: 1.0 became 1.01"]
    assert run_all.differences({"t": "x"}, {"t": "y"}) == [".t: 'x' became 'y'"]
    assert run_all.differences([1, 2], [1]) == [": 2 items became 1"]
    assert run_all.differences({"a": 1}, {"b": 1}) == ["top: keys ['a'] became ['b']"]
