"""FMI 3 clocks: shown by ``fmionnx inspect``, refused (E025) where a system would need them.

A ``<Clock>`` is not data: it ticks, and its ticks drive the variables that name it in their
``clocks`` attribute. fmionnx does not run FMUs in Event Mode yet, so it can neither activate
an input clock nor see an output clock tick. The FMU kind therefore

* records each clock as a fact ``unsupported.<name>`` (so ``inspect`` lists it with its interval
  settings, and an endpoint naming it is E025, not "unknown port"), read from the XML itself
  because fmpy does not read the interval attributes;
* records the port variables updated only at clock ticks (fact ``clockedVariables``);
* refuses a component whose FMU has an input clock (the importer must activate it) or clocked
  ports (their values would never change) with E025: such a model cannot run correctly.

An FMU whose only clocks are output clocks that drive no port runs; its clocks are ignored.
"""

from __future__ import annotations

from typing import Any

from fmionnx.core import codes
from fmionnx.kinds.base import KindProblem

#: Fact key prefix of a name that looks like a port but is not one (kind-independent).
UNSUPPORTED_PREFIX = "unsupported."

#: The fact listing port variables updated only at clock ticks.
CLOCKED_FACT = "clockedVariables"

#: Clock attributes shown, in this order, with the label inspect prints.
_SETTINGS = (
    ("intervalVariability", "interval"),
    ("intervalDecimal", "interval"),
    ("intervalCounter", "interval counter"),
    ("shiftDecimal", "shift"),
    ("shiftCounter", "shift counter"),
    ("resolution", "resolution"),
    ("supportsFraction", "supports fraction"),
    ("priority", "priority"),
    ("canBeDeactivated", "can be deactivated"),
)

#: Longest fact value kept per clock (a hostile description may write megabytes).
_MAX_TEXT = 300


def _describe(clock: Any) -> str:
    causality = clock.get("causality") or "local"
    parts = [f"FMI 3 clock ({causality})"]
    for attribute, label in _SETTINGS:
        value = clock.get(attribute)
        if value is None:
            continue
        unit = " s" if attribute in ("intervalDecimal", "shiftDecimal") else ""
        if attribute == "intervalDecimal" and parts[-1].startswith("interval "):
            parts[-1] += f" {value}{unit}"  # "interval constant 0.1 s"
        else:
            parts.append(f"{label} {value}{unit}")
    return ", ".join(parts)[:_MAX_TEXT]


def clock_facts(root: Any, ports: frozenset[str]) -> list[tuple[str, str]]:
    """The facts of the clocks of the parsed description ``root`` (empty for FMI 2)."""
    variables = root.find("ModelVariables")
    if variables is None:
        return []
    facts: list[tuple[str, str]] = []
    clock_refs: set[str] = set()
    clocked: list[str] = []
    for variable in variables:
        if not isinstance(variable.tag, str):
            continue  # a comment
        name = variable.get("name") or ""
        if variable.tag == "Clock":
            facts.append((UNSUPPORTED_PREFIX + name, _describe(variable)))
            clock_refs.add(variable.get("valueReference") or "")
        elif variable.get("clocks") and name in ports:
            clocked.append(name)
    if clocked:
        facts.append((CLOCKED_FACT, ",".join(clocked)[:_MAX_TEXT]))
    return facts


def clock_problems(facts: tuple[tuple[str, str], ...]) -> list[KindProblem]:
    """E025 for each input clock and for clocked ports, from the interface's facts."""
    problems = []
    hint = "FMI 3 clocks are not supported yet; use an FMU variant without clocks"
    for key, value in facts:
        if key.startswith(UNSUPPORTED_PREFIX) and value.startswith("FMI 3 clock (input)"):
            name = key[len(UNSUPPORTED_PREFIX) :]
            problems.append(
                KindProblem(
                    codes.UNSUPPORTED_VARIABLE,
                    f"the FMU has the input clock `{name}`, which the importer must activate: "
                    "clocks are not supported yet",
                    "path",
                    hint,
                )
            )
        elif key == CLOCKED_FACT:
            names = ", ".join(f"`{n}`" for n in value.split(","))
            problems.append(
                KindProblem(
                    codes.UNSUPPORTED_VARIABLE,
                    f"the ports {names} change only when a clock ticks: clocks are not "
                    "supported yet",
                    "path",
                    hint,
                )
            )
    return problems
