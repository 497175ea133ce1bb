"""The sweep engine: a Dask cluster runs a study's cases, outcomes come back as they finish.

By default a :class:`distributed.LocalCluster` of worker processes (one per core, one thread
each: cases are CPU-bound and models are not all thread-safe); with ``scheduler`` an existing
cluster (``tcp://host:8786``). The driver sends the compiled system as JSON and the models by
content hash (:mod:`.models`): inside every task when they are small, else once per worker as
tasks of their own. Cases go out one per task, or per batch of short cases
(:func:`.case.run_batch`, sized by :mod:`.batching`: one task per worker thread to start),
then up to two tasks in hand per thread; a worker that returns a task is handed the next
one. Each outcome is handed to ``on_done`` on the driver as soon as its task returns, so the
caller can record it durably before the next one arrives. A worker that dies under a task (a
model crashing a non-isolated component) has that task's cases run again one at a time, alone
on the cluster; a case whose worker dies while it runs alone is ``failed``; the study goes
on."""

from __future__ import annotations

import asyncio
import atexit
import contextlib
import logging
import math
import os
import threading
import time
import uuid
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fmionnx.backends.sweep import workerfork
from fmionnx.backends.sweep.batching import BatchSizer
from fmionnx.backends.sweep.case import CaseOutcome, CaseRunner, Job, run_batch
from fmionnx.backends.sweep.daskconfig import LOCAL_CONFIG, PRE_SPAWN
from fmionnx.backends.sweep.leftovers import sweep_orphan_semaphores
from fmionnx.backends.sweep.models import pack_models
from fmionnx.backends.sweep.pinning import CORES_KEY, cores_for
from fmionnx.backends.sweep.syncreport import install as _install_sync_report
from fmionnx.compile.studyir import Case, StudyPlan
from fmionnx.compile.systemfile import to_json
from fmionnx.core.environ import put_back
from fmionnx.core.errors import FmionnxError
from fmionnx.core.scratch import make_scratch, remove_scratch, sweep_stale

_install_sync_report()  # a Ctrl-C's report of Dask's failed clean-up: see the module

#: Tasks in hand per worker thread once the study's first tasks (one per thread) return: one
#: running, one queued on its worker to start the moment the first returns. The rest wait on
#: the driver, where later tasks are sized from the case times measured by then (and a study
#: of 10^5 cases never is 10^5 tasks on the scheduler).
DEPTH = 2
#: Seconds between two questions to the scheduler about its workers during a study.
REFRESH_SECONDS = 2.0
#: Bytes of system and models up to which they travel inside every task (see ``_shared``).
INLINE_BYTES = 1 << 20
#: Seconds to wait for an existing cluster's scheduler to answer.
CONNECT_TIMEOUT = 20
#: Address schemes of a Dask scheduler that a study can reach.
SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")


class SchedulerError(FmionnxError):
    """An existing cluster's scheduler that cannot be used: a malformed address or no answer."""


class ClusterStartError(FmionnxError):
    """The local cluster could not start, or a study was started inside a starting worker."""


#: How to call ``fmionnx.sweep`` from a script: each local worker imports the script again.
SCRIPT_GUARD = (
    'the call must be under `if __name__ == "__main__":` '
    "(each local worker process imports the calling script again as it starts)"
)


def refuse_in_starting_worker() -> None:
    """Raise :class:`ClusterStartError` in a worker process that is still starting.

    The local cluster's workers are started with ``spawn``: each runs the main script of the
    process that started it before it becomes a worker. A script that calls ``fmionnx.sweep``
    at its top level thus calls it again in every worker, which would prepare -- with
    ``force``, wipe -- the same results folder while the real study writes it. Multiprocessing
    marks such a process while it imports the script (``_inheriting``, which its own check
    for this mistake reads), so the call is refused before anything is touched.
    """
    import multiprocessing

    if getattr(multiprocessing.current_process(), "_inheriting", False):
        msg = f"fmionnx.sweep was called while a worker process was starting: {SCRIPT_GUARD}"
        raise ClusterStartError(msg)


