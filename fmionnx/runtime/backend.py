"""The backend contract: options that check themselves, validate before running, then run.

A backend is one module and one entry of the run pipeline's table
(:data:`fmionnx.pipeline.backends.BACKENDS`). It declares the options it takes as a frozen
dataclass (:class:`BackendOptions`): the pipeline hands it the options a caller gave by name
(``sync="free"`` from Python, ``--sync free`` on the command line), the dataclass converts and
checks them once, and refuses what it does not take, so every front end gets the same rules
and the same messages. Then, with the compiled system known, :meth:`Backend.prepare` settles
what depends on it (defaults such as the in-process isolation), :meth:`Backend.validate` says
what would stop the run before anything starts, and :meth:`Backend.run` runs
(Hamilton's ``GraphExecutor`` shape).

A run never raises for a fault inside the simulation: it returns a
:class:`~fmionnx.runtime.result.RunResult` whose ``status`` says how it ended.
"""

from __future__ import annotations

import abc
import dataclasses
from collections.abc import Mapping
from typing import TYPE_CHECKING, ClassVar, Self

from fmionnx.core.errors import FmionnxError
from fmionnx.core.types import is_number

if TYPE_CHECKING:  # options are checked without numpy: the CLI checks them before a run loads
    from fmionnx.compile.ir import CompiledSystem
    from fmionnx.core.diagnostics import Diagnostic
    from fmionnx.runtime.result import RunOptions, RunResult


class OptionsError(FmionnxError):
    """A backend option that does not fit: a usage error (the CLI exits 2)."""


def flag(name: str) -> str:
    """An option's name as the command line spells it (``input_wait`` -> ``--input-wait``).

    Messages name options by their flags: the CLI and the docs use them, and a Python caller
    reads ``--input-wait`` as ``input_wait`` without help.
    """
    return "--" + name.replace("_", "-")


def checked_rtf(value: object) -> float:
    """``--rtf``: a pace >= 0 times real time, finite (0: as fast as possible); every backend
    that paces takes it with this rule."""
    if not is_number(value):
        msg = f"--rtf takes a number, not `{value}`"
        raise OptionsError(msg)
    rtf = float(value)
    if not 0 <= rtf < float("inf"):  # also NaN
        msg = f"--rtf must be a finite number >= 0 (0: as fast as possible), not {rtf!r}"
        raise OptionsError(msg)
    return rtf


@dataclasses.dataclass(frozen=True)
class BackendOptions:
    """Base of a backend's options: a frozen dataclass whose fields are the option names.

    Subclasses convert and check the values in :meth:`checked` (raise :class:`OptionsError`);
    :meth:`from_given` refuses names the backend does not take.
    """

    @classmethod
    def names(cls) -> frozenset[str]:
        """The options this backend takes (its fields)."""
        return frozenset(f.name for f in dataclasses.fields(cls))

    @classmethod
    def from_given(
        cls, given: Mapping[str, object], backend: str, elsewhere: Mapping[str, str] | None = None
    ) -> Self:
        """The options from the values a caller gave (absent: the field's default).

        ``elsewhere`` names, for an option this backend does not take, the backends that do
        (``--input-wait applies to --backend ros2, not to --backend inprocess``).
        """
        unknown = sorted(set(given) - cls.names())
        if unknown:
            where = (elsewhere or {}).get(unknown[0])
            if where:
                msg = f"{flag(unknown[0])} applies to --backend {where}, not to --backend {backend}"
            else:
                msg = f"{flag(unknown[0])} does not apply to --backend {backend}"
            raise OptionsError(msg)
        return cls.checked(given)

    @classmethod
    def checked(cls, given: Mapping[str, object]) -> Self:
        """Convert and check ``given`` (names already known to be fields)."""
        raise NotImplementedError

    def where(self) -> str:
        """Where the run goes, for its first line (`` as ROS 2 nodes (lockstep)``); may be
        empty."""
        return ""

    def how(self) -> str:
        """How it is kept safe, for the end of that line (`` in a guarded process``); may be
        empty."""
        return ""

    @property
    def publishes_rows(self) -> bool:
        """Whether the run publishes its rows while it goes (a follower can format results)."""
        return False

    def details(self) -> dict[str, str | bool]:
        """What run.json's ``execution`` says of these options."""
        return {}


@dataclasses.dataclass(frozen=True)
class RunContext:
    """What a backend's :meth:`Backend.prepare` may need to know of the run besides the system."""

    #: Camera frames and signals go to a recording (``--record``).
    recording: bool = False
    #: Camera frames and signals go to a live view while the run goes (``--view``, ``--rrd``).
    viewing: bool = False


class Backend(abc.ABC):
    """Runs compiled systems. Stateless: runtime objects live inside one ``run`` call."""

    #: The name the table, ``--backend`` and ``run.json`` use.
    name: ClassVar[str]
    #: One line for ``--help``.
    summary: ClassVar[str]
    #: The options this backend takes.
    options_type: ClassVar[type[BackendOptions]]
    #: Whether ``--record FILE`` is written by the backend itself (ROS 2: the wire as it
    #: crossed); else the pipeline records the frames and signals the run hands it.
    records_itself: ClassVar[bool] = False
    #: Whether a single model (``.fmu``) can be run; system files always can.
    runs_single_models: ClassVar[bool] = True

    def prepare(
        self, system: CompiledSystem, options: BackendOptions, context: RunContext
    ) -> BackendOptions:
        """``options`` with what depends on the system settled (raise :class:`OptionsError`)."""
        del system, context
        return options

    def start_helpers(self, system: CompiledSystem, options: BackendOptions) -> None:
        """Start the helper processes the run will need, now: before the pipeline starts
        its own (the plot worker) and its observers their threads, while a command's
        process may still fork them (:mod:`fmionnx.core.forking`). ``options`` come from
        :meth:`prepare`. Nothing by default."""
        del system, options

    @abc.abstractmethod
    def validate(self, system: CompiledSystem, options: BackendOptions) -> list[Diagnostic]:
        """Problems that would stop this backend from running ``system`` (empty when fine)."""

    @abc.abstractmethod
    def run(self, system: CompiledSystem, options: BackendOptions, run: RunOptions) -> RunResult:
        """Run ``system`` from its start to its stop time (or until a fault / Ctrl-C)."""
