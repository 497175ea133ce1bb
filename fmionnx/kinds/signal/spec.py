"""The system-file entry of a ``signal`` component (pydantic models, checked on load)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, field_validator, model_validator

from fmionnx.core.modelfiles import NO_MODEL_FILE
from fmionnx.core.specbase import ComponentSpecBase, StrictModel
from fmionnx.kinds.signal.names import NAME, PORT_NAME

__all__ = ["NAME", "PORT_NAME", "WAVEFORMS", "OutputSpec", "SignalSpec"]

WAVEFORMS = ("constant", "step", "ramp", "sine")


class _Numbers(StrictModel):
    """Waveform parameters: finite numbers only."""

    model_config = StrictModel.model_config | {"allow_inf_nan": False}


class StepSpec(_Numbers):
    """``initial`` before ``time``, ``final`` from ``time`` on (at ``time`` already ``final``)."""

    time: float = Field(description="Time of the step in seconds.")
    initial: float = Field(default=0.0, description="Value before `time`.")
    final: float = Field(default=1.0, description="Value from `time` on.")


class RampSpec(_Numbers):
    """``initial`` until ``time``, then a straight line: by ``slope``, or to ``final``."""

    time: float = Field(default=0.0, description="Time the ramp starts, in seconds.")
    initial: float = Field(default=0.0, description="Value until `time`.")
    slope: float | None = Field(default=None, description="Change per second, without end.")
    final: float | None = Field(
        default=None, description="Value reached `duration` seconds after `time`, then held."
    )
    duration: float | None = Field(
        default=None, gt=0, description="Seconds from `initial` to `final`."
    )

    @model_validator(mode="after")
    def _one_form(self) -> RampSpec:
        to_final = self.final is not None or self.duration is not None
        if (self.slope is not None) == to_final:
            msg = "a ramp takes either `slope`, or `final` and `duration`"
            raise ValueError(msg)
        if to_final and (self.final is None or self.duration is None):
            msg = "a ramp to `final` needs both `final` and `duration`"
            raise ValueError(msg)
        return self


class SineSpec(_Numbers):
    """``offset + amplitude * sin(2π * frequency * t + phase)``, ``t`` the simulated time."""

    frequency: float = Field(
        ge=0, le=1e12, description="Frequency in Hz (at most 10^12: a sampled stimulus)."
    )
    amplitude: float = Field(default=1.0, description="Amplitude.")
    phase: float = Field(default=0.0, description="Phase at t = 0, in radians.")
    offset: float = Field(default=0.0, description="Value added to the sine.")


class OutputSpec(_Numbers):
    """One output port: exactly one waveform, and optionally a unit."""

    constant: float | None = Field(default=None, description="A constant value.")
    step: StepSpec | None = Field(default=None, description="`{time, initial: 0, final: 1}`.")
    ramp: RampSpec | None = Field(
        default=None,
        description="`{time: 0, initial: 0, slope}` or `{time: 0, initial: 0, final, duration}`.",
    )
    sine: SineSpec | None = Field(
        default=None, description="`{frequency, amplitude: 1, phase: 0, offset: 0}`."
    )
    unit: str | None = Field(
        default=None, min_length=1, description="Unit of the port (e.g. `m/s`)."
    )

    @model_validator(mode="after")
    def _one_waveform(self) -> OutputSpec:
        given = [w for w in WAVEFORMS if getattr(self, w) is not None]
        if len(given) != 1:
            found = ", ".join(f"`{w}`" for w in given) or "none"
            msg = (
                "an output takes exactly one waveform: `constant`, `step`, `ramp` or `sine` "
                f"(found {found})"
            )
            raise ValueError(msg)
        return self


class SignalSpec(ComponentSpecBase):
    """System-file keys of a ``signal`` component: ``outputs`` or a CSV table at ``path``."""

    kind: Literal["signal"] = NAME
    path: str = Field(
        default=NO_MODEL_FILE,
        description="A CSV table instead of `outputs`: a header line, then rows of time (first "
        "column, strictly increasing) and one value per column; each value column is an output "
        "port named by its header.",
    )
    outputs: dict[str, OutputSpec] = Field(
        default_factory=dict,
        description="Output ports by name, each with one waveform: `constant`, `step`, `ramp` "
        "or `sine` (float64 scalars).",
    )
    interpolation: Literal["linear", "hold"] = Field(
        default="linear",
        description="Table only: `linear` between rows, or `hold` each row's values until the "
        "next row. Before the first and after the last row the end values are held.",
    )

    @field_validator("outputs")
    @classmethod
    def _port_names(cls, value: dict[str, OutputSpec]) -> dict[str, OutputSpec]:
        for name in value:
            if not PORT_NAME.fullmatch(name):
                msg = (
                    f"output name `{name}` is not a port name: use letters, digits and `_`, "
                    "not starting with a digit"
                )
                raise ValueError(msg)
        return value