def scheduler_problem(address: str) -> str | None:
    """What is wrong with a scheduler address, or None; checked before anything is written.

    Dask itself reports a wrong scheme or a missing port as a ``ValueError`` from deep inside
    its client, after a study folder would have been made.
    """
    from urllib.parse import urlsplit

    expected = f"expected SCHEME://HOST:PORT with SCHEME one of {', '.join(SCHEDULER_SCHEMES)}"
    parts = urlsplit(address)
    if parts.scheme not in SCHEDULER_SCHEMES or not parts.netloc:
        return f"--scheduler {address!r}: {expected} (e.g. tcp://10.0.0.5:8786)"
    try:
        port = parts.port
    except ValueError:
        port = None
    if not parts.hostname or port is None or not 0 < port < 65536:
        return f"--scheduler {address!r}: no valid port; {expected}"
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        return f"--scheduler {address!r}: {expected}, nothing after the port"
    return None


def default_workers() -> int:
    """One worker per core this process may use."""
    from fmionnx.core.cores import usable_cores

    return usable_cores()


@contextmanager
def open_client(scheduler: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """A Dask client: of the cluster at ``scheduler``, else of a new local cluster of
    ``workers`` processes (default: one per core) that is closed with the block."""
    from distributed import Client

    if scheduler is not None:
        problem = scheduler_problem(scheduler)
        if problem is not None:
            raise SchedulerError(problem)
        try:
            client = Client(scheduler, set_as_default=False, timeout=CONNECT_TIMEOUT)
        except (OSError, ValueError, TimeoutError) as exc:
            msg = f"cannot reach the Dask scheduler at {scheduler}: {exc}"
            raise SchedulerError(msg) from None
        with client:
            yield client
        return
    before = {key: os.environ.get(key) for key in _nanny_variables()}
    sweep_orphan_semaphores()
    # The workers' scratch folders (``dask-scratch-space``, left in TMPDIR after every study
    # otherwise) go into a folder of this study's, removed with the cluster; a study killed
    # outright leaves it to the next fmionnx process's sweep.
    scratch = make_scratch("dask")
    try:
        with _handled_reports_quiet():
            try:
                cluster = _local_cluster(workers or default_workers(), scratch)
            except (RuntimeError, OSError, TimeoutError) as exc:
                msg = (
                    f"the local Dask cluster could not start its workers ({exc}); "
                    f"if a script calls fmionnx.sweep, {SCRIPT_GUARD}"
                )
                raise ClusterStartError(msg) from None
            try:
                with Client(cluster, set_as_default=False) as client:
                    yield client
            finally:
                cluster.close()
                # Models a stop signal killed inside a case (their process ended without its
                # exit handlers) left their unpacked FMUs: their owners are gone now.
                sweep_stale()
    finally:
        # What the nanny set in this process: after ``fmionnx.sweep`` in a notebook, a program
        # the user starts would otherwise run OpenMP and BLAS on one thread.
        put_back(before)
        remove_scratch(scratch)


#: This process's clients of existing clusters, by scheduler address (:func:`shared_client`).
_SHARED: dict[str, Any] = {}
_SHARED_LOCK = threading.Lock()


def shared_client(scheduler: str) -> Any:
    """This process's client of the cluster at ``scheduler``, connected on first use and kept
    for the next studies on it (closed when the process exits): a notebook or a script
    running many studies on one cluster connects once.

    A client whose connection was lost is closed and replaced. Raises
    :class:`SchedulerError` for a malformed address or a scheduler that does not answer.
    """
    from distributed import Client

    problem = scheduler_problem(scheduler)
    if problem is not None:
        raise SchedulerError(problem)
    with _SHARED_LOCK:
        client = _SHARED.get(scheduler)
        if client is not None and client.status == "running":
            return client
        if client is not None:
            with contextlib.suppress(Exception):
                client.close()
        try:
            client = Client(scheduler, set_as_default=False, timeout=CONNECT_TIMEOUT)
        except (OSError, ValueError, TimeoutError) as exc:
            msg = f"cannot reach the Dask scheduler at {scheduler}: {exc}"
            raise SchedulerError(msg) from None
        _SHARED[scheduler] = client
        return client


#: Seconds a kept client may take to close when the process exits.
SHARED_CLOSE_TIMEOUT = 2


@atexit.register
def close_shared_clients() -> None:
    """Close the kept clients (:func:`shared_client`), quickly and quietly: the cluster may be
    gone by now (the client then tries to reconnect and says so), and it is not ours to end.

    Runs when the process exits; call it before ending a cluster this process studied on,
    or the kept client goes on trying to reconnect to it in the background."""
    with _SHARED_LOCK:
        clients = list(_SHARED.values())
        _SHARED.clear()
    quiet = logging.getLogger("distributed.client")
    level = quiet.level
    quiet.setLevel(logging.CRITICAL)
    try:
        for client in clients:
            with contextlib.suppress(Exception):
                client.close(timeout=SHARED_CLOSE_TIMEOUT)
    finally:
        quiet.setLevel(level)


def _local_cluster(workers: int, scratch: Path) -> Any:
    """A new local cluster of ``workers`` one-thread processes, with :data:`LOCAL_CONFIG`."""
    import dask
    from distributed import LocalCluster

    # The scheduler and the nannies make their scratch space in Dask's temporary directory,
    # not in the workers' local directory: both are the study's own folder.
    settings: dict[str, Any] = {**LOCAL_CONFIG, "temporary-directory": str(scratch)}
    settings[CORES_KEY] = cores_for(workers)  # each worker's share (:mod:`.pinning`), or None
    workerfork.fork_local_workers()  # from the command's fork server, if it runs
    with dask.config.set(settings):
        return LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            # The scheduler serves its health routes even without a dashboard, on 8787 unless
            # told otherwise, and warns when another cluster on this host holds that port (two
            # studies at once). A free port of the loopback says nothing. (Filtering the warning
            # instead is not thread-safe: the cluster starts while the system compiles.)
            scheduler_kwargs={"dashboard": False, "dashboard_address": "127.0.0.1:0"},
            silence_logs=logging.ERROR,
            memory_limit=0,
            local_directory=str(scratch),
        )


