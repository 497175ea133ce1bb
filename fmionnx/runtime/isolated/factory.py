"""Which components run isolated (``--isolate`` words) and the runner factory that does it."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.runner import Runner, RunnerFactory, Wiring
from fmionnx.core.types import Component

if TYPE_CHECKING:  # the proxy (pipes, shared memory, the zygote) only for a run that isolates
    from fmionnx.runtime.isolated.proxy import IsolationSettings

#: ``--isolate`` words besides component names.
EVERY_FMU = "fmus"
EVERY_COMPONENT = "all"
NOTHING = "none"


def isolating_factory(
    base: RunnerFactory, names: Iterable[str], settings: IsolationSettings
) -> RunnerFactory:
    """``base``, except that the components in ``names`` get an
    :class:`~fmionnx.runtime.isolated.proxy.IsolatedRunner`."""
    from fmionnx.runtime.isolated.proxy import IsolatedRunner

    chosen = frozenset(names)

    def make(component: Component, wiring: Wiring) -> Runner:
        if component.name in chosen:
            return IsolatedRunner(component, wiring, settings)
        return base(component, wiring)

    return make


def isolation_targets(
    system: CompiledSystem, words: Iterable[str]
) -> tuple[frozenset[str], list[str]]:
    """The components ``--isolate`` words select, and the words that name nothing.

    ``fmus`` selects every FMU, ``all`` every component, ``none`` nothing; any other word is a
    component name.
    """
    from fmionnx.kinds.base import FMI
    from fmionnx.kinds.registry import has_capability

    chosen: set[str] = set()
    unknown: list[str] = []
    names = {c.name for c in system.components}
    for word in words:
        if word == NOTHING:
            continue
        if word == EVERY_COMPONENT:
            chosen |= names
        elif word == EVERY_FMU:
            chosen |= {c.name for c in system.components if has_capability(c, FMI)}
        elif word in names:
            chosen.add(word)
        else:
            unknown.append(word)
    return frozenset(chosen), unknown
