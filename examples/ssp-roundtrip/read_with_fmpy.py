"""Read an SSP with FMPy's SSD reader, schema validation on, and print what FMPy sees.

Why: an export is only worth something if other tools read it. FMPy ships the SSP 1.0 schema
and refuses files that do not follow it (it refuses the OMSimulator-style original too: FMPy
knows no ``version="2.0"``), so reading ``fmionnx export``'s archive here shows that the file
fmionnx writes is plain, valid SSP 1.0 with its components, connections and parameter values.
Exits non-zero (FMPy's exception) when FMPy cannot read the file.

Usage: ``python examples/ssp-roundtrip/read_with_fmpy.py FILE.ssp``.
"""

from __future__ import annotations

import sys
import zipfile
from pathlib import Path

from fmpy.ssp.ssd import read_ssd, read_ssv


def describe(path: Path) -> list[str]:
    """Lines describing the archive as FMPy reads it."""
    ssd = read_ssd(str(path), validate=True)
    lines = [f"{path}: SSP {ssd.version}, system `{ssd.system.name}` (read by FMPy, schema-valid)"]
    with zipfile.ZipFile(path) as archive:
        for element in ssd.system.elements:
            lines.append(f"  component {element.name}: {element.source}")
            for binding in element.parameterBindings:
                if binding.source is None:
                    continue
                with archive.open(binding.source) as stream:
                    values = read_ssv(stream, validate=True)
                for parameter in values.parameters:
                    lines.append(f"    {parameter.name} = {parameter.value}")
    for connection in ssd.system.connections:
        lines.append(
            f"  {connection.startElement}.{connection.startConnector} -> "
            f"{connection.endElement}.{connection.endConnector}"
        )
    return lines


def main(argv: list[str]) -> int:
    """Command line: one SSP file."""
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    print("\n".join(describe(Path(argv[0]))))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