def _nanny_variables() -> tuple[str, ...]:
    """What Dask's nanny writes into the environment of the process that starts it, and never
    takes back: its ``pre-spawn-environ`` (Dask's defaults or the user's Dask configuration),
    set before it spawns a worker, and a fixed hash seed."""
    import dask
    import distributed  # noqa: F401 - loads Dask's distributed configuration

    return (*dask.config.get(PRE_SPAWN), workerfork.HASH_SEED)


@dataclass(frozen=True)
class StudyRun:
    """How a study's cases were sent: the cases every task ran (in order of submission; a task
    cut short by its budget counts the cases it ran, a task whose worker died those it was
    given), and the cases run again alone after a worker died under their task."""

    sizes: tuple[int, ...]
    fallbacks: int

    @property
    def tasks(self) -> int:
        """Tasks submitted."""
        return len(self.sizes)


def run_study(
    client: Any,
    plan: StudyPlan,
    cases: Iterable[Case],
    job: Job,
    on_done: Callable[[CaseOutcome], None],
    runner: CaseRunner,
    models: Mapping[str, bytes] | None = None,
    batch: int | None = None,
) -> StudyRun:
    """Run ``cases`` of ``plan`` on ``client``'s cluster; ``on_done`` gets every outcome.

    ``runner`` runs one case's system on a worker (the run pipeline's, sent by reference).

    ``models`` are the packed models (:func:`.models.pack_models`), packed here by default.
    ``batch`` fixes the cases per task (1: one each); None sizes tasks from the measured case
    times (:mod:`.batching`). A batch's outcomes reach ``on_done`` when the batch returns,
    one by one in case order.
    """
    from distributed import as_completed

    # One prefix per run of a study: two drivers running the same study on one shared cluster
    # (say, one with --keep-results) must not be handed each other's outcomes by key.
    prefix = f"fmionnx-{plan.fingerprint[:16]}-{uuid.uuid4().hex[:12]}"
    text, shared_models, shared_job = _shared(client, plan, job, models, prefix)
    cluster = _Cluster(client)
    sizer = BatchSizer(cluster.threads, batch)
    waiting = deque(cases)
    #: Cases of a task whose worker died: each runs again alone on the cluster, before the rest.
    alone: deque[Case] = deque()
    in_flight: dict[str, _InFlight] = {}  # by task key
    sizes: list[int] = []
    fallbacks = 0
    # Without Dask fetching the results itself: see _outcomes.
    running = as_completed(loop=client.loop)

    def submit(
        groups: list[tuple[Case, ...]], worker: str | None = None, *, lone: bool = False
    ) -> None:
        """Send ``groups`` as tasks in one message to the scheduler (Dask batches a client's
        messages every 10 ms: the study's first tasks, sent apart, would reach the second
        worker that much later); to ``worker`` if given, or anywhere if it is gone."""
        keys = [
            f"{prefix}-{group[0].id}"
            + (f"+{len(group) - 1}" if len(group) > 1 else "")
            + ("-alone" if lone else "")
            for group in groups
        ]
        count = len(groups)
        # Submission order is the order to run in (the guided sizes shrink: large tasks first,
        # the small ones last): tasks that become ready together would otherwise start in any
        # order.
        futures = client.map(
            run_batch,
            [text] * count,
            [shared_models] * count,
            [list(group) for group in groups],
            [shared_job] * count,
            [runner] * count,
            [sizer.budget if len(group) > 1 else None for group in groups],
            key=keys,
            pure=False,
            priority=-len(sizes),
            **({"workers": [worker], "allow_other_workers": True} if worker else {}),
        )
        for future, group in zip(futures, groups, strict=True):
            in_flight[future.key] = _InFlight(future, group, lone, len(sizes), worker)
            sizes.append(len(group))
            running.add(future)

    def unpin_from_the_dead() -> None:
        """Hand out again the tasks sent to a worker that is gone.

        A task sent to the worker that had just returned one, as that worker died (the
        whole cluster at once: its fork server killed), waited for it for ever: Dask keeps a
        task whose only named worker is gone unrunnable (``no-worker``) even though the
        restriction is loose, and new workers never take it. Such a task is cancelled and its
        cases go back to the front of the queue (it ran nothing)."""
        cluster.refresh()
        for key, task in list(in_flight.items()):
            if task.worker is not None and not cluster.alive(task.worker):
                del in_flight[key]
                sizes[task.place] = 0
                (alone if task.lone else waiting).extendleft(reversed(task.cases))
                task.future.cancel()

    def refill(finished_on: str | None = None) -> None:
        """Hand out cases until every worker thread has ``DEPTH`` tasks in hand; a single task
        goes to ``finished_on``, the worker that just returned one (see :class:`_Cluster`)."""
        if alone:  # one at a time, nothing beside it: see below
            if not in_flight:
                submit([(alone.popleft(),)], lone=True)
            return
        cluster.refresh()
        sizer.threads = cluster.threads
        free = DEPTH * cluster.threads - len(in_flight)
        if not waiting or free <= 0:
            return
        if free == 1 and finished_on is not None:
            group = tuple(waiting.popleft() for _ in range(sizer.size(len(waiting))))
            submit([group], cluster.address_of(finished_on))
            return
        # Several at once (the study's first tasks, or workers that joined): the scheduler, not
        # the driver, picks their workers, so they are cut equal -- the workers' shares are then
        # equal whichever tasks each gets (guided sizes, largest first, gave one worker of two
        # the first and third tasks: 78 cases against 59, and it ended 20 ms after the other).
        # The first message is one task per thread (:mod:`.batching`).
        size = sizer.size(len(waiting)) if sizes else sizer.first_size(len(waiting))
        groups = [
            tuple(waiting.popleft() for _ in range(min(size, len(waiting))))
            for _ in range(min(free, math.ceil(len(waiting) / size)))
        ]
        submit(groups)

    refill()
    for future in running:
        task = in_flight.pop(future.key, None)
        if task is None:  # cancelled by unpin_from_the_dead: its cases were handed out again
            future.release()
            continue
        group, lone, place = task.cases, task.lone, task.place
        outcomes = _outcomes(future)
        if outcomes is None:
            cluster.changed()
            unpin_from_the_dead()
        if outcomes is None and not lone:
            # Its worker died (a crash in a component that is not isolated). Dask counts a
            # death against every task assigned to that worker, running or queued, so the
            # culprit is not known: each of the task's cases runs again alone, with nothing
            # else on the cluster, and a death then is that case's own.
            alone.extend(group)
            fallbacks += len(group)
            outcomes = []
        elif outcomes is None:
            outcomes = [CaseOutcome(group[0].id, "failed", _died(future))]
        else:
            # A task that used up its budget ran only its first cases: the rest are handed
            # out again, first.
            waiting.extendleft(reversed(group[len(outcomes) :]))
            sizes[place] = len(outcomes)
        future.release()
        for outcome in outcomes:
            sizer.observe(outcome.wall_time)
            on_done(outcome)
        refill(outcomes[0].worker if outcomes else None)
    return StudyRun(tuple(sizes), fallbacks)


