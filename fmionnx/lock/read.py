"""Read a lock file with positions, so lock findings can point at the line of a port.

Parsing reuses the system-file YAML loader (safe: plain data only, duplicate keys refused)
and its pydantic error mapping; every problem is reported as E082 at its position, because
for the user they all mean one thing: the lock cannot be trusted, regenerate it.

A lock arrives with the system, in a pull request as often as not, so it is read only from
its place: a regular file beside the system, never through a symbolic link (which could make
``validate --locked`` read, and quote in its diagnostics, a file anywhere). The paths a lock
names are text: ``system`` must be a plain file name, and a component's ``path`` is shown in
messages but never opened (interfaces are read from the system file's paths).
"""

from __future__ import annotations

from pathlib import Path

from pydantic import ValidationError
from ruamel.yaml import YAML
from ruamel.yaml.error import YAMLError

from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.lock.model import LOCK_VERSION, LockFile
from fmionnx.spec.limits import check_limits
from fmionnx.spec.pydantic_errors import report_validation_error
from fmionnx.spec.sourcemap import SourceMap
from fmionnx.spec.yaml import parse_yaml, read_text


class LoadedLock:
    """A parsed lock; where its keys and items are is worked out only when first asked.

    Positions need ruamel's round-trip parser, which is slow on the lock of a large system;
    the lock is first read with the (C) safe loader and re-parsed for positions only when a
    finding must point into it.
    """

    def __init__(self, lock: LockFile, path: Path, sources: SourceMap | None = None) -> None:
        self.lock = lock
        self.path = path
        self._sources = sources

    @property
    def sources(self) -> SourceMap:
        """Positions of every key and item of the lock file."""
        if self._sources is None:
            sources = SourceMap(self.path)
            parse_yaml(
                self.path.read_text(encoding="utf-8-sig"), self.path, sources, DiagnosticBag()
            )
            self._sources = sources
        return self._sources


def _fast(text: str) -> LockFile | None:
    """The lock when it reads and validates cleanly with the safe loader, else None.

    ``text`` must already be within the YAML limits: the safe loader shares aliased values,
    but validating them walks every repetition.
    """
    try:
        data = YAML(typ="safe", pure=False).load(text)
        if isinstance(data, dict) and data.get("fmionnx-lock") == LOCK_VERSION:
            return LockFile.model_validate(data)
    except (YAMLError, ValidationError, ValueError):
        return None
    return None


def read_lock(path: Path, system: Path, bag: DiagnosticBag) -> LoadedLock | None:
    """Read ``path``; None with E081 (missing) or E082 (unreadable) diagnostics in ``bag``."""
    if not path.exists():
        bag.emit(
            codes.LOCK_MISSING,
            f"no interface lock `{path.name}` beside `{system.name}`",
            Span(system),
            hint=f"run `fmionnx lock {system}` and commit `{path.name}`",
        )
        return None
    regenerate = f"regenerate it with `fmionnx lock {system}`"
    if path.is_symlink():
        bag.emit(
            codes.LOCK_INVALID,
            f"lock file `{path.name}` is a symbolic link; a lock is read only as a regular file "
            "beside its system",
            Span(path),
            hint=f"replace the link by the lock itself: {regenerate}",
        )
        return None
    scratch = DiagnosticBag()
    text = read_text(path, scratch)
    if text is not None and check_limits(text, path, scratch):
        fast = _fast(text)
        if fast is not None:
            return _named_plainly(LoadedLock(fast, path), bag, regenerate)
    else:
        text = None
    sources = SourceMap(path)
    data = parse_yaml(text, path, sources, scratch) if text is not None else None
    if data is not None and not isinstance(data, dict):
        scratch.emit(codes.INVALID_VALUE, "a lock file is a mapping", Span(path, 1, 1))
        data = None
    lock = None
    if data is not None:
        version = data.get("fmionnx-lock")
        if version != LOCK_VERSION:
            bag.emit(
                codes.LOCK_INVALID,
                f"lock file version `{version}` is not supported (this release writes "
                f"`fmionnx-lock: {LOCK_VERSION}`)",
                sources.value(("fmionnx-lock",)),
                hint=regenerate,
            )
            return None
        try:
            lock = LockFile.model_validate(data)
        except ValidationError as exc:
            report_validation_error(exc, data, sources, scratch, root=LockFile)
    for diagnostic in scratch:
        bag.emit(
            codes.LOCK_INVALID,
            f"lock file `{path.name}`: {diagnostic.message}",
            diagnostic.span,
            hint=regenerate,
        )
    if lock is None:
        return None
    return _named_plainly(LoadedLock(lock, path, sources), bag, regenerate)


def _named_plainly(loaded: LoadedLock, bag: DiagnosticBag, regenerate: str) -> LoadedLock | None:
    """``loaded``, or None with E082 when its ``system`` is not a plain file name."""
    name = loaded.lock.system
    if name and name not in (".", "..") and "/" not in name and "\\" not in name:
        return loaded
    bag.emit(
        codes.LOCK_INVALID,
        f"lock file `{loaded.path.name}` names the system `{name}`, not a file name "
        "(a lock lies beside its system and names it without a folder)",
        loaded.sources.value(("system",)),
        hint=regenerate,
    )
    return None
