"""fmionnx: declarative pipelines of FMUs, ONNX models and MuJoCo, checked like a compiler."""

__version__ = "0.1.0"

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from fmionnx.api import load as load
    from fmionnx.api import sweep as sweep


def __getattr__(name: str) -> Any:
    """``fmionnx.load`` and ``fmionnx.sweep`` without importing the runtime (numpy, fmpy ...) on ``import fmionnx``."""
    if name == "load":
        from fmionnx.api import load

        return load
    if name == "sweep":
        from fmionnx.api import sweep

        return sweep
    msg = f"module 'fmionnx' has no attribute {name!r}"
    raise AttributeError(msg)