@dataclass(frozen=True)
class _InFlight:
    """A task of a study's, sent and not yet handed back."""

    future: Any
    cases: tuple[Case, ...]
    #: Whether it runs alone (a death is then the case's own).
    lone: bool
    #: Its place in the study's task sizes.
    place: int
    #: The worker it was sent to (the one that had just returned a task), if any.
    worker: str | None


class _ClosedComm(logging.Filter):
    """Drops tornado's report of a callback that met a closed connection to the cluster."""

    def filter(self, record: logging.LogRecord) -> bool:
        from distributed.comm.core import CommClosedError

        error = record.exc_info[1] if record.exc_info else None
        return not isinstance(error, CommClosedError)


class _DeathsSaid(logging.Filter):
    """Drops the scheduler's reports of a task lost with its worker: the study says it."""

    #: The scheduler's messages (``distributed.scheduler``), as it formats them.
    SAID = (
        "Task %s marked as failed because %d workers died",
        "Task %s marked as failed because it timed out waiting",
        "Couldn't gather keys: ",
    )

    def filter(self, record: logging.LogRecord) -> bool:
        return not str(record.msg).startswith(self.SAID)


@contextmanager
def _handled_reports_quiet() -> Iterator[None]:
    """While a local cluster of this study's lives and closes, drop what Dask logs on the
    user's terminal about what the study handles itself:

    * tornado's reports of a ``CommClosedError``: a study stopped early (Ctrl-C) has results
      in flight, whose tracking by Dask meets the cluster as it closes and logged a
      traceback (one run in ten on a fast machine), about results the study no longer wants;
    * the scheduler's ``ERROR`` lines about tasks lost with a worker that died (a model
      crashing it, the workers' fork server killed): the study runs their cases again, or
      records them as failed with the reason, and says so in its table.

    Nothing else of tornado's or the scheduler's is touched, and the filters go with the
    cluster."""
    filters = (("tornado.application", _ClosedComm()), ("distributed.scheduler", _DeathsSaid()))
    for name, dropping in filters:
        logging.getLogger(name).addFilter(dropping)
    try:
        yield
    finally:
        for name, dropping in filters:
            logging.getLogger(name).removeFilter(dropping)


