"""An ONNX component's output at the start time (issue #34).

It is computed from its connected inputs at the start time, as an FMU's outputs are after
initialization; it was the output for all-zero inputs, held for its whole first period
(``nn.y[0,0]`` = f(0, 0) at t = 0 and 1 with ``period: 2``; the sign detector saw a black frame
first).
"""

from __future__ import annotations

from pathlib import Path

import fmionnx
from tests.results.test_element_names import system_file


def test_the_first_output_is_computed_from_the_start_inputs_and_held(tmp_path: Path) -> None:
    result = fmionnx.load(system_file(tmp_path)).run()
    assert list(result.time) == [0, 1, 2, 3, 4]
    # a.v is 3 at t = 0: 2 * 3 + 1 = 7, held through t = 1 (period 2), not f(0) = 1
    assert list(result["nn.y[0,0]"][:2]) == [7.0, 7.0]
    assert list(result["nn.y[0,1]"][:2]) == [21.0, 21.0]
    # its steps read `a` after `a` stepped (it comes first in the order): a.v = 4 at t = 0,
    # 6 at t = 2; each result is published at the end of the step
    assert list(result["nn.y[0,0]"][2:]) == [9.0, 9.0, 13.0]
