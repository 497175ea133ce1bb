"""An FMI 2 variable named like an array element that was not grouped into an array can be
connected by its name.

FMI 2 exporters write arrays as scalars ``v[1]``..``v[n]``, which the FMU reader groups into
one port ``v``; it leaves them apart when they do not make a whole array (``v[0]``, a gap, a
scalar ``v`` beside them). Such ports were listed, settable under ``parameters:`` and said
unconnected by W030, but a connection to ``g.v[0]`` read ``[0]`` as an element of a port
``v`` that does not exist (E021), or of the scalar ``v`` (E022): a bug hunt. The literal name
is tried first.
"""

from __future__ import annotations

import re
import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest

import fmionnx


def _zero_based(tmp_path: Path, fixture_fmu: Callable[[str], Path], *, scalar_v: bool) -> Path:
    """Gain unpacked, its ``v[1..3]`` renamed ``v[0..2]`` (and ``u`` renamed ``v``)."""
    folder = tmp_path / "zero"
    with zipfile.ZipFile(fixture_fmu("Gain")) as archive:
        archive.extractall(folder)
    description = folder / "modelDescription.xml"
    text = description.read_text(encoding="utf-8")
    text = re.sub(r'name="v\[(\d)\]"', lambda m: f'name="v[{int(m[1]) - 1}]"', text)
    if scalar_v:
        text = text.replace('name="u"', 'name="v"')
    description.write_text(text, encoding="utf-8")
    return folder


@pytest.mark.parametrize("scalar_v", [False, True], ids=["no-v", "beside-a-scalar-v"])
def test_a_connection_reaches_a_port_named_like_an_element(
    tmp_path: Path, fixture_fmu: Callable[[str], Path], scalar_v: bool
) -> None:
    fmu = _zero_based(tmp_path, fixture_fmu, scalar_v=scalar_v)
    plain = "v" if scalar_v else "u"
    system = tmp_path / "system.yaml"
    system.write_text(
        f"""fmionnx: 1
name: zero
run: {{stop: 0.1, step: 0.01}}
components:
  src: {{kind: signal, outputs: {{a: {{constant: 3}}}}}}
  g: {{kind: fmu, path: {fmu}, parameters: {{{plain}: 1, "v[1]": 2}}}}
connections:
  - src.a -> g.v[0]
  - src.a -> g.v[2]
""",
        encoding="utf-8",
    )
    loaded = fmionnx.load(system)
    (g,) = [c for c in loaded.compiled.components if c.name == "g"]
    assert [p.name for p in g.interface.ports if p.name.startswith("v")] == [
        *([plain] if scalar_v else []),
        "v[0]",
        "v[1]",
        "v[2]",
    ]
    result = loaded.run()
    assert [result[f"g.w[{i}]"][-1] for i in range(3)] == [6.0, 4.0, 6.0]  # k * (3, 2, 3)