def _shared(
    client: Any, plan: StudyPlan, job: Job, models: Mapping[str, bytes] | None, prefix: str
) -> tuple[Any, Any, Any]:
    """What every task of a study takes besides its cases: the system's JSON, the packed models
    and the job, as values or as futures.

    Up to :data:`INLINE_BYTES` they travel inside each task: a task then starts the moment it
    reaches its worker. Larger, each is a task of its own that every case task depends on, so
    that it crosses the network once per worker, not once per task; the first cases then wait
    for it (a scheduler's round trip more). Either way nothing is scattered data: the
    scheduler keeps the recipe, so a worker that dies (a crashing model) loses nothing the
    other cases need.
    """
    text = to_json(plan.system)
    packed = dict(models if models is not None else pack_models(plan.system))
    if len(text.encode()) + sum(map(len, packed.values())) <= INLINE_BYTES:
        return text, packed, job
    shared_text = client.submit(_value, text, key=f"{prefix}-system", pure=False)
    shared_models = {
        digest: client.submit(_value, blob, key=f"fmionnx-model-{digest}", pure=False)
        for digest, blob in packed.items()
    }
    shared_job = client.submit(_value, job, key=f"{prefix}-job-{int(job.keep_results)}", pure=False)
    return shared_text, shared_models, shared_job


