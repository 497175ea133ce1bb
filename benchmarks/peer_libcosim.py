"""One FMU end to end with libcosim: the script a libcosimpy user writes, run as its own process.

``python benchmarks/peer_libcosim.py FMU CSV STEPS STEP``: load the FMU into libcosim's
fixed-step master, set the input ``u`` to 1, step ``STEPS`` times, record the output ``x`` at
every step with libcosim's time-series observer and write ``time,x`` to ``CSV``. The whole
process is what :mod:`benchmarks.startup` times beside ``fmpy simulate`` and ``fmionnx run``:
interpreter start, libcosimpy's import, loading the FMU, the loop and the CSV.

Not part of the project's code: a peer's side of a benchmark, kept as short as a user's script.
"""

from __future__ import annotations

import sys
from pathlib import Path

#: The Integrator fixture's value references (tests/fixtures/fmus/Integrator).
INPUT_U = 0
OUTPUT_X = 2


def main(argv: list[str]) -> int:
    fmu, csv_path, steps, step = Path(argv[0]), Path(argv[1]), int(argv[2]), float(argv[3])
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    execution = CosimExecution.from_step_size(step_size=round(step * 1e9))
    slave = CosimLocalSlave(fmu_path=str(fmu), instance_name="integrator")
    index = execution.add_local_slave(local_slave=slave)
    execution.real_initial_value(index, INPUT_U, 1.0)
    execution.real_time_simulation_enabled(False)
    observer = CosimObserver.create_time_series(buffer_size=steps + 1)
    execution.add_observer(observer=observer)
    observer.start_time_series(index, OUTPUT_X, CosimVariableType.REAL)
    if not execution.step(steps):
        print("libcosim: a step failed", file=sys.stderr)
        return 1
    # libcosimpy trims a sample list at each step number 0, so step 0 is read on its own.
    first = observer.time_series_real_samples(index, OUTPUT_X, 0, 2)
    rest = observer.time_series_real_samples(index, OUTPUT_X, 1, steps)
    times = [*first[0][:1], *rest[0]]
    values = [*first[2][:1], *rest[2]]
    if len(values) != steps + 1:
        print(f"libcosim: {len(values)} samples, expected {steps + 1}", file=sys.stderr)
        return 1
    with csv_path.open("w", encoding="utf-8") as stream:
        stream.write("time,x\n")
        stream.writelines(f"{t / 1e9!r},{x!r}\n" for t, x in zip(times, values, strict=True))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
