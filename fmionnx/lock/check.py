"""Interface lock: record the interfaces a system was validated against, check them later.

``fmionnx lock SYSTEM`` compiles the system and writes ``<stem>.fmionnx.lock`` beside it
(see :mod:`fmionnx.lock.model` for the format). ``fmionnx validate --locked`` then re-reads
every model and compares (:mod:`fmionnx.lock.diff`), so a re-exported FMU or a retrained ONNX
model whose interface changed fails CI with a diff instead of failing on the robot.

The check reads the interfaces itself rather than taking them from the compiled system: a
changed interface usually also breaks connections, the compiler then returns no system, and
that is exactly when the lock diff explains the most.

``robot.yaml``, ``robot.yml`` and ``robot.ssp`` share one lock name; the lock's ``system:``
says whose it is. Locking one system never replaces another's lock without ``--force``, and
checking a system against another's lock is E081 naming the other system, never a diff
against models the system does not use.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from fmionnx import api
from fmionnx.compile.resolve import read_interface
from fmionnx.core import codes
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag, Note, Span
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

__all__ = [
    "LockResult",
    "PreparedLock",
    "check_lock",
    "check_lock_target",
    "lock_path",
    "lock_system",
    "locked_system",
    "prepare_lock",
    "write_lock",
]


@dataclass(frozen=True)
class LockResult:
    """What ``lock_system`` did: the lock written (None on errors), whether it changed."""

    path: Path | None
    changed: bool
    diagnostics: tuple[Diagnostic, ...]


@dataclass(frozen=True)
class PreparedLock:
    """A system compiled for locking, nothing written yet: the lock's path and text (None
    when the system has errors) and the compiler's diagnostics."""

    system: Path
    path: Path | None
    text: str | None
    diagnostics: tuple[Diagnostic, ...]


def locked_system(path: Path) -> str | None:
    """The system file the lock at ``path`` names (its ``system:``); None when there is no
    lock there or it cannot be read."""
    loaded = read_lock(path, path, DiagnosticBag())
    return None if loaded is None else loaded.lock.system


def check_lock_target(system: Path, *, force: bool) -> None:
    """Raise :class:`OverwriteRefusedError` when the lock's name holds something not ours.

    A lock ``fmionnx lock`` wrote for this system (recognised by its header and its
    ``system:``) is rewritten freely: re-locking is the normal loop. A hand-written file, a
    folder, a symbolic link, or the lock of another system sharing the name (``robot.yml``
    beside ``robot.yaml``, ``robot.ssp`` beside the ``robot.yaml`` converted from it) is
    replaced only with ``force``. A folder given as the system has no lock: compiling it
    says what it is (E011).
    """
    if force or system.is_dir():
        return
    path = lock_path(system)
    if not (path.exists() or path.is_symlink()):
        return
    if not written_by_lock(path):
        raise refuse(path, "exists and was not written by `fmionnx lock`")
    owner = locked_system(path)
    if owner is not None and owner != system.name:
        raise refuse(
            path,
            f"is the lock of `{owner}`, not of `{system.name}` (system files that differ only "
            "in their suffix share one lock name)",
        )


def prepare_lock(system: Path) -> PreparedLock:
    """Compile ``system`` and render its lock, writing nothing (a system with errors has
    no lock text)."""
    result = api.compile_system(system)
    if result.system is None:
        return PreparedLock(system, None, None, result.diagnostics)
    lock = LockFile.model_validate(
        {
            "fmionnx-lock": LOCK_VERSION,
            "system": system.name,
            "components": {c.name: LockedComponent.of(c) for c in result.system.components},
        }
    )
    return PreparedLock(system, lock_path(system), render_lock(lock), result.diagnostics)


def write_lock(prepared: PreparedLock) -> LockResult:
    """Write a prepared lock; one with errors writes nothing.

    The file is rewritten only when its text changes, so an unchanged lock keeps its
    modification time and ``git status`` stays clean. It is written atomically and never
    through a symbolic link.
    """
    path, text = prepared.path, prepared.text
    if path is None or text is None:
        return LockResult(None, changed=False, diagnostics=prepared.diagnostics)
    old = _old_lock(path)
    if old != text:
        if path.is_dir() and not path.is_symlink():  # only with force: a folder in the way
            shutil.rmtree(path)
        write_text_atomic(path, text)
    return LockResult(path, changed=old != text, diagnostics=prepared.diagnostics)


def lock_system(system: Path, *, force: bool = False) -> LockResult:
    """Compile ``system`` and write its lock; a system with errors is not locked.

    A name that is not an earlier lock of this system needs ``force``
    (:func:`check_lock_target`); see :func:`write_lock`.
    """
    check_lock_target(system, force=force)
    return write_lock(prepare_lock(system))


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
    if locked.lock.system != system.name:  # robot.yml's lock beside robot.yaml
        bag.emit(
            codes.LOCK_MISSING,
            f"`{locked.path.name}` is the lock of `{locked.lock.system}`, not of "
            f"`{system.name}`: `{system.name}` has no lock (system files that differ only in "
            "their suffix share one lock name)",
            Span(system),
            hint=f"rename one of the two system files, or lock this one instead with "
            f"`fmionnx lock --force {system}`",
            notes=[Note("the system this lock belongs to", locked.sources.value(("system",)))],
        )
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
