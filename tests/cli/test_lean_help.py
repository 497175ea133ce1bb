"""``--help`` renders through typer's rich renderer without importing ``rich.markdown`` and
``rich.traceback`` (fmionnx/cli/lean_help.py), and looks exactly as without that deferral.

Each case runs in a fresh interpreter: what is deferred is an import, which one process
does only once.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

PROBE = """\
import sys
mode = sys.argv.pop(1)
if mode == "eager":  # typer's renderer imported as it is: prepare() then does nothing
    import typer.rich_utils
from fmionnx.cli import main
try:
    main()
finally:
    deferred = [m for m in ("rich.markdown", "rich.traceback", "markdown_it", "attr")
                if m in sys.modules]
    print("deferred-loaded:" + ",".join(deferred), file=sys.stderr)
"""


def _run(
    folder: Path, mode: str, *args: str, color: bool = False
) -> subprocess.CompletedProcess[str]:
    probe = folder / "probe.py"
    probe.write_text(PROBE, encoding="utf-8")
    colour_vars = ("FORCE_COLOR", "NO_COLOR", "PY_COLORS", "GITHUB_ACTIONS", "TERMINAL_WIDTH")
    env = {k: v for k, v in os.environ.items() if k not in colour_vars}
    env["COLUMNS"] = "100"
    if color:
        env["FORCE_COLOR"] = "1"
    return subprocess.run(
        [sys.executable, str(probe), mode, *args],
        cwd=folder, env=env, capture_output=True, text=True, check=False, timeout=60,
    )  # fmt: skip


def _prints_ok(code: str) -> None:
    """Run ``code`` in a fresh interpreter, which must print ``ok`` (its asserts passed)."""
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False, timeout=60
    )
    assert done.stdout.strip() == "ok", done.stderr


@pytest.mark.parametrize(
    ("args", "color"),
    [((), False), (("--help",), False), (("run", "--help"), False), (("run", "-h"), True)],
)
def test_help_is_byte_for_byte_typer_s(tmp_path: Path, args: tuple[str, ...], color: bool) -> None:
    lean = _run(tmp_path, "lean", *args, color=color)
    eager = _run(tmp_path, "eager", *args, color=color)
    assert lean.returncode == eager.returncode
    assert lean.stdout == eager.stdout
    assert "Usage: " in lean.stdout
    assert lean.stderr.strip().endswith("deferred-loaded:")
    assert "rich.markdown" in eager.stderr  # the probe sees what typer alone imports


def test_a_usage_error_still_renders_typer_s_panel(tmp_path: Path) -> None:
    """No help asked: typer's renderer loads as it is (markdown too) when it has to report."""
    done = _run(tmp_path, "lean", "run", "--no-such-option")
    assert done.returncode == 2
    assert "No such option: --no-such-option" in done.stderr
    assert "Error" in done.stderr


def test_deferred_names_are_the_real_classes_once_used(tmp_path: Path) -> None:
    code = (
        "from fmionnx.cli import lean_help\n"
        "lean_help.prepare()\n"
        "import sys, typer.rich_utils as ru\n"
        "assert 'rich.markdown' not in sys.modules\n"
        "md = ru.Markdown('*x*')\n"
        "import rich.markdown, rich.traceback\n"
        "assert type(md) is rich.markdown.Markdown\n"
        "assert ru.Traceback.from_exception is not None\n"
        "assert rich.traceback.Traceback.__module__ == 'rich.traceback'\n"
        "print('ok')\n"
    )
    _prints_ok(code)


def test_a_typer_that_uses_the_modules_at_import_falls_back_to_importing_them(
    tmp_path: Path,
) -> None:
    """A stand-in that cannot serve (here: it raises) leaves typer imported as it is."""
    code = (
        "from fmionnx.cli import lean_help\n"
        "def refuse(self, name):\n"
        "    raise RuntimeError('used at import')\n"
        "lean_help._StandIn.__getattr__ = refuse\n"
        "lean_help.prepare()\n"
        "import sys, typer.rich_utils as ru, rich.markdown\n"
        "assert ru.Markdown is rich.markdown.Markdown\n"
        "assert not isinstance(sys.modules['rich.traceback'], lean_help._StandIn)\n"
        "print('ok')\n"
    )
    _prints_ok(code)


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["fmionnx"], True),
        (["fmionnx", "--help"], True),
        (["fmionnx", "run", "-h"], True),
        (["fmionnx", "run", "model.fmu"], False),
        (["fmionnx", "--version"], False),
    ],
)
def test_help_is_recognised_on_the_command_line(argv: list[str], expected: bool) -> None:
    from fmionnx.cli.lean_help import wants_help

    assert wants_help(argv) is expected
