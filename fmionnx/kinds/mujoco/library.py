"""The ``mujoco`` module as fmionnx uses it: no log file in the working folder.

By default MuJoCo appends every warning (an unstable simulation, a model it had to adjust) to
``MUJOCO_LOG.TXT`` in the process's working folder: a run would leave a file beside whatever
the user ran it from. MuJoCo 3.3 and later have a log configuration whose file output is
turned off here, once per process, before any model is compiled; warnings still go to the
console, and fmionnx reads the ones that matter from ``MjData.warning`` (:mod:`.runner`).
An older MuJoCo gets a warning handler instead, which prints the warning to the standard
error and writes no file.
"""

from __future__ import annotations

import sys
from typing import Any

_configured: list[bool] = []


def _print_warning(message: str) -> None:
    print(f"MuJoCo warning: {message}", file=sys.stderr)


def mujoco_module() -> Any:
    """``mujoco``, imported, with its log file turned off (once per process)."""
    import mujoco

    if not _configured:
        config_type = getattr(mujoco, "MjLogConfig", None)
        if config_type is not None:
            config = config_type.get()
            config.logto_file = False
            config.set()
        else:  # pragma: no cover - MuJoCo before 3.3
            mujoco.set_mju_user_warning(_print_warning)
        _configured.append(True)
    return mujoco
