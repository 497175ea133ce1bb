"""Saving and restoring a co-simulation FMU's state, for iterated algebraic loops.

An iterated loop steps its members from the same communication point until the values they
exchange converge (``docs/execution.md``): before the first try each member's state is saved,
before every further try it is restored. For a co-simulation FMU that is FMI's
``getFMUstate``/``setFMUstate`` (``canGetAndSetFMUstate``, checked at compile time: E051);
one FMU state is kept per instance and overwritten by each save, as FMI allows, and freed at
terminate. The output buffers are copied along, so a restored FMU also shows the outputs of
the saved point. Model exchange has no such mixin: fmionnx's integrator state is not saved.
"""

from __future__ import annotations

import contextlib
import ctypes
from typing import ClassVar

from fmionnx.core.runner import OutputCopies
from fmionnx.kinds.fmu.runner import FmuRunner


class FmuRollback(FmuRunner):
    """:class:`fmionnx.core.runner.StateSaving` for co-simulation FMUs of either version."""

    #: The version's (get, set, free) FMU state functions.
    state_functions: ClassVar[tuple[str, str, str]]

    _saved: ctypes.c_void_p | None = None
    _saved_outputs: OutputCopies | None = None

    def save_state(self, t: float) -> None:
        """``get FMU state`` into the one kept state (allocated by the FMU at first use)."""
        if self._saved is None:
            self._saved = ctypes.c_void_p()
            views = [view for group in self._outputs for view in group.views.values()]
            self._saved_outputs = OutputCopies(views)
        name = self.state_functions[0]
        status = getattr(self._fmu.dll, name)(self._instance, ctypes.byref(self._saved))
        self._check(name, int(status), t)
        assert self._saved_outputs is not None
        self._saved_outputs.save()

    def restore_state(self, t: float) -> None:
        """``set FMU state`` back to the kept state, and the outputs with it."""
        if self._saved is None or self._saved_outputs is None:
            msg = f"{self.component.name}: restore_state before save_state"
            raise RuntimeError(msg)
        name = self.state_functions[1]
        status = getattr(self._fmu.dll, name)(self._instance, self._saved)
        self._check(name, int(status), t)
        self._saved_outputs.restore()

    def terminate(self) -> None:
        """Free the kept state before the instance goes."""
        saved, self._saved = self._saved, None
        fmu = self._fmu
        if saved is not None and saved.value and not self._terminated and fmu is not None:
            with contextlib.suppress(Exception):  # freeing must not mask a fault
                getattr(fmu.dll, self.state_functions[2])(self._instance, ctypes.byref(saved))
        super().terminate()
