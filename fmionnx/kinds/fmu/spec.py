"""System-file keys of a ``fmu`` component: its pydantic model, loaded only where a system
file or a lone model is compiled (a compiled system read back, a study's worker or an
isolated model's process needs none of pydantic)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from fmionnx.core.specbase import ComponentSpecBase


class FmuSpec(ComponentSpecBase):
    """System-file keys of an ``fmu`` component."""

    kind: Literal["fmu"] = "fmu"
    interface: Literal["cs", "me"] | None = Field(
        default=None,
        description="Interface type to use; default: co-simulation when offered, else model "
        "exchange.",
    )
    solver: Literal["cvode", "euler"] = Field(
        default="cvode", description="Model exchange only: integrator between communication points."
    )
    tolerance: float | None = Field(
        default=None, gt=0, description="Model exchange only: relative tolerance of CVode."
    )
