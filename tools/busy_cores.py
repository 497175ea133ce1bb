"""Keep every core of this machine busy until stopped (Ctrl-C or SIGTERM).

CI runs the suite on shared 2-core machines, where other jobs take the cores the tests would
like to have. ``python tools/busy_cores.py & make test`` runs the suite on such a machine:
a test that passes only with a core to itself fails here (docs/contributing.md).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import sys


def _spin(parent: int) -> None:
    """Spin until the parent is gone (even killed outright: no spinner outlives it)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    while os.getppid() == parent:
        for _ in range(1_000_000):
            pass


def main() -> int:
    count = int(sys.argv[1]) if len(sys.argv) > 1 else (os.cpu_count() or 1)
    spinners = [
        multiprocessing.Process(target=_spin, args=(os.getpid(),), daemon=True)
        for _ in range(count)
    ]
    for spinner in spinners:
        spinner.start()
    print(f"busy_cores: {count} spinning processes; stop with Ctrl-C or SIGTERM", flush=True)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    with contextlib.suppress(KeyboardInterrupt):
        signal.pause()
    return 0


if __name__ == "__main__":
    sys.exit(main())
