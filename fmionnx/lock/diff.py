"""Compare a model's current interface with its lock entry and say what changed.

Interface changes (E080) are port changes (added, removed, renamed-looking, causality, type,
shape or unit changed), a different component kind, and changes of the facts listed in
:data:`INTERFACE_FACTS`. Anything else that differs (the file's hash, the GUID or
instantiation token, the ONNX opset, the generation tool) means "binary changed, same
interface" (I080): worth knowing, not worth failing a build.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

from fmionnx.core import codes
from fmionnx.core.diagnostics import Diagnostic, Note, Span, make
from fmionnx.core.types import ComponentInterface, Port
from fmionnx.lock.model import UNLOCKED, LockedComponent, LockedPort
from fmionnx.lock.read import LoadedLock
from fmionnx.spec.sourcemap import SourceMap

#: Facts whose change changes how a system uses the model.
INTERFACE_FACTS = ("fmiVersion", "interfaceTypes")


@dataclass(frozen=True)
class LockContext:
    """Where the entry is: the lock and the component's key path in it."""

    lock: LoadedLock
    name: str

    @property
    def sources(self) -> SourceMap:
        """Positions in the lock file (parsed on first use)."""
        return self.lock.sources

    def at(self, *path: str | int) -> Span:
        """Span of a value under this component's entry."""
        return self.sources.value(("components", self.name, *path))

    def key(self, *path: str | int) -> Span:
        """Span of a key under this component's entry."""
        return self.sources.key(("components", self.name, *path))


def _signature(port: LockedPort) -> tuple[str, str, tuple[int | str, ...], str | None]:
    return (port.causality.value, port.dtype.value, tuple(port.shape), port.unit)


def _port_changes(locked: LockedPort, current: Port) -> list[str]:
    now = LockedPort.of(current)
    changes = []
    name = f"`{locked.name}`"
    if now.causality is not locked.causality:
        changes.append(f"{name}: causality changed from {locked.causality} to {now.causality}")
    if now.dtype is not locked.dtype:
        changes.append(f"{name}: type changed from {locked.dtype} to {now.dtype}")
    if now.shape != locked.shape:
        changes.append(f"{name}: shape changed from {locked.shape_text()} to {now.shape_text()}")
    if now.unit != locked.unit:
        before = f"`{locked.unit}`" if locked.unit else "no unit"
        after = f"`{now.unit}`" if now.unit else "no unit"
        changes.append(f"{name}: unit changed from {before} to {after}")
    return changes


def _renames(
    removed: list[tuple[int, LockedPort]], added: list[Port]
) -> list[tuple[int, LockedPort, Port]]:
    """Pair removed and added ports of identical signature, most similar names first."""
    candidates = [
        (difflib.SequenceMatcher(None, old.name, new.name).ratio(), index, old, new)
        for index, old in removed
        for new in added
        if _signature(old) == _signature(LockedPort.of(new))
    ]
    pairs = []
    used_old: set[str] = set()
    used_new: set[str] = set()
    for _, index, old, new in sorted(candidates, key=lambda c: (-c[0], c[2].name, c[3].name)):
        if old.name not in used_old and new.name not in used_new:
            pairs.append((index, old, new))
            used_old.add(old.name)
            used_new.add(new.name)
    return sorted(pairs, key=lambda p: p[1].name)


def port_notes(
    locked: LockedComponent, interface: ComponentInterface, ctx: LockContext
) -> list[Note]:
    """One note per port difference, each pointing at the lock line it concerns."""
    notes: list[Note] = []
    current = {p.name: p for p in interface.ports}
    removed: list[tuple[int, LockedPort]] = []
    for index, port in enumerate(locked.ports):
        now = current.get(port.name)
        if now is None:
            removed.append((index, port))
        else:
            changes = _port_changes(port, now)
            if changes:  # positions are looked up only for a difference (see LoadedLock)
                where = ctx.at("ports", index)
                notes.extend(Note(change, where) for change in changes)
    known = {p.name for p in locked.ports}
    added = [p for p in interface.ports if p.causality not in UNLOCKED and p.name not in known]
    renamed = _renames(removed, added)
    for index, old, new in renamed:
        notes.append(
            Note(
                f"`{old.name}` removed and `{new.name}` added, both {old.type_text()}: renamed?",
                ctx.at("ports", index),
            )
        )
    paired_old = {old.name for _, old, _ in renamed}
    paired_new = {new.name for _, _, new in renamed}
    for index, port in removed:
        if port.name not in paired_old:
            notes.append(
                Note(f"`{port.name}` removed (was {port.type_text()})", ctx.at("ports", index))
            )
    for new_port in added:
        if new_port.name not in paired_new:
            text = LockedPort.of(new_port).type_text()
            notes.append(Note(f"`{new_port.name}` added ({text})", ctx.key("ports")))
    return notes


def _fact_notes(
    locked: LockedComponent, interface: ComponentInterface, ctx: LockContext, keys: set[str]
) -> list[Note]:
    now = dict(interface.facts)
    notes = []
    for key in sorted((set(locked.facts) | set(now)) & keys):
        before, after = locked.facts.get(key), now.get(key)
        if before == after:
            continue
        where = ctx.key("facts", key) if key in locked.facts else ctx.key("facts")
        notes.append(Note(f"{key} changed from {_shown(before)} to {_shown(after)}", where))
    return notes


def _model(locked: LockedComponent) -> str:
    """The locked model file in backticks, or "its entry" for a component without one."""
    return f"`{locked.path}`" if locked.path else "its entry"


def _shown(value: str | None) -> str:
    return "(none)" if value is None else f"`{value}`"


def compare(
    name: str,
    kind: str,
    locked: LockedComponent,
    interface: ComponentInterface,
    span: Span,
    ctx: LockContext,
) -> Diagnostic | None:
    """E080, I080 or None (identical) for one component."""
    lock_file = ctx.lock.path.name
    notes: list[Note] = []
    if kind != locked.kind:
        notes.append(Note(f"kind changed from `{locked.kind}` to `{kind}`", ctx.at("kind")))
    all_facts = set(locked.facts) | {k for k, _ in interface.facts}
    notes.extend(_fact_notes(locked, interface, ctx, set(INTERFACE_FACTS)))
    notes.extend(port_notes(locked, interface, ctx))
    if notes:
        count = f"{len(notes)} change" + ("s" if len(notes) != 1 else "")
        return make(
            codes.LOCK_INTERFACE_CHANGED,
            f"component `{name}`: the interface of {_model(locked)} changed since it was locked "
            f"in `{lock_file}` ({count})",
            span,
            hint="if the change is intended, adapt the system and run `fmionnx lock` to "
            "record the new interface; otherwise restore the previous model",
            notes=notes,
        )
    fact_notes = _fact_notes(locked, interface, ctx, all_facts - set(INTERFACE_FACTS))
    hash_changed = bool(
        locked.sha256 and interface.content_hash and locked.sha256 != interface.content_hash
    )
    if not hash_changed and not fact_notes:
        return None
    if hash_changed:
        before = locked.sha256 or ""
        fact_notes.insert(
            0,
            Note(
                f"sha256 changed from {before[:12]}… to {interface.content_hash[:12]}…",
                ctx.at("sha256"),
            ),
        )
    return make(
        codes.LOCK_BINARY_CHANGED,
        f"component `{name}`: {_model(locked)} changed since it was locked in `{lock_file}`, "
        "its interface did not",
        span,
        hint="run `fmionnx lock` to record the new model",
        notes=fact_notes,
    )
