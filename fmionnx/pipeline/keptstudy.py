"""A study's compile kept in the compile cache: ``fmionnx sweep`` and ``fmionnx validate`` of
an unchanged study read its plan back instead of compiling it.

Compiling a study reads the study file with its pydantic types and resolves every target,
value and metric against the system: about 0.2 s of CPU in the driver's start, when the
driver competes with the local cluster's workers starting. The plan is kept in the same
cache as a system's compile (:mod:`fmionnx.pipeline.compilecache`), keyed by the study file's
bytes; the system file the study names is one more dependency, hashed at each lookup with the
system's models. The plan's system goes through the compiled-system checks; the rest of the
plan (cases, metrics with their parsed expressions, objective, isolation, timeouts) is
decoded by the compiled-system file's codec, each field against its declared type.
"""

from __future__ import annotations

import dataclasses
import functools
import typing
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fmionnx.compile.studyir import StudyPlan
from fmionnx.core.diagnostics import Diagnostic, DiagnosticBag
from fmionnx.pipeline import compilecache
from fmionnx.pipeline.compilecache import Slot

if TYPE_CHECKING:
    from fmionnx.spec.study import LoadedStudy

#: The system files a kept plan may name: every file their compile reads is hashed with them.
KEPT_SYSTEM_SUFFIXES = frozenset({".yaml", ".yml", ".ssp"})


@dataclass(frozen=True)
class KeptPlan:
    """A study's plan read back, and the diagnostics (warnings) its compile gave."""

    plan: StudyPlan
    diagnostics: tuple[Diagnostic, ...]


def plan_slot(study: Path) -> Slot | None:
    """Where the compile of the study file ``study`` is kept (None: not kept)."""
    return compilecache.study_slot(study)


def kept_plan(place: Slot | None) -> KeptPlan | None:
    """The plan kept in ``place``, or None (a miss, or an entry that does not decode)."""
    from fmionnx.compile.systemfile import CompiledFileError, decode_value

    cached = compilecache.lookup(place)
    if cached is None or not isinstance(cached.payload, dict):
        return None
    fields = _plan_fields()
    if set(cached.payload) != set(fields):
        return None
    try:
        values = {
            name: decode_value(hint, cached.payload[name], f"study.{name}")
            for name, hint in fields.items()
        }
    except CompiledFileError:
        return None
    return KeptPlan(StudyPlan(system=cached.system, **values), cached.diagnostics)


def keep_plan(
    place: Slot | None, plan: StudyPlan, diagnostics: Sequence[Diagnostic], system_file: Path
) -> None:
    """Keep ``plan`` (compiled without errors, from ``system_file``) in ``place``; not for a
    loose SSD file, which may read ``.ssv`` and ``.ssm`` files beside it that no entry lists
    (an SSP archive's are inside the archive, which is hashed)."""
    if place is None or system_file.suffix.lower() not in KEPT_SYSTEM_SUFFIXES:
        return
    from fmionnx.compile.systemfile import encode_value

    payload = {name: encode_value(getattr(plan, name)) for name in _plan_fields()}
    compilecache.store(place, plan.system, diagnostics, payload=payload, files=(system_file,))


def compiled_plan(
    loaded: LoadedStudy, bag: DiagnosticBag, place: Slot | None
) -> tuple[StudyPlan | None, tuple[Diagnostic, ...]]:
    """A read study file compiled (its system through the compile cache), and every
    diagnostic; a plan without errors is kept in ``place``. None: the study has errors."""
    from fmionnx.compile.study import compile_study
    from fmionnx.pipeline.system import study_system

    plan = compile_study(loaded, bag, system_compiler=study_system)
    diagnostics = tuple(bag.sorted())
    if plan is None or loaded.spec is None or bag.has_errors:
        return None, diagnostics
    keep_plan(place, plan, diagnostics, loaded.path.parent / loaded.spec.system)
    return plan, diagnostics


@functools.cache
def _plan_fields() -> dict[str, Any]:
    """The plan's fields but its system, with their types (the codec decodes by them)."""
    hints = typing.get_type_hints(StudyPlan)
    return {f.name: hints[f.name] for f in dataclasses.fields(StudyPlan) if f.name != "system"}
