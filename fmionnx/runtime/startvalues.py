"""Initial values of components that have no state of their own (ONNX models).

A model without state has no initialization: its outputs are a function of its inputs. After
every runner is set up, each such runner (:class:`~fmionnx.core.runner.StartEvaluating`) gets,
in the execution order, the values its connections carry at the start time — a producer
earlier in the order already evaluated, a camera rendered at the initial state — and computes
its outputs from them. Those are its outputs at the start time: the first row of the results
and, held, until its first step publishes (docs/execution.md, "Initial values").
Initialization is not iterated: a producer later in the order gives its set-up value.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from fmionnx.compile.ir import CompiledSystem
from fmionnx.core.runner import Runner, StartEvaluating
from fmionnx.core.types import PortRef
from fmionnx.runtime.transfer import make_transfer


def evaluate_at_start(
    system: CompiledSystem,
    runners: Mapping[str, Runner],
    producer_hook: Callable[[PortRef], Callable[[], None] | None],
) -> None:
    """Hand every start-evaluating runner its connected inputs at the start time, in order.

    ``producer_hook`` makes a lazy output (a camera) of a producer for its consumer, as the
    run's own transfers do, so that a frame is rendered once for the start time.
    """
    start = system.run.start
    for name in system.order:
        runner = runners[name]
        if not isinstance(runner, StartEvaluating):
            continue
        for connection in system.inputs_of(name):
            source = connection.src
            make_transfer(connection, runners[source.component], runner, producer_hook(source))(
                start
            )
        runner.evaluate_at_start(start)
