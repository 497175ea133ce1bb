"""The single-driver check (E034) names the earliest connection each duplicate overlaps.

The check keeps, per input, the first connection of any kind, the first to the whole port
and the first to each element (it compared each connection with every earlier one, which
made hundreds of thousands of connections take hours); these cases pin that the note still
points at the earliest overlapping connection in the file.
"""

from __future__ import annotations

from pathlib import Path

from fmionnx.api import compile_system

SYSTEM = """\
fmionnx: 1
name: drivers
run: {{stop: 0.1, step: 0.01}}
components:
  s: {{kind: signal, outputs: {{a: {{constant: 1}}, b: {{constant: 2}}}}}}
  h: {{kind: fmu, path: {gain}}}
  g: {{kind: fmu, path: {gain}}}
connections:
  - s.a -> g.v[1]
  - h.w -> g.v
  - s.a -> g.v[2]
  - s.b -> g.v[1]
  - s.a -> g.u
  - s.b -> g.u
  - s.a -> g.u
"""


def test_each_duplicate_names_the_earliest_connection_it_overlaps(
    tmp_path: Path, fixture_fmu
) -> None:
    path = tmp_path / "drivers.yaml"
    path.write_text(SYSTEM.format(gain=fixture_fmu("Gain")), "utf-8")
    found = [
        (d.span.line if d.span else 0, d.message, d.notes[0].message)
        for d in compile_system(path).diagnostics
        if d.code == "E034"
    ]
    assert found == [
        (10, "`g.v` is already driven by `s.a`", "first driven by `s.a -> g.v[1]`"),
        (11, "`g.v[2]` is already driven by `h.w`", "first driven by `h.w -> g.v`"),
        (12, "`g.v[1]` is already driven by `s.a`", "first driven by `s.a -> g.v[1]`"),
        (14, "`g.u` is already driven by `s.a`", "first driven by `s.a -> g.u`"),
        (15, "`g.u` is already driven by `s.a`", "first driven by `s.a -> g.u`"),
    ]
