"""The examples in README.md and docs/ are executed, so the docs cannot drift from the behaviour.

Users copy what the docs show, and a transcript that no longer matches the tool (a diagnostic
at another line, a stop time the reference file no longer has) costs them more than no example.
So every ```console block is run and its shown output compared, and YAML blocks that claim to be
(part of) a system are checked against the real file or the compiler. The convention is
documented for contributors in ``docs/contributing.md``; in short:

* in a ```console block a line starting with ``$ `` is a command, the lines after it (up to the
  next command) are its expected output, compared line by line after stripping trailing blanks;
* ``...`` inside an expected line matches any text on that line; a line that is only ``...``
  matches any number of lines (wall times, real-time factors, plot file names);
* a block that cannot run here says so on the line right above its fence:
  ``<!-- docs-test: not-run: REASON -->``; a command of an unmarked block that is not one the
  test can run fails the test instead of being skipped;
* ``<!-- docs-test: part-of PATH -->`` above a ```yaml block: every key, value and list item
  it shows is in the repository file PATH; ``<!-- docs-test: valid-system -->``: the block,
  saved in ``systems/``, validates without errors. A YAML block that is a whole system (it has
  the top-level ``fmionnx:`` key) must carry one of these or ``not-run``.

Commands run in a scratch copy of the files the docs refer to (``systems/``, ``schemas/``,
``models/``, the built ``build/models`` and the test fixtures), never in the repository, with
the venv's ``fmionnx`` first on ``PATH`` and a fixed 80-column, colourless terminal.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
import threading
from collections.abc import Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from ruamel.yaml import YAML

from tests.conftest import BUILT_MODELS, REPO

DOC_FILES = [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]
MARKER = re.compile(r"^<!--\s*docs-test:\s*(?P<kind>[a-z-]+)(?::?\s*(?P<arg>.*?))?\s*-->$")
FENCE = re.compile(r"^(?P<indent>\s*)```(?P<lang>[\w-]*)\s*$")
ANY_LINES = "..."
# Programs a block may call besides `fmionnx`: plain file tools a transcript uses to set up or
# show a file. Anything else (make, git, ros2, a benchmark) cannot run here and must be marked.
RUNNABLE = {"fmionnx", "sed", "cat", "ls", "head", "grep", "echo", "cp", "mkdir"}
# Set-up lines the test provides itself: the venv's bin folder is already first on PATH.
ACTIVATE = {". .venv/bin/activate", "source .venv/bin/activate"}
# What a scratch copy holds: everything a documented command may read or write by a relative
# path. Built models are copied too, so no command can write into the repository through them.
SCRATCH_TREES = ["systems", "schemas", "models", "tests/fixtures", "examples"]
KNOWN_MARKERS = {"not-run", "part-of", "valid-system"}
TIMEOUT_S = 120
# What a transcript of a failing command shows: a diagnostic summary with errors, an error
# annotation, a usage error, a run fault or failed checks. Such a command must exit non-zero,
# any other 0.
FAILURE = re.compile(r"^\d+ errors?\b|\berror\[E\d{3}|^::error |^error: |^fault:|checks? failed")


@dataclass
class Command:
    """One ``$ `` line and the output the doc shows for it."""

    line: int
    text: str
    expected: list[str] = field(default_factory=list)


@dataclass
class Block:
    """A fenced block with its language, its markers and where it is."""

    doc: Path
    line: int
    lang: str
    body: list[str]
    markers: dict[str, str]

    @property
    def where(self) -> str:
        return f"{self.doc.relative_to(REPO).as_posix()}:{self.line}"

    def commands(self) -> list[Command]:
        """Split a console block into commands and their expected output."""
        commands: list[Command] = []
        for offset, raw in enumerate(self.body, start=1):
            if raw.startswith("$ "):
                commands.append(Command(self.line + offset, raw[2:].strip()))
            elif not commands:
                msg = f"{self.where}: output before the first `$ ` command: {raw!r}"
                raise AssertionError(msg)
            else:
                commands[-1].expected.append(raw.rstrip())
        return commands


def parse_blocks(doc: Path) -> Iterator[Block]:
    """Every fenced block of a Markdown file, with the ``docs-test`` markers right above it."""
    lines = doc.read_text(encoding="utf-8").splitlines()
    index = 0
    while index < len(lines):
        fence = FENCE.match(lines[index])
        if fence is None:
            index += 1
            continue
        markers: dict[str, str] = {}
        above = index - 1
        while above >= 0 and (marker := MARKER.match(lines[above].strip())):
            markers[marker["kind"]] = (marker["arg"] or "").strip()
            above -= 1
        indent = len(fence["indent"])
        end = index + 1
        while end < len(lines) and lines[end].strip() != "```":
            end += 1
        body = [line[indent:] for line in lines[index + 1 : end]]
        yield Block(doc, index + 1, fence["lang"], body, markers)
        index = end + 1


def all_blocks() -> list[Block]:
    return [block for doc in DOC_FILES for block in parse_blocks(doc)]


def lines_match(expected: list[str], actual: list[str]) -> bool:
    """Compare output line by line; ``...`` matches text within a line, a ``...`` line any lines.

    Backtracking over the any-lines marker is needed because it may be followed by lines that
    also occur inside the skipped part (a table border, say).
    """
    if not expected:
        return not actual
    head, rest = expected[0], expected[1:]
    if head.strip() == ANY_LINES:
        return any(lines_match(rest, actual[skip:]) for skip in range(len(actual) + 1))
    if not actual:
        return False
    pattern = ".*".join(re.escape(part) for part in head.split("..."))
    return re.fullmatch(pattern, actual[0]) is not None and lines_match(rest, actual[1:])


def _program(command: str) -> str:
    try:
        words = shlex.split(command, comments=True)
    except ValueError:
        return command.split(maxsplit=1)[0]
    return words[0] if words else ""


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env.update({"COLUMNS": "80", "NO_COLOR": "1", "TERM": "dumb", "PYTHONUNBUFFERED": "1"})
    for name in ("FORCE_COLOR", "CLICOLOR_FORCE"):
        env.pop(name, None)
    return env


@pytest.fixture(scope="session")
def scratch_template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One copy of the files documented commands use; each block starts from its own copy."""
    template = tmp_path_factory.mktemp("docs-template")
    for tree in SCRATCH_TREES:
        shutil.copytree(REPO / tree, template / tree, symlinks=False)
    built = template / "build" / "models"
    built.mkdir(parents=True)
    for model in BUILT_MODELS.iterdir():
        if model.is_file() and model.suffix in {".fmu", ".onnx"}:
            shutil.copy2(model, built / model.name)
    return template


