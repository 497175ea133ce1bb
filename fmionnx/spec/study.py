"""The raw study-file model (``fmionnx sweep STUDY``): what to vary, what to measure.

A study names one system file and says, per *target* (``component.parameter`` or a run
setting such as ``run.stop``), which values to try: a grid axis (a list, ``values``,
``range``) or a sampled dimension (``random``, ``latin_hypercube``). Grid axes combine as a
cartesian product; sampled dimensions are drawn jointly (``samples`` rows, one ``seed``) and
every sample row is combined with every grid point. ``metrics`` are measures in the checks
language (``final(plant.y)``), ``objective`` ranks the cases by one of them.

The file is read by the same line-aware YAML loader as a system file (positions on every key
and value, the same resource limits, no tags); targets, values and metrics are resolved
against the compiled system by :mod:`fmionnx.compile.study`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal, TypeGuard

from pydantic import (
    BeforeValidator,
    Field,
    ModelWrapValidatorHandler,
    PrivateAttr,
    ValidationError,
    field_validator,
    model_validator,
)

from fmionnx.core import codes
from fmionnx.core.diagnostics import DiagnosticBag, Span
from fmionnx.core.sourcetext import edited_text
from fmionnx.core.specbase import ScalarLiteral, StrictModel
from fmionnx.spec.model import known_format
from fmionnx.spec.pydantic_errors import report_validation_error
from fmionnx.spec.sourcemap import SourceMap
from fmionnx.spec.yaml import parse_yaml, read_text

#: Significant digits kept of generated numbers (a range's, a sample's): tidy tables, the same
#: cases on every machine. Numbers the study file writes are kept as written.
GENERATED_DIGITS = 12


def _not_null(value: object) -> object:
    """Refuse ``null`` before the union of scalars does, whose last member's complaint ("a
    valid boolean") says nothing of what is wrong."""
    if value is None:
        msg = "null is not a value: write a number, `true`/`false` or a text (quoted)"
        raise ValueError(msg)
    return value


#: One value of a study's list, never null.
StudyScalar = Annotated[ScalarLiteral, BeforeValidator(_not_null)]
#: A parameter value a study may try: a scalar or a flat list (an array parameter).
StudyValue = Annotated[StudyScalar | list[StudyScalar], BeforeValidator(_not_null)]


def _integer(value: object) -> TypeGuard[int]:
    """Whether ``value`` was written as an integer (``true`` is not one)."""
    return isinstance(value, int) and not isinstance(value, bool)


def tidy(value: float) -> float:
    """``value`` rounded to :data:`GENERATED_DIGITS` significant digits (a generated number)."""
    return float(f"{value:.{GENERATED_DIGITS}g}")


def between(start: float, stop: float, fraction: float) -> float:
    """The number ``fraction`` of the way from ``start`` to ``stop``, never overflowing where
    both are finite (``start + (stop - start) * fraction`` is infinite from ``-1e308`` to
    ``1e308``), and ``start``/``stop`` exactly at 0 and 1."""
    if fraction == 1:
        return stop
    return start * (1 - fraction) + stop * fraction


def within(value: float, low: float, high: float) -> float:
    """``value`` (a generated number) tidied, unless tidying takes it out of ``[low, high]``;
    kept inside it either way (a last rounding of the sum can step past a bound)."""
    tidied = tidy(value)
    chosen = tidied if low <= tidied <= high else value
    return min(max(chosen, low), high)


