"""Command-line interface. Commands live in one module each and are registered here."""

from __future__ import annotations

import atexit
import contextlib
import os
import sys
import threading
from importlib.machinery import ModuleSpec
from pathlib import Path

from fmionnx.cli import (  # noqa: F401 - importing registers the commands (invoked, lean_help aside)
    build_cmd,
    compile_cmd,
    graph_cmd,
    inspect_cmd,
    invoked,
    lean_help,
    lock_cmd,
    lsp_cmd,
    node_cmd,
    ros2_cmd,
    run_cmd,
    schema_cmd,
    ssp_cmd,
    sweep_cmd,
    validate_cmd,
)
from fmionnx.cli.app import ExitCode, app
from fmionnx.cli.helptext import tidy

tidy(app)  # every command is registered now: plain flags, help paragraphs unwrapped


def main() -> None:
    """Console-script entry point.

    Commands check the paths they are given; this is the net below them, so that a file system
    refusing (a full disk, a path that vanished) ends with one line, not a traceback.
    """
    _children_skip_the_script()
    if lean_help.wants_help(sys.argv):
        lean_help.prepare()
    try:
        invoked.narrowed(app, sys.argv)()
    except BrokenPipeError:  # `fmionnx graph ... | head`: the reader left; nothing to say
        sys.stderr.close()
        sys.exit(ExitCode.PROBLEMS)
    except OSError as exc:
        _exit_if_stopped(exc)
        where = f": `{exc.filename}`" if exc.filename else ""
        print(f"error: {exc.strerror or exc}{where}", file=sys.stderr)
        sys.exit(ExitCode.PROBLEMS)
    except Exception as exc:
        _exit_if_stopped(exc)
        raise


def _exit_if_stopped(exc: BaseException) -> None:
    """Exit as stopped (one line, 128 + the signal) when ``exc`` was raised because of a stop
    signal: a Ctrl-C landing in the import of a C extension, which then fails with an error
    of its own (:func:`~fmionnx.runtime.stopping.stop_behind`)."""
    from fmionnx.runtime.stopping import exit_code, stop_behind, stop_reason

    stop = stop_behind(exc)
    if stop is not None:
        reason = stop_reason(stop)
        print(f"error: interrupted by {reason} ({type(exc).__name__}: {exc})", file=sys.stderr)
        raise SystemExit(exit_code(reason)) from None  # said: not again by _say_if_stopped


#: Modules whose objects may still have work to do when they are torn down (network sessions
#: that send what is queued as they close): a process that loaded them exits the slow way.
KEEP_TEARDOWN = ("rclpy", "zenoh")


def console() -> None:
    """The console script's entry point (and ``python -m fmionnx``): :func:`main`, then out
    without the interpreter's teardown.

    Once a command is done, Python would still tear down every module and object it made
    before the process ends: about 0.25 s after a lone FMU's run of 1.2 s, and after every
    other command, for nothing anyone sees (every file fmionnx writes is closed by then). So
    the exit status is handed to the system directly, after what Python's exit does that
    matters: its ``atexit`` hooks (the isolated models' zygote, scratch folders, logging) and
    the standard streams flushed. A process where another (non-daemon) thread still runs, or
    that loaded a module of :data:`KEEP_TEARDOWN`, or whose streams cannot be flushed, exits
    the normal way. :func:`main` itself stays an ordinary function for programs that call it.
    """
    global _whole_process  # noqa: PLW0603 - set once, by the process's entry point
    _whole_process = True
    try:
        main()
    except SystemExit as exc:
        _say_if_stopped(exc)
        _leave(exc.code)
        raise
    _leave(None)


def _say_if_stopped(exc: SystemExit) -> None:
    """One line for a stop that ended the command before any of its own handlers could say
    so: typer turns a Ctrl-C while it parses or calls the command into a silent exit 130
    (raised from the ``KeyboardInterrupt``). A stop the command reported itself ends its
    chain (``from None``) and is not said twice."""
    from fmionnx.runtime.stopping import stop_behind, stop_reason

    stop = stop_behind(exc)
    if stop is not None:
        with contextlib.suppress(OSError, ValueError):
            print(f"error: interrupted by {stop_reason(stop)}", file=sys.stderr)


_whole_process = False


def whole_process() -> bool:
    """Whether this process is one command and nothing else (started by :func:`console`), so
    that a command may start helpers that keep this process's environment for their whole
    life (a local study's worker fork server): not so in a program calling :func:`main`."""
    return _whole_process


def _leave(code: object) -> None:
    """End the process with ``code`` (as ``SystemExit`` takes it) after the ``atexit`` hooks,
    skipping the interpreter's teardown; returns only where that is not safe (see
    :func:`console`)."""
    others = [t for t in threading.enumerate() if t is not threading.current_thread()]
    if any(not t.daemon for t in others) or any(name in sys.modules for name in KEEP_TEARDOWN):
        return
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):  # a closed or broken stream: let Python report it
        return
    if code is None:
        status = 0
    elif isinstance(code, int):
        status = code
    else:  # sys.exit("message"): printed, status 1, as Python does
        print(code, file=sys.stderr)
        status = 1
    atexit._run_exitfuncs()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    finally:
        os._exit(status & 0xFF)


#: The name of the console script that pip writes (``bin/fmionnx``).
SCRIPT_NAME = "fmionnx"


def _children_skip_the_script() -> None:
    """Let the processes that ``multiprocessing`` spawns from this one (a local study's Dask
    workers) start without running the console script again, ignoring Ctrl-C from the start.

    A spawned process re-runs the parent's main script, unless the parent was started as a
    module (``python -m``): for ``bin/fmionnx`` that imports this package's whole command
    line (typer, every command's module), which a worker never uses, in every worker. Given
    the spec of a module, a spawned process runs that module instead: :mod:`fmionnx.spawned`,
    a few lines that make it ignore SIGINT (the driver decides; a Ctrl-C while a worker
    imported Dask printed a traceback). ``python -m fmionnx`` is given it too. Only the
    console script's module and ``fmionnx.__main__`` are touched: a program that calls
    :func:`main` from a main module of its own keeps its spec.
    """
    script = sys.modules.get("__main__")
    if script is None:
        return
    spec = getattr(script, "__spec__", None)
    if spec is None:
        if Path(getattr(script, "__file__", "") or "").name != SCRIPT_NAME:
            return
    elif spec.name != "fmionnx.__main__":
        return
    script.__spec__ = ModuleSpec("fmionnx.spawned", None)