# A command's output depends only on the commands run before it in a fresh copy (fmionnx runs
# are deterministic), so blocks that start the same way share one run: the 32 s reference
# scenario is shown in several places and runs once per session.
_RUNS: dict[tuple[str, ...], Future[tuple[int, list[str], Path]]] = {}
_RUNS_LOCK = threading.Lock()


def _shell(text: str, cwd: Path, env: dict[str, str]) -> tuple[int, list[str]]:
    done = subprocess.run(
        ["bash", "-c", text], cwd=cwd, env=env, stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        timeout=TIMEOUT_S, check=False,
    )  # fmt: skip
    return done.returncode, [line.rstrip() for line in done.stdout.splitlines()]


def _run_once(
    history: tuple[str, ...], text: str, scratch: Path, cwd: Path, env: dict[str, str]
) -> tuple[int, list[str]]:
    """Run a command unless a block that began the same way ran (or is running) it already.

    The first block to get there runs it and keeps a copy of its scratch folder afterwards;
    the others take that copy as their own, so the files the command wrote are there for
    their next commands exactly as if they had run it.
    """
    with _RUNS_LOCK:
        future = _RUNS.get(history)
        owner = future is None
        if future is None:
            future = _RUNS[history] = Future()
    if owner:
        try:
            status, output = _shell(text, cwd, env)
            snapshot = scratch.with_name(f"{scratch.name}-after-{len(history)}")
            shutil.copytree(scratch, snapshot, symlinks=True)
            future.set_result((status, output, snapshot))
        except BaseException as error:  # the waiting blocks must see it too
            future.set_exception(error)
            raise
        return status, output
    status, output, snapshot = future.result()
    shutil.rmtree(scratch)
    shutil.copytree(snapshot, scratch, symlinks=True)
    return status, output


