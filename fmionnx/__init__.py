"""fmionnx: declarative pipelines of FMUs, ONNX models and MuJoCo, checked like a compiler."""

__version__ = "0.1.0"

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from fmionnx.api import load as load
    from fmionnx.api import run as run
    from fmionnx.api import sweep as sweep

#: What ``fmionnx.<name>`` gives, imported on first use: ``import fmionnx`` loads no runtime
#: (numpy, fmpy ...).
_LAZY = ("load", "run", "sweep")


def __getattr__(name: str) -> Any:
    """``fmionnx.load``, ``fmionnx.run`` and ``fmionnx.sweep`` from :mod:`fmionnx.api`."""
    if name in _LAZY:
        from fmionnx import api

        return getattr(api, name)
    msg = f"module 'fmionnx' has no attribute {name!r}"
    raise AttributeError(msg)
