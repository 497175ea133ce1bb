"""Shared pieces of the raw system-file models (pydantic, strict, frozen)."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field
from pydantic import main as _pydantic_main

from fmionnx.core.modelfiles import NO_MODEL_FILE

#: A scalar in a system file. ``bool`` first so that ``true`` stays a bool, not 1.
ScalarLiteral = bool | int | float | str
#: A parameter or start value: a scalar, a list, or a list of lists (row-major).
ParameterLiteral = ScalarLiteral | list[ScalarLiteral] | list[list[ScalarLiteral]]


#: Whether a model's validator is built on first use instead of at import: a process that only
#: reads a compiled system back (a run from the compile cache, a study worker, an isolated
#: model's process) then builds none. Only where pydantic builds lazily under a lock (its
#: ``_rebuild_lock``, in recent 2.x): before that, two threads validating a model first at
#: the same time (a multi-threaded Dask worker) could use a half-built one.
DEFER_BUILD = hasattr(_pydantic_main, "_rebuild_lock")


class StrictModel(BaseModel):
    """Base of every raw model: unknown keys are errors, values are immutable."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=False, defer_build=DEFER_BUILD)


class ComponentSpecBase(StrictModel):
    """Keys every component has, whatever its kind.

    Kind-specific models (in ``fmionnx.kinds.<kind>``) add their own options; the
    ``kind`` key selects the model, so an option of another kind is an unknown key.
    """

    kind: str = Field(description="Component kind (one of the registered kinds).")
    path: str = Field(min_length=1, description="Model file, relative to the system file.")
    period: float | None = Field(
        default=None,
        gt=0,
        allow_inf_nan=False,
        strict=True,  # a number, not "0.02" (lax mode took the string)
        description="Seconds between two steps of this component; a whole multiple of "
        "`run.step`. Default: the base step.",
    )
    parameters: dict[str, ParameterLiteral] = Field(
        default_factory=dict,
        description="Values set before initialization: parameters and start values, by "
        "variable/port name.",
    )
    external: bool = Field(
        default=False,
        description="ROS 2 mode: the component is provided from outside (e.g. a real robot); "
        "its topics are expected, no node is started for it.",
    )
    description: str = Field(default="", description="Free text shown by `graph` and docs.")

    @property
    def has_model_file(self) -> bool:
        """False for an entry that names no model file (see :data:`NO_MODEL_FILE`)."""
        return self.path != NO_MODEL_FILE