def _strip_comment(command: str) -> str:
    return re.sub(r"\s+#\s.*$", "", command).strip()


def run_block(block: Block, scratch: Path, environment: dict[str, str] | None = None) -> list[str]:
    """Run a console block's commands in ``scratch``; return one message per mismatch.

    ``environment``: the commands' environment, taken on the main thread by a caller that
    runs blocks on threads (pytest changes ``os.environ`` as it goes from test to test, and a
    thread copying it meanwhile meets a variable that is gone: KeyError).
    """
    problems: list[str] = []
    cwd, env = scratch, dict(environment) if environment is not None else _environment()
    history: tuple[str, ...] = ()
    for command in block.commands():
        text = _strip_comment(command.text)
        history = (*history, f"{cwd.relative_to(scratch)}$ {text}")
        if text in ACTIVATE:
            output, status = [], 0
        elif text.startswith("cd "):
            cwd = (cwd / text[3:].strip()).resolve()
            output, status = [], 0
        elif text.startswith("export "):
            for assignment in shlex.split(text[7:]):
                name, _, value = assignment.partition("=")
                env[name] = value
            output, status = [], 0
        elif _program(text) not in RUNNABLE:
            problems.append(
                f"{block.where}: line {command.line}: `{_program(text)}` cannot run in the docs "
                "test; mark the block `<!-- docs-test: not-run: REASON -->`"
            )
            continue
        else:
            status, output = _run_once(history, text, scratch, cwd, env)
        # A transcript showing an error diagnostic or a failed check documents a failing
        # command; any other command must succeed, whatever it printed.
        fails = any(FAILURE.search(line) for line in command.expected)
        if (status != 0) != fails:
            problems.append(
                f"{block.where}: line {command.line}: `{command.text}` exited {status}, the doc "
                f"implies {'failure' if fails else 'success'}; it printed:\n" + "\n".join(output)
            )
        elif not lines_match(command.expected, output):
            problems.append(
                f"{block.where}: line {command.line}: `{command.text}` printed\n"
                + "\n".join(output)
                + "\n--- but the doc shows ---\n"
                + "\n".join(command.expected)
            )
    return problems


def _yaml_load(text: str) -> object:
    return YAML(typ="safe", pure=True).load(text)


def contained(part: object, whole: object) -> bool:
    """``part`` shows nothing ``whole`` does not have: keys, values and list items (any order)."""
    if isinstance(part, dict):
        return isinstance(whole, dict) and all(
            key in whole and contained(value, whole[key]) for key, value in part.items()
        )
    if isinstance(part, list):
        return isinstance(whole, list) and all(any(contained(p, w) for w in whole) for p in part)
    return bool(part == whole)


BLOCKS = all_blocks()
CONSOLE = [b for b in BLOCKS if b.lang == "console" and "not-run" not in b.markers]
CHECKED_YAML = [
    b for b in BLOCKS if b.lang == "yaml" and b.markers.keys() & {"part-of", "valid-system"}
]


def test_markers_are_known_and_give_reasons() -> None:
    """A misspelt marker would silently un-check a block; ``not-run`` without a reason hides why."""
    bad = []
    for block in BLOCKS:
        for kind, arg in block.markers.items():
            if kind not in KNOWN_MARKERS or (kind in {"not-run", "part-of"} and not arg):
                bad.append(f"{block.where}: <!-- docs-test: {kind} {arg} -->")
    assert not bad, "unknown marker or missing reason/path:\n" + "\n".join(bad)


def test_whole_systems_in_yaml_blocks_are_marked() -> None:
    """A YAML block that is a complete system file must be checked or say why it is not."""
    unmarked = []
    for block in BLOCKS:
        if block.lang != "yaml" or block.markers:
            continue
        text = "\n".join(block.body)
        if re.search(r"^fmionnx:", text, re.MULTILINE) and re.search(
            r"^components:", text, re.MULTILINE
        ):
            unmarked.append(block.where)
    assert not unmarked, f"mark these system examples (valid-system, part-of, not-run): {unmarked}"