class _Cluster:
    """The threads of the cluster's workers, as the scheduler last said.

    Tasks in hand are capped at ``DEPTH`` per thread, and when a worker returns a task its
    next one goes to that worker (a loose restriction: anywhere if it is gone). Left to
    itself, the scheduler assigns a ready task at once to the worker it judges least busy and
    moves it only by work stealing, once a second: on a short study the last tasks queued up
    behind one busy worker while another sat idle (docs/sweep.md, "Performance", has the
    measurements). Workers that join during a study are found by asking again every
    :data:`REFRESH_SECONDS` and get tasks from then on.

    A case names its worker by the address the worker calls itself (``get_worker().address``),
    which is not always the scheduler's name for it: a worker given a host name as its contact
    address (``--contact-address tcp://node-3:8788``, usual behind NAT or in containers) is
    known to the scheduler by the resolved IP address, and a restriction to the host name
    would name no worker. Such a worker's own address is its Dask *name* unless it was given
    one, so names are mapped to the scheduler's addresses too (:meth:`address_of`).
    """

    def __init__(self, client: Any) -> None:
        self._client = client
        self._asked = -math.inf
        self._threads = 1
        #: The scheduler's address of each worker, by that address and by the worker's name.
        self._addresses: dict[str, str] = {}
        self.refresh()

    @property
    def threads(self) -> int:
        """Threads of all workers, at least 1."""
        return self._threads

    def refresh(self) -> None:
        """Ask the scheduler again if the last answer is older than ``REFRESH_SECONDS``."""
        now = time.monotonic()
        if now - self._asked >= REFRESH_SECONDS:
            self._asked = now
            workers: dict[str, Any] = self._client.scheduler_info(n_workers=-1)["workers"]
            self._threads = max(1, sum(int(w.get("nthreads", 0)) for w in workers.values()))
            names = {str(w.get("name")): address for address, w in workers.items()}
            self._addresses = names | {address: address for address in workers}

    def address_of(self, worker: str) -> str | None:
        """The scheduler's address of the worker that calls itself ``worker`` (None: unknown,
        the scheduler then picks where the next task runs)."""
        return self._addresses.get(worker)

    def changed(self) -> None:
        """A worker may have died: ask again at the next refill."""
        self._asked = -math.inf

    def alive(self, address: str) -> bool:
        """Whether the scheduler, when last asked, had a worker at ``address``."""
        return address in self._addresses.values()


def _value(value: object) -> object:
    """A task that is its argument: how a shared value becomes recomputable."""
    return value


def _outcomes(future: Any) -> list[CaseOutcome] | None:
    """A returned task's outcomes; None when it did not finish or its result is gone.

    Fetched here, not by ``as_completed(with_results=True)``: a task that finished on a
    worker that died before its result was fetched (workers dying together: the local
    cluster's fork server killed, an out-of-memory killer) made Dask's fetch raise
    ``KilledWorker`` inside ``as_completed``, which then never handed the task back, and the
    study waited for ever (4 times in 16 such deaths). Gone with its worker, the result is
    as good as a death under the task: its cases run again."""
    if future.status != "finished":
        return None
    try:
        outcomes: list[CaseOutcome] = future.result()
    except (Exception, asyncio.CancelledError):
        return None
    return outcomes


def _died(future: Any) -> str:
    """Why a case's task failed (the case itself never raises: its worker died).

    The status is read once and the task's exception asked for only when it ended in one:
    a result lost with its worker leaves the future ``lost`` while Dask runs it again, and
    asking it for its exception then waited for that run and gave ``None``."""
    status = future.status
    if status in ("finished", "lost"):  # its result went with its worker (see _outcomes)
        return "the worker running the case died before its result was taken"
    if status != "error":
        return f"the worker running the case is gone (its task is {status})"
    try:
        exception = future.exception()
    except Exception as exc:
        return f"the case did not finish: {type(exc).__name__}: {exc}"
    name = type(exception).__name__
    if name == "KilledWorker":
        return "the worker running the case died (a model crashed its process)"
    return f"{name}: {exception}"
