"""The child process of one isolated component: ``python -m fmionnx.runtime.isolated.child``.

It makes the component's ordinary runner (the kind table's factory) and serves the
supervisor's commands until told to terminate or until the supervisor goes away. Everything a
model can do to its process (crash, abort, exit, hang) happens here, not in the run.
"""

from __future__ import annotations

import os
import signal
import sys


def _die_with_parent() -> None:
    """Linux kills this process when the supervisor dies (a hung model stays no orphan)."""
    from fmionnx.runtime.lifetime import die_with_parent

    die_with_parent()
    if os.getppid() == 1:  # the supervisor died before prctl took effect
        os._exit(1)


def main(argv: list[str]) -> int:
    """``child COMMANDS REPLIES SHARED [--no-spin] [--keep] [--sandbox WRITABLE MODEL]``
    (inherited descriptors; ``--no-spin``: block on the command pipe at once, see
    ``server.SPIN_NS``; ``--keep``: the process may serve the next runs of its model, so
    models are kept loaded between them as a study's worker keeps them).

    Whatever processes the model starts are this process's descendants (it adopts their
    orphans) and end with it: see :mod:`fmionnx.runtime.lifetime`.
    """
    from fmionnx.runtime import lifetime

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the supervisor's to handle
    _die_with_parent()
    lifetime.set_subreaper(True)
    try:
        return _serve(argv)
    finally:
        lifetime.end_descendants()


def _serve(argv: list[str]) -> int:
    commands, replies, shared = (int(a) for a in argv[:3])
    options = argv[3:]
    spin = options[:1] != ["--no-spin"]
    if not spin:
        options = options[1:]
    if options[:1] == ["--keep"]:
        options = options[1:]
        from fmionnx.kinds.registry import settle_worker

        settle_worker()  # e.g. an FMU's unpacked files and loaded library kept for the next run
    refusal = None
    if options[:1] == ["--sandbox"]:  # first: a process with threads cannot enter namespaces
        from pathlib import Path

        from fmionnx.runtime.isolated.sandbox import SandboxUnavailableError, confine

        try:
            missing = confine(Path(options[1]), Path(options[2]))
        except SandboxUnavailableError as exc:
            missing = [str(exc)]
        if missing:
            refusal = "this system cannot confine the model: it lacks " + "; ".join(missing)
    from fmionnx.runtime.isolated.limits import limit_address_space
    from fmionnx.runtime.isolated.server import Child

    limit_address_space()  # before the model is loaded (after the sandbox's namespaces)

    Child(commands, replies, shared, refusal, spin=spin).serve()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
