"""The interface lock file: its data model and its diff-friendly YAML text.

A lock records, per component, the interface a system was validated against: every port a
system can use (all causalities but ``local`` and ``independent``) with causality, dtype,
shape and unit; the model's facts (FMI version, GUID / instantiation token, ONNX opset ...);
and the sha256 of the model file. The text is written by hand rather than by a YAML dumper
so the layout is fixed: sorted keys, one port per line, no timestamps, so a re-export that
changes one unit changes one line of the diff.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Literal

from pydantic import ConfigDict, Field

from fmionnx.core.specbase import StrictModel
from fmionnx.core.types import Causality, Component, DType, Port

LOCK_VERSION = 1
LOCK_SUFFIX = ".fmionnx.lock"

#: Causalities a system never connects to; ports of these are not locked.
UNLOCKED = (Causality.LOCAL, Causality.INDEPENDENT)


#: The first line of every lock file starts with this; a file without it is not ours.
LOCK_HEADER = "# Interface lock of "


def written_by_lock(path: Path) -> bool:
    """``path`` is a regular file whose first line is the header ``render_lock`` writes."""
    if path.is_symlink() or not path.is_file():
        return False
    try:
        with path.open(encoding="utf-8") as stream:
            return stream.readline().startswith(LOCK_HEADER)
    except (OSError, UnicodeDecodeError):
        return False


def lock_path(system: Path) -> Path:
    """``systems/robot.yaml`` -> ``systems/robot.fmionnx.lock``.

    The suffix is not part of the name: ``robot.yaml``, ``robot.yml`` and ``robot.ssp`` share
    one lock name, and the lock's ``system:`` says which of them it belongs to (the lock
    command refuses to replace another system's lock, ``validate --locked`` refuses to check
    against one). A path without a name of its own (``.``, ``..``, ``""``) is resolved first;
    one that has none even then (``/``) is a ValueError: a folder has no lock.
    """
    if system.name in ("", ".", ".."):
        system = system.resolve()
    if not system.name:
        msg = f"`{system}` is a folder, not a system file: it has no lock"
        raise ValueError(msg)
    return system.with_name(system.stem + LOCK_SUFFIX)


class LockedPort(StrictModel):
    """One port as locked."""

    name: str
    causality: Causality
    dtype: DType
    shape: list[int | str] = Field(default_factory=list)
    unit: str | None = None

    @classmethod
    def of(cls, port: Port) -> LockedPort:
        """The locked form of an interface port."""
        return cls(
            name=port.name,
            causality=port.causality,
            dtype=port.dtype,
            shape=list(port.shape),
            unit=port.unit,
        )

    def shape_text(self) -> str:
        """``scalar`` or ``[1,3]``, like :meth:`fmionnx.compile.ir.Port.shape_text`."""
        return "[" + ",".join(str(d) for d in self.shape) + "]" if self.shape else "scalar"

    def type_text(self) -> str:
        """``output float64[3] (m)``: causality, type, shape and unit in one phrase."""
        shape = "" if not self.shape else self.shape_text()
        unit = f" ({self.unit})" if self.unit else ""
        return f"{self.causality.value} {self.dtype.value}{shape}{unit}"


class LockedComponent(StrictModel):
    """One component's locked interface."""

    kind: str
    path: str
    sha256: str | None = None
    facts: dict[str, str] = Field(default_factory=dict)
    ports: list[LockedPort] = Field(default_factory=list)

    @classmethod
    def of(cls, component: Component) -> LockedComponent:
        """Lock what the compiler read from the model file."""
        interface = component.interface
        ports = sorted(
            (LockedPort.of(p) for p in interface.ports if p.causality not in UNLOCKED),
            key=lambda p: p.name,
        )
        return cls(
            kind=component.kind,
            path=component.declared_path,
            sha256=interface.content_hash or None,
            facts=dict(sorted(interface.facts)),
            ports=ports,
        )


class LockFile(StrictModel):
    """The whole lock file."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)

    version: Literal[1] = Field(alias="fmionnx-lock")
    system: str
    components: dict[str, LockedComponent] = Field(default_factory=dict)


#: Words YAML 1.2 or common YAML 1.1 readers (PyYAML) take for something other than a string.
_SPECIAL = {"true", "false", "yes", "no", "on", "off", "null", "~", ""}
_PLAIN = re.compile(r"[A-Za-z_][A-Za-z0-9_./-]*")


def yaml_str(text: str) -> str:
    """A YAML scalar reading back as the string ``text``: plain when safe, else quoted.

    Plain scalars are limited to identifier-like text so they are safe inside flow mappings
    (no ``[]{},:#``); everything else is a JSON string, which is a valid YAML double-quoted
    scalar.
    """
    if _PLAIN.fullmatch(text) and text.lower() not in _SPECIAL:
        return text
    return json.dumps(text, ensure_ascii=False)


def _port_line(port: LockedPort) -> str:
    dims = ", ".join(str(d) if isinstance(d, int) else yaml_str(d) for d in port.shape)
    parts = [
        f"name: {yaml_str(port.name)}",
        f"causality: {port.causality.value}",
        f"dtype: {port.dtype.value}",
        f"shape: [{dims}]",
    ]
    if port.unit is not None:
        parts.append(f"unit: {yaml_str(port.unit)}")
    return "      - {" + ", ".join(parts) + "}"


def render_lock(lock: LockFile) -> str:
    """The lock file text (sorted, one port per line, newline-terminated)."""
    lines = [
        f"{LOCK_HEADER}{lock.system}, written by `fmionnx lock`.",
        "# `fmionnx validate --locked` fails when a model's interface no longer matches it.",
        f"# After an intended change: `fmionnx lock {lock.system}`, then commit this file.",
        f"fmionnx-lock: {lock.version}",
        f"system: {yaml_str(lock.system)}",
        "components:" + ("" if lock.components else " {}"),
    ]
    for name in sorted(lock.components):
        entry = lock.components[name]
        lines.append(f"  {yaml_str(name)}:")
        lines.append(f"    kind: {yaml_str(entry.kind)}")
        lines.append(f"    path: {yaml_str(entry.path)}")
        if entry.sha256 is not None:
            lines.append(f"    sha256: {json.dumps(entry.sha256)}")
        if entry.facts:
            lines.append("    facts:")
            lines.extend(
                f"      {yaml_str(key)}: {json.dumps(value, ensure_ascii=False)}"
                for key, value in sorted(entry.facts.items())
            )
        else:
            lines.append("    facts: {}")
        if entry.ports:
            lines.append("    ports:")
            lines.extend(_port_line(p) for p in sorted(entry.ports, key=lambda p: p.name))
        else:
            lines.append("    ports: []")
    return "\n".join(lines) + "\n"
