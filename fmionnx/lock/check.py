"""Interface lock: record the interfaces a system was validated against, check them later.

``fmionnx lock SYSTEM`` compiles the system and writes ``<stem>.fmionnx.lock`` beside it
(see :mod:`fmionnx.lock.model` for the format). ``fmionnx validate --locked`` then re-reads
every model and compares (:mod:`fmionnx.lock.diff`), so a re-exported FMU or a retrained ONNX
model whose interface changed fails CI with a diff instead of failing on the robot.

The check reads the interfaces itself rather than taking them from the compiled system: a
changed interface usually also breaks connections, the compiler then returns no system, and
that is exactly when the lock diff explains the most.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from fmionnx import api
from fmionnx.compile.resolve import read_interface
from fmionnx.core import codes
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag
from fmionnx.core.safewrite import refuse, write_text_atomic
from fmionnx.lock.diff import LockContext, compare
from fmionnx.lock.model import (
    LOCK_VERSION,
    LockedComponent,
    LockFile,
    lock_path,
    render_lock,
    written_by_lock,
)
from fmionnx.lock.read import read_lock
from fmionnx.spec.frontends import load_system

__all__ = ["LockResult", "check_lock", "check_lock_target", "lock_path", "lock_system"]


@dataclass(frozen=True)
class LockResult:
    """What ``lock_system`` did: the lock written (None on errors), whether it changed."""

    path: Path | None
    changed: bool
    diagnostics: tuple[Diagnostic, ...]


def check_lock_target(system: Path, *, force: bool) -> None:
    """Raise :class:`OverwriteRefusedError` when the lock's name holds something not ours.

    A lock ``fmionnx lock`` wrote (recognised by its header) is rewritten freely: re-locking
    is the normal loop. A hand-written file, a folder or a symbolic link at that name is
    replaced only with ``force``.
    """
    path = lock_path(system)
    if force or not (path.exists() or path.is_symlink()):
        return
    if not written_by_lock(path):
        raise refuse(path, "exists and was not written by `fmionnx lock`")


def lock_system(system: Path, *, force: bool = False) -> LockResult:
    """Compile ``system`` and write its lock; a system with errors is not locked.

    The file is rewritten only when its text changes, so an unchanged lock keeps its
    modification time and ``git status`` stays clean. It is written atomically and never
    through a symbolic link; a name that is not an earlier lock needs ``force``.
    """
    check_lock_target(system, force=force)
    result = api.compile_system(system)
    if result.system is None:
        return LockResult(None, changed=False, diagnostics=result.diagnostics)
    lock = LockFile.model_validate(
        {
            "fmionnx-lock": LOCK_VERSION,
            "system": system.name,
            "components": {c.name: LockedComponent.of(c) for c in result.system.components},
        }
    )
    text = render_lock(lock)
    path = lock_path(system)
    old = _old_lock(path)
    if old != text:
        if path.is_dir() and not path.is_symlink():  # only with force: a folder in the way
            shutil.rmtree(path)
        write_text_atomic(path, text)
    return LockResult(path, changed=old != text, diagnostics=result.diagnostics)


def _old_lock(path: Path) -> str | None:
    """The text of the lock at ``path``; a link is never read through (it gets replaced)."""
    if path.is_symlink() or not path.is_file():
        return None
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None


def check_lock(system: Path) -> list[Diagnostic]:
    """Compare every component's current interface with the lock beside ``system``.

    Problems of the system file or of unreadable models are not repeated here: the compiler
    reports them; components it cannot read are skipped.
    """
    scratch = DiagnosticBag()
    loaded = load_system(system, scratch)
    if loaded.spec is None:
        return []
    bag = DiagnosticBag()
    locked = read_lock(lock_path(system), system, bag)
    if locked is None:
        return bag.sorted()
    for name, spec in loaded.spec.components.items():
        span = loaded.sources.key(("components", name))
        entry = locked.lock.components.get(name)
        if entry is None:
            bag.emit(
                codes.LOCK_MISSING,
                f"component `{name}` is not in the lock `{locked.path.name}`",
                span,
                hint=f"run `fmionnx lock {system}` to add it, and commit the lock file",
            )
            continue
        interface = read_interface(name, spec, system, loaded.sources, scratch)
        if interface is None:
            continue
        found = compare(name, spec.kind, entry, interface, span, LockContext(locked, name))
        if found is not None:
            bag.add(found)
    return bag.sorted()