@pytest.fixture(scope="session")
def console_results(
    request: pytest.FixtureRequest,
    scratch_template: Path,
    tmp_path_factory: pytest.TempPathFactory,
) -> Iterator[dict[str, Future[list[str]]]]:
    """Start every console block at once, the slowest first, on as many workers as cores.

    The commands are separate processes, mostly single-threaded: running blocks side by side
    keeps the docs test at the length of its longest run (the reference scenario) plus a
    share of the rest, instead of their sum.
    """
    selected = [
        item.callspec.params["block"]
        for item in request.session.items
        if isinstance(item, pytest.Function) and item.originalname == "test_console_block"
    ]
    slow_first = sorted(selected, key=lambda b: not any("fmionnx run " in line for line in b.body))
    environment = _environment()  # here, not on the threads (see run_block)
    with ThreadPoolExecutor(max_workers=max(2, min(4, os.cpu_count() or 1))) as pool:
        results: dict[str, Future[list[str]]] = {}
        for block in slow_first:
            scratch = tmp_path_factory.mktemp("docs-block") / "work"
            shutil.copytree(scratch_template, scratch, symlinks=True)
            results[block.where] = pool.submit(run_block, block, scratch, environment)
        yield results


@pytest.mark.parametrize("block", CONSOLE, ids=[b.where for b in CONSOLE])
def test_console_block(block: Block, console_results: dict[str, Future[list[str]]]) -> None:
    """Run the block's commands in a fresh copy and compare what they print with the doc."""
    problems = console_results[block.where].result()
    assert not problems, "\n\n".join(problems)


@pytest.mark.parametrize("block", CHECKED_YAML, ids=[b.where for b in CHECKED_YAML])
def test_yaml_block(block: Block, scratch_template: Path, tmp_path: Path) -> None:
    """A YAML example claiming to be (part of) a system is (part of) one."""
    text = "\n".join(block.body) + "\n"
    if "part-of" in block.markers:
        reference = REPO / block.markers["part-of"]
        shown, real = _yaml_load(text), _yaml_load(reference.read_text(encoding="utf-8"))
        assert contained(shown, real), f"{block.where} shows what {reference.name} does not have"
    if "valid-system" in block.markers:
        scratch = tmp_path / "work"
        shutil.copytree(scratch_template, scratch, symlinks=True)
        system = scratch / "systems" / "docs_example.yaml"
        system.write_text(text, encoding="utf-8")
        done = subprocess.run(
            ["fmionnx", "validate", "--quiet", "systems/docs_example.yaml"], cwd=scratch,
            env=_environment(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            timeout=TIMEOUT_S, check=False,
        )  # fmt: skip
        assert done.returncode == 0, f"{block.where} does not validate:\n{done.stdout}"


def test_matcher_is_strict() -> None:
    """The comparison must fail on a changed line number and honour only the two wildcards."""
    shown = ["a.yaml:48:5: error[E021 unknown-port]: ...", "...", "1 error in 1 file"]
    printed = ["a.yaml:48:5: error[E021 unknown-port]: no port", "x", "y", "1 error in 1 file"]
    assert lines_match(shown, printed)
    assert not lines_match(shown, [printed[0].replace("48:5", "31:5"), *printed[1:]])
    assert not lines_match(["no problems in 1 file"], ["no problems in 1 file", "extra"])
    assert not lines_match([], ["unexpected output"])
    assert lines_match(["...", "end"], ["end"])
    assert not lines_match(["a ... c"], ["a b"])


def test_unmarked_block_that_cannot_run_fails(tmp_path: Path) -> None:
    """A command the test cannot run is a failure, not a silent skip, until the block is marked."""
    block = Block(REPO / "README.md", 1, "console", ["$ make demo"], {})
    problems = run_block(block, tmp_path)
    assert problems
    assert "not-run" in problems[0]
