"""Loading an FMU's shared library through fmpy: one load at a time in a process, the process's
working folder left as it was, and a library that does not load reported as the component's
fault.

fmpy changes the process's working folder to the library's folder while it loads the library
(some Windows DLLs find their dependencies that way) and back afterwards -- but not when the
load fails: the process is then left in the FMU's scratch folder, which the run removes right
after, so every later relative path of the process fails and ``os.getcwd()`` raises (an
embedding program's, a sweep worker's next cases). Two threads loading at once (cases on a
multi-threaded Dask worker, a program running systems in threads) would also leave the
process in one another's library folder. So loads take turns, and the working folder is put
back whatever happened.

A library that does not load is common and is the FMU's problem, not fmionnx's: built for
another platform, needing a library this machine lacks, damaged, or missing FMI functions.
fmpy raises a bare ``Exception`` for it; here it becomes a fault of the component whose message
names the library by its place in the FMU, not by the scratch folder it was unpacked into.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from fmionnx.core.errors import FmionnxError
from fmionnx.core.processlocal import ProcessLocal
from fmionnx.core.runner import fault

T = TypeVar("T")

#: Held while fmpy loads a library: the working folder is the whole process's. One per
#: process: a child forked while another thread of its parent held it (the guardian's, in a
#: program that loads FMUs in threads) would otherwise wait for it forever.
_LOADING: ProcessLocal[threading.Lock] = ProcessLocal()


def load_library(component: str, root: Path, load: Callable[[], T]) -> T:
    """``load()`` -- fmpy making its object for the FMU unpacked at ``root`` -- with the
    process's working folder restored after it; a failure is a fault of ``component``."""
    with _LOADING.get_or_make(threading.Lock):
        try:
            before = Path.cwd()
        except FileNotFoundError:  # fmpy reads it first, and would fail with a bare errno
            msg = "its library cannot be loaded: this process's working folder was removed"
            raise fault(component, msg, time=0.0) from None
        try:
            return load()
        except FmionnxError:  # fmionnx's own checks on the way (a library outside the FMU)
            raise
        except Exception as exc:
            raise fault(component, library_problem(exc, root), time=0.0) from None
        finally:
            os.chdir(before)


def library_problem(exc: Exception, root: Path) -> str:
    """What went wrong loading a library, in the FMU's own terms (paths inside the FMU)."""
    cause = exc.__cause__ or exc.__context__
    detail = _inside(str(cause if isinstance(cause, OSError) else exc), root)
    if isinstance(cause, OSError):
        return (
            f"its shared library does not load: {detail} (a library built for another "
            "platform, damaged, or needing a library this machine does not have)"
        )
    if isinstance(exc, AttributeError):
        return f"its shared library lacks an FMI function: {detail}"
    return f"its shared library could not be loaded: {detail}"


def _inside(text: str, root: Path) -> str:
    """``text`` with the scratch folder's path dropped: paths as the FMU names its files."""
    return text.replace(f"{root}{os.sep}", "").replace(str(root), ".")
