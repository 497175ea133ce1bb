"""Hand-built interfaces and their lock, for the lock unit tests (real models: test_cli_lock)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from fmionnx.core.diagnostics import DiagnosticBag
from fmionnx.core.types import Causality, Component, ComponentInterface, DType, Port
from fmionnx.kinds.fmu.kind import FmuConfig
from fmionnx.lock.model import LockedComponent, LockFile, render_lock
from fmionnx.lock.read import LoadedLock, read_lock

GAIN = ComponentInterface(
    kind="fmu",
    path=Path("Gain.fmu"),
    ports=(
        Port("u", Causality.INPUT, DType.FLOAT64, unit="m"),
        Port("k", Causality.PARAMETER, DType.FLOAT64),
        Port("y", Causality.OUTPUT, DType.FLOAT64, unit="m"),
        Port("w", Causality.OUTPUT, DType.FLOAT64, (3,), unit="m"),
        Port("state", Causality.LOCAL, DType.FLOAT64),
    ),
    facts=(("fmiVersion", "2.0"), ("guid", "{1234}"), ("interfaceTypes", "cs,me")),
    content_hash="a" * 64,
)


def component(interface: ComponentInterface, name: str = "gain") -> Component:
    """A compiled component around ``interface``."""
    return Component(
        name=name,
        kind=interface.kind,
        path=interface.path,
        interface=interface,
        config=FmuConfig(),
        declared_path=str(interface.path),
        period=0.01,
        period_steps=1,
    )


def write_and_read(tmp_path: Path, *interfaces: ComponentInterface) -> LoadedLock:
    """Lock ``interfaces`` (named gain, gain2 ...) into ``tmp_path`` and read the lock back."""
    names = ["gain", *(f"gain{i}" for i in range(2, len(interfaces) + 1))]
    lock = LockFile.model_validate(
        {
            "fmionnx-lock": 1,
            "system": "system.yaml",
            "components": {
                n: LockedComponent.of(component(i, n))
                for n, i in zip(names, interfaces, strict=True)
            },
        }
    )
    path = tmp_path / "system.fmionnx.lock"
    path.write_text(render_lock(lock), encoding="utf-8")
    bag = DiagnosticBag()
    loaded = read_lock(path, tmp_path / "system.yaml", bag)
    assert loaded is not None, [d.message for d in bag]
    return loaded


def with_port(interface: ComponentInterface, port: str, /, **changes: object) -> ComponentInterface:
    """``interface`` with port ``port`` changed (fields of :class:`Port`)."""
    ports = tuple(replace(p, **changes) if p.name == port else p for p in interface.ports)  # type: ignore[arg-type]
    return replace(interface, ports=ports)
