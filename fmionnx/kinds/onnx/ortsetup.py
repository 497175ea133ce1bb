"""onnxruntime as fmionnx uses it: no telemetry, and an allocator with a ceiling.

**Telemetry.** onnxruntime 1.2x and later start a telemetry system when the module is
imported: on Linux it writes a device id and a queue of usage events under
``~/.cache/Microsoft/DeveloperTools/.onnxruntime`` and a session file ``$TMPDIR/.ses``. A
simulation tool must not leave such traces behind its user's back, so before onnxruntime is
first imported ``ORT_DISABLE_TELEMETRY=1`` is set (unless the environment already says
otherwise), which keeps it from starting at all, and ``disable_telemetry_events()`` is called
after, for an onnxruntime that was imported by someone else first.

**Memory.** A model can compute a tensor whose shape depends on its input *values* (an
``Expand`` to a shape read from an input): no check before the run can bound it
(:mod:`.sizes` bounds every shape that follows from the model's constants). The sessions of
this process therefore allocate from one shared arena registered here with a ceiling,
:data:`~fmionnx.core.resources.ONNX_BYTES`; a run that would take more fails with
onnxruntime's "Available memory of ... is smaller than requested bytes" and becomes a fault
naming the component, instead of taking the machine's memory.
"""

from __future__ import annotations

import logging
import os
from typing import Any

from fmionnx.core.resources import ONNX_BYTES

logger = logging.getLogger(__name__)

#: onnxruntime's session setting that makes a session allocate from the registered arena.
USE_SHARED_ARENA = "session.use_env_allocators"

#: Whether this process registered the capped arena (None: not tried yet).
_registered: list[bool] = []


def onnxruntime_module() -> Any:
    """``onnxruntime``, imported without telemetry, with the capped arena registered (once
    per process). Raises ModelError (E008) for a malformed ``FMIONNX_MAX_ONNX_BYTES``."""
    ceiling = ONNX_BYTES.value()
    os.environ.setdefault("ORT_DISABLE_TELEMETRY", "1")
    import onnxruntime as ort

    if not _registered:
        ort.disable_telemetry_events()
        _registered.append(_register_arena(ort, ceiling))
    return ort


def _register_arena(ort: Any, ceiling: int) -> bool:
    """Register the shared CPU arena of at most ``ceiling`` bytes; False when it cannot be
    (another arena registered first, an onnxruntime without the call): sessions then keep
    their own arenas, without the ceiling."""
    try:
        memory = ort.OrtMemoryInfo(
            "Cpu", ort.OrtAllocatorType.ORT_ARENA_ALLOCATOR, 0, ort.OrtMemType.DEFAULT
        )
        ort.create_and_register_allocator(memory, ort.OrtArenaCfg(ceiling, -1, -1, -1))
    except Exception:  # an arena registered before, or an onnxruntime without the call
        logger.debug("onnxruntime: no capped arena registered", exc_info=True)
        return False
    return True


def session_options(ort: Any) -> Any:
    """New ``SessionOptions`` whose session allocates from the capped arena."""
    options = ort.SessionOptions()
    if _registered and _registered[0]:
        options.add_session_config_entry(USE_SHARED_ARENA, "1")
    return options
