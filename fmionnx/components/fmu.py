"""FMU components (FMI 2.0 and 3.0, co-simulation and model exchange)."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field

from fmionnx.compile.ir import ComponentInterface
from fmionnx.spec.base import ComponentSpecBase


class FmuSpec(ComponentSpecBase):
    """System-file keys of an ``fmu`` component."""

    kind: Literal["fmu"] = "fmu"  # type: ignore[assignment]
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


class FmuKind:
    """Reads FMU interfaces from ``modelDescription.xml`` (via fmpy)."""

    name = "fmu"
    spec_model = FmuSpec
    suffixes = (".fmu",)
    summary = "Functional Mock-up Unit (FMI 2.0/3.0, CS/ME)"

    def read_interface(self, path: Path, spec: ComponentSpecBase | None) -> ComponentInterface:
        """Read the FMU's ports and facts."""
        raise NotImplementedError


FMU_KIND = FmuKind()
