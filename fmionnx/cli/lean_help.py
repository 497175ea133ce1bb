"""Typer's help renderer without the two rich modules it imports and never uses here.

``typer.rich_utils`` renders ``--help`` (panels, colours). At its top it imports
``rich.markdown`` (which brings markdown_it and pygments) and ``rich.traceback`` (which brings
``rich.pretty`` and attrs): about 35 ms of a 0.17 s ``fmionnx --help`` on the project's
2-core machine. fmionnx uses neither: help texts are rich markup, not Markdown
(``rich_markup_mode="rich"``), and typer's pretty tracebacks are off
(``pretty_exceptions_enable=False``: fmionnx reports its own errors). The help's look is
product, so the renderer stays; this module only defers those two imports until a name from
them is actually used.

:func:`prepare` imports ``typer.rich_utils`` while ``rich.markdown`` and ``rich.traceback``
are stand-in modules whose names resolve to deferred classes: calling one (or reading an
attribute of it) imports the real module then. The stand-ins leave ``sys.modules`` as soon as
``typer.rich_utils`` is imported, so any later ``import rich.markdown`` gets the real module.
When anything goes wrong (a typer release that uses those modules differently at import
time) the stand-ins are removed and typer is imported as it is: slower, never broken.
``tests/cli/test_lean_help.py`` pins that the help is byte for byte the one typer renders
without this module.
"""

from __future__ import annotations

import importlib
import sys
import types
from collections.abc import Mapping

#: The modules deferred and the names ``typer.rich_utils`` imports from them.
DEFERRED: dict[str, tuple[str, ...]] = {
    "rich.markdown": ("Markdown",),
    "rich.traceback": ("Traceback",),
}


class _DeferredClass(type):
    """Metaclass of a stand-in: calling it or reading its attributes loads the real class."""

    _module: str
    _name: str

    def real(cls) -> object:
        """The class the stand-in stands for (its module imported on first use)."""
        module = sys.modules.get(cls._module)
        if module is None or isinstance(module, _StandIn):
            sys.modules.pop(cls._module, None)
            module = importlib.import_module(cls._module)
        return getattr(module, cls._name)

    def __call__(cls, *args: object, **kwargs: object) -> object:
        real = cls.real()
        assert callable(real)
        return real(*args, **kwargs)

    def __getattr__(cls, name: str) -> object:
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(cls.real(), name)


class _StandIn(types.ModuleType):
    """A module whose every public name is a deferred class of the real module."""

    def __getattr__(self, name: str) -> object:
        if name.startswith("__"):
            raise AttributeError(name)
        return _DeferredClass(name, (), {"_module": self.__name__, "_name": name})


def prepare() -> None:
    """Import ``typer.rich_utils`` with ``rich.markdown`` and ``rich.traceback`` deferred.

    Does nothing when typer's renderer is already imported; leaves a module already imported
    by someone else as it is.
    """
    if "typer.rich_utils" in sys.modules:
        return
    placed = {name: _StandIn(name) for name in DEFERRED if name not in sys.modules}
    sys.modules.update(placed)
    try:
        importlib.import_module("typer.rich_utils")
    except Exception:  # any surprise: typer imported as it is, below
        sys.modules.pop("typer.rich_utils", None)
        _remove(placed)
        importlib.import_module("typer.rich_utils")
    finally:
        _remove(placed)


def _remove(placed: Mapping[str, types.ModuleType]) -> None:
    for name, stand_in in placed.items():
        if sys.modules.get(name) is stand_in:
            del sys.modules[name]


def wants_help(argv: list[str]) -> bool:
    """True when the command line asks for help (typer renders it: the renderer is needed).

    Also a bare ``fmionnx`` (``no_args_is_help``). A help flag that is in fact an option's
    value only costs the deferral; nothing changes in what is printed.
    """
    return len(argv) <= 1 or any(arg in ("-h", "--help") for arg in argv[1:])
