"""``fmionnx sweep`` writes its table and draws its plots without pandas (issue #32): pandas
costs about 0.4 CPU-s to import, which on a busy machine the cases do not get. A Python caller
of :func:`fmionnx.sweep` still gets a DataFrame."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.sweep.conftest import WriteStudy

STUDY = """\
fmionnx: 1
system: system.yaml
isolate: [none]
parameters:
  gain.k: [1, 3, 2]
  integ.x0: [0, 1]
metrics:
  y_end: final(gain.y)
objective: {maximize: y_end}
"""

SCRIPT = """\
import sys

from fmionnx.cli import main

if __name__ == "__main__":
    sys.argv = ["fmionnx", "sweep", "study.yaml", "--workers", "1", "--out", "out"]
    try:
        main()
    except SystemExit as exc:
        code = exc.code
    print(f"exit={code} pandas={'pandas' in sys.modules}", file=sys.stderr)
"""


@pytest.mark.parametrize("worker", ["1", "0"], ids=["plot-worker", "plots-in-the-driver"])
def test_the_command_writes_its_table_and_summary_without_pandas(
    write_study: WriteStudy, worker: str
) -> None:
    study = write_study(STUDY)
    folder = study.parent
    (folder / "drive.py").write_text(SCRIPT, encoding="utf-8")
    env = {**os.environ, "FMIONNX_PLOT_WORKER": worker}  # 0: drawn as on one core
    done = subprocess.run(
        [sys.executable, "drive.py"],
        cwd=folder, env=env, capture_output=True, text=True, timeout=240, check=False,
    )  # fmt: skip
    assert done.stderr.strip().splitlines()[-1] == "exit=0 pandas=False", done.stderr
    assert "best cases (maximize y_end)" in done.stdout
    out = folder / "out"
    assert {p.name for p in out.iterdir()} >= {"cases.csv", "cases.parquet", "passfail.png"}
    import pandas as pd

    table = pd.read_parquet(out / "cases.parquet")
    assert list(table["case"]) == [f"case-{i:04d}" for i in range(6)]
    assert (table["status"] == "ok").all()
    assert Path(out / "cases.csv").read_text("utf-8").splitlines()[0] == (
        "case,gain.k,integ.x0,y_end,check: small,status,message,wall_time,worker"
    )


KEPT = """\
import sys

from fmionnx.cli import main

if __name__ == "__main__":
    sys.argv = ["fmionnx", "sweep", "study.yaml", "--scheduler", sys.argv[1], "--out", sys.argv[2]]
    try:
        main()
    except SystemExit as exc:
        code = exc.code
    print(f"exit={code} pydantic={'pydantic' in sys.modules}", file=sys.stderr)
"""


def test_a_study_compiled_before_is_read_back_without_its_types_and_runs_the_same(
    write_study: WriteStudy, cluster: str, tmp_path: Path
) -> None:
    """The compile cache keeps the study's plan: the driver of an unchanged study's sweep
    imports no pydantic (its study types), and the table is the same but for the timings."""
    folder = write_study(STUDY).parent
    (folder / "drive.py").write_text(KEPT, encoding="utf-8")
    env = {**os.environ, "FMIONNX_CACHE": str(tmp_path / "kept")}
    tables = []
    for out, types in (("first", "True"), ("again", "False")):
        done = subprocess.run(
            [sys.executable, "drive.py", cluster, out],
            cwd=folder, env=env, capture_output=True, text=True, timeout=240, check=False,
        )  # fmt: skip
        assert done.stderr.strip().splitlines()[-1] == f"exit=0 pydantic={types}", done.stderr
        rows = (folder / out / "cases.csv").read_text("utf-8").splitlines()
        tables.append([row.rsplit(",", 2)[0] for row in rows])  # less wall_time and worker
    assert tables[1] == tables[0]
    assert len(tables[0]) == 7
