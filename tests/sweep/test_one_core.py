"""A sweep's case uses one core (``fmionnx.backends.sweep.case.one_core_per_case``).

Parallelism in a sweep is across cases, so a case does not fan out: onnxruntime's pool, the
software renderer's threads and an isolated child's spin each took a core from another case.
The settings are process-wide, so they are checked in a fresh interpreter.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

PROBE = """
import json, os
from fmionnx.backends.sweep.case import one_core_per_case
from fmionnx.kinds.onnx import runner
from fmionnx.runtime.isolated import proxy
before = [proxy.children_spin(), runner._default_threads[0]]
one_core_per_case()
print(json.dumps({"before": before, "after": [proxy.children_spin(), runner._default_threads[0]],
                  "render": os.environ.get("LP_NUM_THREADS")}))
"""


def _probe(**env: str) -> dict[str, object]:
    clean = {k: v for k, v in os.environ.items() if k != "LP_NUM_THREADS"}
    done = subprocess.run(
        [sys.executable, "-c", PROBE], env={**clean, **env}, capture_output=True, text=True,
        timeout=120, check=True,
    )  # fmt: skip
    return json.loads(done.stdout)  # type: ignore[no-any-return]


def test_a_sweep_case_runs_onnx_on_one_thread_renders_on_one_and_its_children_do_not_spin() -> None:
    found = _probe()
    assert found["before"] == [True, None]  # fmionnx run: onnxruntime's default, children spin
    assert found["after"] == [False, 1]
    assert found["render"] == "1"


def test_a_render_thread_count_the_user_set_is_kept() -> None:
    assert _probe(LP_NUM_THREADS="4")["render"] == "4"