class RangeSpec(StrictModel):
    """``num`` evenly spaced numbers from ``start`` to ``stop`` (both included)."""

    # The docstring above is the schema's description (``schemas/study.schema.json``).

    model_config = StrictModel.model_config | {"allow_inf_nan": False}
    start: float = Field(description="First value.")
    stop: float = Field(description="Last value (included).")
    num: int = Field(ge=1, le=100_000, description="How many values (at least 1).")
    #: ``start`` and ``stop`` as written when both are integers (exact, however large).
    _whole: tuple[int, int] | None = PrivateAttr(default=None)

    @model_validator(mode="wrap")
    @classmethod
    def _written_whole(cls, data: Any, handler: ModelWrapValidatorHandler[RangeSpec]) -> RangeSpec:
        """Keep ``start`` and ``stop`` as written when both are integers: the fields are
        floats (a large integer is not exact as one, and ``0`` is then ``0.0``)."""
        made = handler(data)
        if isinstance(data, dict):
            start, stop = data.get("start"), data.get("stop")
            if _integer(start) and _integer(stop):
                made._whole = (start, stop)
        return made

    def numbers(self) -> list[float] | list[int]:
        """The range's numbers: ``start`` and ``stop`` as written, those between generated
        (rounded to :data:`GENERATED_DIGITS` digits, within the range).

        ``start`` and ``stop`` written as integers, with every number between them whole,
        give integers (``{start: 0, stop: 10, num: 11}``: 0, 1, ... 10), as the same numbers
        written as a list do: an integer parameter takes them, a float one converts them (a
        bug hunt: an integer parameter could not be varied by a range at all)."""
        if self._whole is not None:
            first, last = self._whole
            steps = max(self.num - 1, 1)
            if (last - first) % steps == 0:
                return [first + (last - first) // steps * i for i in range(self.num)]
        if self.num == 1:
            return [self.start]
        low, high = sorted((self.start, self.stop))
        inner = [
            within(between(self.start, self.stop, i / (self.num - 1)), low, high)
            for i in range(1, self.num - 1)
        ]
        return [self.start, *inner, self.stop]


class BoundsSpec(StrictModel):
    """A sampled dimension's interval ``[low, high)``."""

    model_config = StrictModel.model_config | {"allow_inf_nan": False}
    low: float = Field(description="Lower bound (included).")
    high: float = Field(description="Upper bound (excluded); greater than `low`.")

    @model_validator(mode="after")
    def _ordered(self) -> BoundsSpec:
        if not self.high > self.low:
            msg = f"`high` ({self.high:g}) must be greater than `low` ({self.low:g})"
            raise ValueError(msg)
        return self


class AxisSpec(StrictModel):
    """How one target varies: exactly one of ``values``/``list``, ``range``, ``random``,
    ``latin_hypercube``."""

    values: list[StudyValue] | None = Field(
        default=None, min_length=1, description="Grid axis: these values, in this order."
    )
    list_: list[StudyValue] | None = Field(
        default=None, alias="list", min_length=1, description="Same as `values`."
    )
    range: RangeSpec | None = Field(
        default=None, description="Grid axis: `{start, stop, num}` evenly spaced values."
    )
    random: BoundsSpec | None = Field(
        default=None, description="Sampled: uniform in `{low, high}` (see `sampling`)."
    )
    latin_hypercube: BoundsSpec | None = Field(
        default=None,
        description="Sampled: a Latin-hypercube design over `{low, high}`, joint with the "
        "study's other Latin-hypercube targets (see `sampling`).",
    )

    model_config = StrictModel.model_config | {"populate_by_name": True}

    @model_validator(mode="before")
    @classmethod
    def _bare_list(cls, data: Any) -> Any:
        """``target: [1, 2]`` is short for ``target: {values: [1, 2]}``."""
        return {"values": data} if isinstance(data, list) else data

    @model_validator(mode="after")
    def _exactly_one(self) -> AxisSpec:
        given = [
            name
            for name, value in (
                ("values", self.values),
                ("list", self.list_),
                ("range", self.range),
                ("random", self.random),
                ("latin_hypercube", self.latin_hypercube),
            )
            if value is not None
        ]
        if len(given) != 1:
            what = ", ".join(f"`{g}`" for g in given) if given else "none"
            msg = (
                "give exactly one of `values`, `list`, `range`, `random`, `latin_hypercube` "
                f"(found {what})"
            )
            raise ValueError(msg)
        return self

    @property
    def sampled(self) -> Literal["random", "latin_hypercube"] | None:
        """The sampling method, or None for a grid axis."""
        if self.random is not None:
            return "random"
        if self.latin_hypercube is not None:
            return "latin_hypercube"
        return None

    def grid_values(self) -> list[StudyValue]:
        """A grid axis's values in order (empty for a sampled dimension)."""
        if self.values is not None:
            return list(self.values)
        if self.list_ is not None:
            return list(self.list_)
        if self.range is not None:
            return list(self.range.numbers())
        return []


class SamplingSpec(StrictModel):
    """How many rows the sampled targets draw, and from which seed."""

    samples: int = Field(ge=1, le=1_000_000, description="Rows drawn (each with every grid point).")
    seed: int = Field(default=0, ge=0, description="Seed of the generator: same seed, same cases.")


class ObjectiveSpec(StrictModel):
    """Rank cases by one metric: ``{minimize: NAME}`` or ``{maximize: NAME}``."""

    minimize: str | None = Field(default=None, description="Metric to minimize.")
    maximize: str | None = Field(default=None, description="Metric to maximize.")

    @model_validator(mode="after")
    def _exactly_one(self) -> ObjectiveSpec:
        if (self.minimize is None) == (self.maximize is None):
            msg = "give exactly one of `minimize` and `maximize`"
            raise ValueError(msg)
        return self

    @property
    def metric(self) -> str:
        """The metric ranked."""
        return self.minimize if self.minimize is not None else str(self.maximize)


class StudySpec(StrictModel):
    """A whole study file."""

    fmionnx: int = Field(description="Format version of this file; this release reads 1.")
    system: str = Field(min_length=1, description="The system file varied, relative to this file.")
    description: str = ""
    parameters: dict[str, AxisSpec] = Field(
        min_length=1,
        description="Targets (`component.parameter`, a system input, `run.stop`, "
        "`run.output_interval`, a signal's `component.amplitude`, a scene's "
        "`component.body.NAME.pos`) and how each varies: a list of values (a grid axis) or one of "
        "`values`, `list`, `range`, `random`, `latin_hypercube`.",
    )
    sampling: SamplingSpec | None = Field(
        default=None, description="Required when a target is `random` or `latin_hypercube`."
    )
    metrics: dict[str, str] = Field(
        default_factory=dict,
        description="Name -> a measure in the checks language, e.g. `final(plant.y)`.",
    )
    objective: ObjectiveSpec | None = Field(default=None, description="Rank the cases.")
    isolate: list[str] = Field(
        default_factory=lambda: ["fmus"],
        description="Components run in a process of their own, as `fmionnx run --isolate` "
        "(`fmus`, `all`, `none` or names); a crash of one is a failed case.",
    )
    timeout: float | None = Field(
        default=600.0,
        gt=0,
        allow_inf_nan=False,
        description="Seconds of wall time one case may take (null: no limit).",
    )
    step_timeout: float | None = Field(
        default=None,
        gt=0,
        allow_inf_nan=False,
        description="Seconds one step of a component (its loading included) may take, as "
        "`fmionnx run --step-timeout`; an isolated model over it is killed (a `fault`). "
        "Default: `timeout`.",
    )

    @field_validator("fmionnx")
    @classmethod
    def _known_format(cls, value: int) -> int:
        return known_format(value)

    @field_validator("parameters")
    @classmethod
    def _finite(cls, value: dict[str, AxisSpec]) -> dict[str, AxisSpec]:
        for target, axis in value.items():
            for item in axis.grid_values():
                if isinstance(item, float) and not math.isfinite(item):
                    msg = f"`{target}`: values must be finite numbers"
                    raise ValueError(msg)
        return value


@dataclass(frozen=True)
class LoadedStudy:
    """A study file's model (None when unusable) and where everything is."""

    spec: StudySpec | None
    sources: SourceMap
    path: Path


def load_study(path: Path, bag: DiagnosticBag) -> LoadedStudy:
    """Load and validate a study file; every problem goes into ``bag`` at its place."""
    sources = SourceMap(path)
    # An editor's unsaved text stands in for the file (the language server; a bug hunt: a new
    # study not yet saved was said not to exist, its real problems unseen).
    if edited_text(path) is None and not path.is_file():
        what = "does not exist" if not path.exists() else "is not a file"
        bag.emit(codes.STUDY_FILE, f"study file `{path}` {what}", Span(path))
        return LoadedStudy(None, sources, path)
    text = read_text(path, bag)
    if text is None:
        return LoadedStudy(None, sources, path)
    data: Any = parse_yaml(text, path, sources, bag)
    if data is None:
        return LoadedStudy(None, sources, path)
    if not isinstance(data, dict) or ("system" not in data and "components" in data):
        bag.emit(
            codes.STUDY_FILE,
            "a study file is a mapping with keys `fmionnx`, `system`, `parameters` ...",
            Span(path, 1, 1),
            hint="this looks like a system file: a study names one with `system: FILE`"
            if isinstance(data, dict)
            else "start the file with `fmionnx: 1`",
        )
        return LoadedStudy(None, sources, path)
    try:
        spec = StudySpec.model_validate(data)
    except ValidationError as exc:
        report_validation_error(exc, data, sources, bag, root=StudySpec)
        return LoadedStudy(None, sources, path)
    return LoadedStudy(spec, sources, path)


def json_schema() -> dict[str, Any]:
    """The JSON Schema of the study file (written to ``schemas/study.schema.json``)."""
    schema = StudySpec.model_json_schema(by_alias=True)
    axis = schema["properties"]["parameters"]["additionalProperties"]
    value = schema["$defs"]["AxisSpec"]["properties"]["values"]["anyOf"][0]
    schema["properties"]["parameters"]["additionalProperties"] = {"anyOf": [value, axis]}
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["$id"] = "https://fmionnx.dev/schemas/study.schema.json"
    schema["title"] = "fmionnx study file"
    return schema
