"""``fmionnx run --profile``: the statistics as a table, components sorted by share of the loop.

One row per unit of work (a component, a native group, a loop) with its steps, mean and
largest step, the time of each phase and its share of the loop's wall time; a last row says
where the rest went (views, paced waits, the loop itself). run.json's ``statistics`` holds
the same numbers (docs/running.md, "Statistics").
"""

from __future__ import annotations

from collections.abc import Mapping

from rich.console import Console
from rich.table import Table

from fmionnx.runtime.result import Detail

#: The loop's phases, one column each (the step column shows ``infer`` rows too).
LOOP_COLUMNS = ("transfer", "render", "step", "record")


def _ms(value: Detail) -> str:
    """Seconds as milliseconds, three significant digits, never in exponent notation."""
    if not isinstance(value, int | float):
        return ""
    ms = value * 1e3
    return f"{ms:,.0f}" if ms >= 100 else f"{ms:.3g}"


def _setup(phases: Mapping[str, Detail]) -> Detail:
    """Instantiate and initialize together: the table's ``setup`` column."""
    values = [phases.get("instantiate"), phases.get("initialize")]
    return sum(v for v in values if isinstance(v, int | float))


def print_statistics(console: Console, statistics: Mapping[str, Detail]) -> None:
    """The ``--profile`` table on ``console`` (times in milliseconds)."""
    from rich import box

    wall = statistics.get("loop_wall_time")
    title = f"where the loop's {wall:.3f} s went (ms)" if isinstance(wall, float) else "statistics"
    table = Table(
        title=title,
        title_justify="left",
        box=box.SIMPLE_HEAD,
        pad_edge=False,
        padding=(0, 1),
        show_edge=False,
        collapse_padding=True,
    )
    for column in ("component", "share", "steps", "mean", "max", *LOOP_COLUMNS, "setup"):
        if column == "component":  # a long name folds; numbers and headers stay whole
            table.add_column(column, overflow="fold", ratio=1)
        else:
            table.add_column(column, justify="right", no_wrap=True, min_width=len(column))
    components = statistics.get("components")
    inferring = False
    for name, entry in components.items() if isinstance(components, dict) else ():
        if not isinstance(entry, dict):
            continue
        phases = entry.get("phases")
        phases = phases if isinstance(phases, dict) else {}
        step = phases.get("step", phases.get("infer"))
        label = name if "infer" not in phases else f"{name}*"
        inferring = inferring or "infer" in phases
        share = entry.get("share")
        table.add_row(
            label, f"{share:.1%}" if isinstance(share, float) else "",
            str(entry.get("steps", "")), _ms(entry.get("step_mean")), _ms(entry.get("step_max")),
            *(_ms(step if p == "step" else phases.get(p)) for p in LOOP_COLUMNS),
            _ms(_setup(phases)),
        )  # fmt: skip
    notes = []
    other = statistics.get("other")
    if isinstance(other, dict):
        rest = ", ".join(f"{k.replace('_', ' ')} {_ms(v)}" for k, v in other.items() if v)
        if rest:
            notes.append(f"outside the components: {rest}")
    if inferring:
        notes.append("* its step is an inference (infer)")
    if statistics.get("concurrent"):
        notes.append("steps ran on worker threads too: shares can add up to more than 100 %")
    if notes:
        table.caption = "; ".join(notes)
        table.caption_justify = "left"
    console.print(table)
