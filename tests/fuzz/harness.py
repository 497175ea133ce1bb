"""What every fuzz property checks, and how long it may take.

The promise under test (``docs/security.md``): every input ends in diagnostics with a code, a
location and a message, or in a successful compile; never a Python traceback, never a hang.
``fmionnx validate`` calls :func:`fmionnx.api.compile_system` and renders the diagnostics with
no ``try`` around either, so *any* exception out of those two is a traceback a user would see;
the checks here call exactly those functions in-process.
"""

from __future__ import annotations

import io
import os
import signal
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from types import FrameType
from typing import TypeVar

from hypothesis import HealthCheck, Phase, event, settings
from hypothesis.errors import InvalidArgument

from fmionnx import api
from fmionnx.core.diagnostics import CODES, Severity
from fmionnx.reporters import REPORTER_BY_NAME, FileResult

#: ``FMIONNX_FUZZ=long`` (``make fuzz``) multiplies every property's examples by this.
LONG_FACTOR = 100
#: Seconds one example may take before it counts as a hang (a real compile takes < 1 s).
EXAMPLE_TIMEOUT = 30
#: How much of a failing input the failure message shows.
SHOWN = 3000

T = TypeVar("T")


def record(value: str) -> None:
    """Count ``value`` in hypothesis's statistics (``--hypothesis-show-statistics`` shows which
    codes the fuzzers reached); outside a property (seed checks), nothing."""
    with suppress(InvalidArgument):
        event(value)


def long_run() -> bool:
    """True under ``make fuzz`` (``FMIONNX_FUZZ=long``)."""
    return os.environ.get("FMIONNX_FUZZ", "").lower() == "long"


def register_profiles() -> None:
    """The two profiles (see ``conftest.py``, which registers them for the suite)."""
    common = settings(
        deadline=None,
        database=None,
        suppress_health_check=[
            HealthCheck.too_slow,
            HealthCheck.data_too_large,
            HealthCheck.large_base_example,
        ],
    )
    # No shrinking in the short budget: a failing property (a known bug marked xfail) would
    # spend half a minute shrinking in every `make test`; `make fuzz` shrinks.
    quick = (Phase.explicit, Phase.reuse, Phase.generate)
    settings.register_profile(
        "fuzz-short", common, derandomize=True, print_blob=False, phases=quick
    )
    settings.register_profile("fuzz-long", common, derandomize=False, print_blob=True)


def fuzz_settings(examples: int) -> settings:
    """The active profile with this property's example count: ``examples`` for ``make
    test``, ``LONG_FACTOR`` times as many for ``make fuzz``."""
    name = "fuzz-long" if long_run() else "fuzz-short"
    try:
        profile = settings.get_profile(name)
    except InvalidArgument:  # imported outside pytest (a script replaying an input)
        register_profiles()
        profile = settings.get_profile(name)
    return settings(profile, max_examples=examples * (LONG_FACTOR if long_run() else 1))


class ExampleTimeout(BaseException):
    """Raised by the alarm in :func:`time_limit`; a BaseException so that no ``except
    Exception`` in the code under test swallows it."""


@contextmanager
def time_limit(seconds: float = EXAMPLE_TIMEOUT) -> Iterator[None]:
    """Raise :class:`ExampleTimeout` in the main thread if the block runs longer than
    ``seconds`` (wall time). A hang is a failure like a traceback: it must not stall the
    suite for hypothesis to report."""

    def expire(_signum: int, _frame: FrameType | None) -> None:
        raise ExampleTimeout

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def write_input(path: Path, data: bytes | str) -> Path:
    """Write a mutated input (text as UTF-8, bytes as they are) to ``path``; returns it."""
    if isinstance(data, str):
        path.write_text(data, encoding="utf-8")
    else:
        path.write_bytes(data)
    return path


def shown(data: bytes | str) -> str:
    """The failing input as the failure message shows it (repr, cut at ``SHOWN`` chars).
    Archives pass the description of their mutation instead of their bytes."""
    text = repr(data)
    return text if len(text) <= SHOWN else f"{text[:SHOWN]}... ({len(data)} in all)"


def guarded(what: str, data: bytes | str, call: Callable[[], T]) -> T:
    """``call()`` under the hang guard, with warnings recorded as they would be printed (the
    suite turns warnings into errors; a user would only see a line on stderr). Any exception
    fails the example with the input in the message."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with time_limit():
                result = call()
        except ExampleTimeout:
            msg = f"{what} hung for more than {EXAMPLE_TIMEOUT} s on input:\n{shown(data)}"
            raise AssertionError(msg) from None
        except Exception as error:
            msg = f"{what} raised {type(error).__name__}: {error}\non input:\n{shown(data)}"
            raise AssertionError(msg) from error
    for warning in caught:
        record(f"warning: {warning.category.__name__}")
    return result


def check_diagnostics(result: api.CompileResult, data: bytes | str) -> None:
    """A compile either succeeded, or failed with well-formed error diagnostics; either way
    every diagnostic has a known code, a location and a message."""
    if result.system is None:
        assert any(d.severity is Severity.ERROR for d in result.diagnostics), (
            f"no system and no error diagnostic for input:\n{shown(data)}"
        )
    for diagnostic in result.diagnostics:
        assert diagnostic.code in CODES, (diagnostic, shown(data))
        assert diagnostic.span is not None, (diagnostic, shown(data))
        assert diagnostic.message.strip(), (diagnostic, shown(data))
        if diagnostic.severity is Severity.ERROR:
            record(f"error {diagnostic.code}")
    if result.ok:
        record("compiled")


def validate_in_process(path: Path, data: bytes | str) -> api.CompileResult:
    """What ``fmionnx validate PATH`` does, in-process: compile, then render every report
    format (reporters quote the source line under a column; odd columns must not crash)."""
    result = guarded("compile_system", data, lambda: api.compile_system(path))
    check_diagnostics(result, data)
    for name, reporter in REPORTER_BY_NAME.items():
        stream = io.StringIO()
        guarded(
            f"the {name} reporter",
            data,
            lambda r=reporter, s=stream: r.render(  # type: ignore[misc]
                [FileResult(path, result.diagnostics)], s, color=False
            ),
        )
        assert stream.getvalue(), f"the {name} reporter wrote nothing"
    return result
