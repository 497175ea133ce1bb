"""The system file's ``run:`` section and the endpoint syntax, apart from the whole file's model.

Compiling a single model (``fmionnx run model.fmu``) needs these and nothing else of the
system-file format: :mod:`fmionnx.spec.model` builds its ``components`` union from every
component kind, which a lone model does not pay for (issue #14). ``SystemSpec.run`` is the
:class:`RunSpec` defined here.
"""

from __future__ import annotations

import re
from typing import Literal

from pydantic import Field, field_validator

from fmionnx.core.specbase import StrictModel
from fmionnx.core.steps import step_problem

#: ``name.more[3]``: a dotted name with an optional element index (``[0]`` or ``[0,2]``).
#: Which prefix is the component is decided by the compiler from the known component names
#: (SSP nested systems give dotted component names; Modelica FMUs give dotted port names).
#: A port whose name is no dotted word (PyTorch's ONNX names ``input.1`` and ``12``, a
#: camera ``a b``, FMI 2's ``medium[1].T``) is written between double quotes after its
#: component, ``t."input.1"[0]`` (group ``quoted``, the text before it group ``owner``): the
#: quotes hold the whole port name, which needs no escapes and so cannot itself hold ``"``.
ENDPOINT_RE = re.compile(
    r"^\s*(?:(?P<name>[A-Za-z_][\w:-]*(?:\.[A-Za-z_$][\w:$-]*)+)"
    r'|(?P<owner>[A-Za-z_][\w:-]*(?:\.[A-Za-z_$][\w:$-]*)*)\."(?P<quoted>[^"]+)")'
    r"(?:\[(?P<index>\s*\d+\s*(?:,\s*\d+\s*)*)\])?\s*$"
)


class AlgebraicLoopsSpec(StrictModel):
    """Opt-in iteration of algebraic loops (cycles through direct-feedthrough ports).

    Without this key such a loop is error E035; with it, each loop is solved at every
    communication point where its members are due (``docs/execution.md``).
    """

    model_config = StrictModel.model_config | {"allow_inf_nan": False, "strict": True}

    solver: Literal["fixed-point", "newton"] = Field(
        default="fixed-point",
        description="`fixed-point`: repeat the loop's step with the newest exchanged values "
        "(relaxed); `newton`: Newton's method on the exchanged values, with a finite-difference "
        "Jacobian.",
    )
    tolerance: float = Field(
        default=1e-10,
        gt=0,
        description="Converged when every exchanged value changes by at most "
        "tolerance * (1 + |value|) in one iteration.",
    )
    max_iterations: int = Field(
        default=50,
        ge=1,
        le=10_000,
        description="Iterations allowed per communication point; more is a fault naming the loop.",
    )
    relaxation: float = Field(
        default=1.0,
        gt=0,
        le=2,
        description="Step factor: x + relaxation * (update - x). Below 1 damps an oscillating "
        "or diverging iteration.",
    )


class RunSpec(StrictModel):
    """When and how finely the system runs. Missing values are resolved by the compiler."""

    model_config = StrictModel.model_config | {"allow_inf_nan": False}

    # strict: `stop: true` and `step: "0.01"` were taken as 1 and 0.01 (pydantic's lax mode),
    # while a parameter's `true` is refused; the schema says numbers.
    start: float = Field(default=0.0, strict=True, description="Start time in seconds.")
    stop: float | None = Field(default=None, strict=True, description="Stop time in seconds.")
    step: float | None = Field(
        default=None,
        gt=0,
        strict=True,
        description="Base step in seconds: the fastest component's period.",
    )
    output_interval: float | None = Field(
        default=None,
        gt=0,
        strict=True,
        description="Seconds between two rows of results.csv: a whole multiple of the base "
        "step (default: every base step). The last point of the run is always written.",
    )
    algebraic_loops: AlgebraicLoopsSpec | None = Field(
        default=None,
        description="Solve algebraic loops by iteration at each communication point (default: "
        "an algebraic loop is error E035).",
    )

    @field_validator("step", "output_interval")
    @classmethod
    def _normal_step(cls, value: float | None) -> float | None:
        # `gt=0` lets a subnormal such as 5e-324 through; it is positive but has no precision.
        problem = step_problem(value) if value is not None else None
        if problem is not None:
            msg = f"the step must be a normal positive float; {problem}"
            raise ValueError(msg)
        return value
