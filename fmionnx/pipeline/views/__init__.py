"""Live views of a run: Rerun (``--view rerun``, ``--rrd``) and Foxglove (``--view foxglove``).

Each view is an observer of the run pipeline (:class:`~fmionnx.pipeline.observers.RunObserver`)
that :attr:`~fmionnx.pipeline.observers.RunObserver.wants_feed`: it is handed camera frames
as they are rendered and recorded rows while the run goes (:mod:`fmionnx.pipeline.feed`),
the compiled system before, the checks after. The viewers' libraries are the optional extra
``fmionnx[view]``, imported here only when a view is asked for; without them a run asking for
one is refused with the command that installs them. docs/viewing.md shows what each view holds.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from fmionnx.core.errors import FmionnxError
from fmionnx.pipeline.observers import RunObserver
from fmionnx.pipeline.viewspec import ViewTarget

#: How to install the extra from a clone (the README's set-up).
INSTALL_HINT = "pip install -e '.[view]' (from the fmionnx clone; or pip install 'fmionnx[view]')"


class ViewUnavailableError(FmionnxError):
    """A view whose library is not installed (a usage error)."""


class ViewerUnreachableError(FmionnxError):
    """A viewer that cannot be reached or started (the run is refused before it starts)."""


#: Seconds a spawned Rerun viewer gets to listen, and a remote one to answer.
VIEWER_WAIT = 10.0


def _require(module: str, distribution: str, what: str) -> None:
    import importlib

    try:
        importlib.import_module(module)
    except ImportError:
        msg = f"{what} needs the `{distribution}` package, which is not installed: {INSTALL_HINT}"
        raise ViewUnavailableError(msg) from None


def require_rerun(option: str) -> None:
    """Raise :class:`ViewUnavailableError` (naming ``option``) when Rerun is not installed."""
    _require("rerun", "rerun-sdk", option)


def make_views(targets: Sequence[ViewTarget], rrd: Path | None) -> list[RunObserver]:
    """The observers showing a run on ``targets`` (and recording it to ``rrd``)."""
    views: list[RunObserver] = []
    rerun = [t for t in targets if t.kind == "rerun"]
    if rerun or rrd is not None:
        _require("rerun", "rerun-sdk", "--rrd" if not rerun else "--view rerun")
        from fmionnx.pipeline.views.rerun_view import RerunView, reach_viewer

        if rerun:
            reach_viewer(rerun[0], VIEWER_WAIT)
        views.append(RerunView(rerun[0] if rerun else None, rrd))
    for target in targets:
        if target.kind == "foxglove":
            _require("foxglove", "foxglove-sdk", "--view foxglove")
            from fmionnx.pipeline.views.foxglove_view import FoxgloveView

            views.append(FoxgloveView(target.port))
    return views
