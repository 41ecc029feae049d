"""Independent tasks on a ``dask.distributed`` cluster, or one after the other in this process.

The long jobs of impactid are made of independent parts: the recordings and fits of a campaign
(:mod:`impactid.campaign`), the operating points of a regime map
(:func:`impactid.rigs.pivoted.regimes.regime_map`), the cam speeds of a bifurcation diagram
(:func:`impactid.rigs.flat.simulate.bifurcation`), the cases of the envelope validation
(``benchmarks/validate_envelope.py``). Each accepts a ``client`` (a :class:`distributed.Client`):
with one, the parts are mapped over the cluster's workers; without (the default), they run here,
in order, as before.

* :func:`connect` opens the client of a command's ``--scheduler ADDRESS`` (an existing cluster,
  used as it is) or ``--workers N`` (a local cluster of ``N`` single-threaded worker processes on
  this machine, closed on exit);
* :func:`map_tasks` and :func:`iter_tasks` run a function over items, on the client or serially;
* the long runs show their progress with :func:`impactid.commandline.progress_bar` (tqdm on stderr).

``dask[distributed]`` is an optional dependency (the ``campaign`` extra: ``pip install
'impactid[campaign]'``); :func:`require` raises an :class:`~impactid.errors.ImpactidError`
naming what to install when it is missing, and nothing here imports dask unless a cluster is asked
for, so the serial path works without it.

A Ctrl-C reaches every process of the terminal's foreground process group, the local cluster's
workers included: they start with SIGINT blocked and ignore it (:func:`_cluster_start`), so that only
this process acts on it, closing the cluster (a Ctrl-C while the cluster starts takes effect once
it has started); the workers' log lines while they close are not shown. The command then ends in
its one line ``impactid: error: interrupted ...``.

Worker processes of the local cluster run with ``NUMBA_NUM_THREADS=1``: each worker is one core,
and numba's parallel kernels inside it would otherwise start one thread per core in every
worker. An existing cluster is left as it was started (give its workers that variable yourself:
``NUMBA_NUM_THREADS=1 dask worker ADDRESS --nthreads 1``; one thread per worker process also keeps
the warnings each estimate collects apart, which Python's warning filters cannot do between
threads of one process). Functions sent to workers are pickled
by reference to their module, so the workers must import the same impactid (and, for the envelope
validation, the repository's ``tests`` package); recordings are read by the workers from their
paths, so every worker must see them under the same paths (a shared file system).
"""

from __future__ import annotations

import contextlib
import importlib.util
import logging
import os
import signal
import threading
import weakref
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import Any

from impactid.errors import ImpactidError

__all__ = ["ProgressFn", "add_scheduler_arguments", "cluster_from_args", "connect", "default_workers", "iter_tasks",
           "map_tasks", "missing", "require", "scheduler_arguments", "scheduler_client"]

#: Callback ``progress(done, total)`` of the long runs.
ProgressFn = Callable[[int, int], None]

#: How long :func:`connect` tries to reach an existing scheduler.
CONNECT_TIMEOUT = "20s"

#: Environment of the local cluster's worker processes (one core each: numba single-threaded).
WORKER_ENV = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
              "OPENBLAS_NUM_THREADS": "1"}


def missing(*modules: str) -> list[str]:
    """The modules of ``modules`` that cannot be imported here (without importing them)."""
    return [m for m in modules if importlib.util.find_spec(m) is None]


def require(*modules: str, what: str = "this") -> None:
    """Raise an :class:`ImpactidError` naming the extra to install if a module is missing.

    Parameters
    ----------
    modules : top-level module names, e.g. ``"distributed"``, ``"pyarrow"``.
    what : what needs them, for the message (e.g. ``"impactid campaign"``).
    """
    absent = missing(*modules)
    if absent:
        raise ImpactidError(f"{what} needs {', '.join(absent)}, not installed here: install the 'campaign' extra "
                            "(pip install 'impactid[campaign]')")


def default_workers() -> int:
    """Worker processes of a local cluster by default: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def connect(address: str | None = None, workers: int | None = None, *, what: str = "this command",
            memory_limit: str | float | None = "auto") -> Iterator[Any]:
    """A :class:`distributed.Client` for the duration of a ``with`` block.

    Parameters
    ----------
    address : the scheduler of an existing cluster (``tcp://host:8786`` or a scheduler file's
        path ending in ``.json``); the cluster is used as it is and only this connection is closed
        on exit.
    workers : without ``address``: the number of single-threaded worker processes of a local
        cluster started here and closed on exit (default :func:`default_workers`).
    what : the command, for the message when dask is missing.
    memory_limit : memory limit of each local worker (dask's ``"auto"``: the machine's memory
        shared among the workers), bytes or a string such as ``"4GB"``.

    Raises
    ------
    ImpactidError
        dask is not installed, or the scheduler cannot be reached.
    """
    require("distributed", what=what)
    import dask
    from distributed import Client, LocalCluster

    if address is not None:
        try:
            if address.endswith(".json"):
                client = Client(scheduler_file=address, timeout=CONNECT_TIMEOUT)
            else:
                client = Client(address, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ImpactidError(f"argument --scheduler: cannot connect to {address} ({exc})") from None
        try:
            yield client
        finally:
            client.close()
        return
    n = default_workers() if workers is None else int(workers)
    if n < 1:
        raise ImpactidError(f"a local cluster needs at least one worker, got {n}")
    # the worker processes start with one numba thread each: set before they are spawned (they may
    # import numba while starting, e.g. when the main module imports impactid). A nanny sets these in
    # the environment of its own process, which for a local cluster is this one: restored below
    # (numba refuses to compile once its threads run if NUMBA_NUM_THREADS has changed since)
    environ = {**dask.config.get("distributed.nanny.pre-spawn-environ", {}), **WORKER_ENV}
    saved = {key: os.environ.get(key) for key in environ}
    # each worker runs this module's dask_setup as it starts (after any preloads of the user's config)
    configured = dask.config.get("distributed.worker.preload", None) or []
    preload = [*([configured] if isinstance(configured, str) else configured), __name__]
    started: list[Any] = []  # the cluster, once it exists: closed below whatever happens after
    try:
        with _cluster_start() as deferred:
            try:
                with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
                    # no dashboard; the scheduler's small HTTP server (health checks) on a free port, not 8787
                    started.append(LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                                dashboard_address=None, scheduler_kwargs={"dashboard_address": ":0"},
                                                memory_limit=memory_limit, preload=preload))
            finally:
                _restore_environ(saved)
        deferred.deliver()  # a Ctrl-C or SIGTERM while the cluster started: raised now, the cluster closed below
        client = Client(started[0])
        try:
            yield client
        finally:
            with _quiet_shutdown():
                client.close()
    finally:
        try:
            if started:
                with _quiet_shutdown():
                    started[0].close()
        finally:
            _restore_environ(saved)  # a nanny that restarted a dead worker set them again


#: Signals the worker processes of a local cluster never act on: a Ctrl-C at the terminal goes to
#: the whole foreground process group, workers included, and would stop each of them with a
#: ``KeyboardInterrupt`` traceback of its own while this process closes the cluster. (SIGTERM is
#: left to them: dask's nanny stops a worker that fails to start with it.)
WORKER_IGNORED_SIGNALS = (signal.SIGINT,)
#: Signals whose Python handlers this process runs only once a starting local cluster is in hand.
DEFERRED_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class _DeferredSignals:
    """The signals received while a local cluster started (:func:`_cluster_start`), and their handlers."""

    def __init__(self) -> None:
        self.received: list[int] = []
        self.handlers: dict[int, Callable] = {}

    def record(self, signum: int, frame: Any) -> None:
        self.received.append(signum)

    def deliver(self) -> None:
        """Run the handler of each signal received (a Ctrl-C raises :class:`KeyboardInterrupt` here)."""
        for signum in dict.fromkeys(self.received):
            self.handlers[signum](signum, None)


@contextlib.contextmanager
def _cluster_start() -> Iterator[_DeferredSignals]:
    """Start a local cluster inside this block: its worker processes never see Ctrl-C.

    A worker process must not act on the Ctrl-C that the terminal sends to the whole process group:
    this process shuts the workers down (closing the cluster), and a worker whose parent is gone
    leaves by itself (dask watches the parent). Two layers keep SIGINT from the workers:

    * **blocked from the start.** The calling thread blocks :data:`WORKER_IGNORED_SIGNALS` for the
      duration of the block. The cluster's event-loop thread is created here, and from it the
      threads that spawn (and later respawn) the worker processes; a thread inherits the signal mask
      of the thread that creates it, and a process that of the thread that forks it, across
      ``exec``. So a worker starts with SIGINT blocked, before its interpreter has imported anything
      (the start of a worker takes seconds). Python's multiprocessing unblocks SIGINT in the thread
      that first starts its resource tracker: it is started here, before blocking.
    * **ignored once running.** Each worker runs :func:`dask_setup` as it starts (a preload), which
      sets SIGINT to be ignored, whatever unblocks it later.

    In the main thread, a Ctrl-C or SIGTERM during the block is recorded instead of being raised in
    the middle of the cluster's start (which would leave a half-started cluster behind, with no
    handle to close it); the caller calls :meth:`_DeferredSignals.deliver` once it holds the cluster
    and can close it. The start of a cluster takes seconds: the wait of that Ctrl-C.
    """
    from multiprocessing import resource_tracker

    resource_tracker.ensure_running()
    deferred = _DeferredSignals()
    if threading.current_thread() is threading.main_thread():
        for signum in DEFERRED_SIGNALS:
            handler = signal.getsignal(signum)
            if callable(handler):
                deferred.handlers[signum] = handler
                signal.signal(signum, deferred.record)
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, WORKER_IGNORED_SIGNALS)
    try:
        yield deferred
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)  # a pending Ctrl-C arrives now
        for signum, handler in deferred.handlers.items():
            signal.signal(signum, handler)


def dask_setup(worker: Any) -> None:
    """Set up a worker process of a local cluster of :func:`connect` (dask's preload hook).

    The worker ignores SIGINT (:func:`_cluster_start`), and what it logs while it closes is
    not shown: when a campaign is interrupted, its tasks are cancelled and the cluster closed under
    busy workers, which report the cancelled tasks and the scheduler gone before them, none of it
    news to the user. What a running worker logs (memory pressure, a lost connection) still shows.

    Parameters
    ----------
    worker : the :class:`distributed.Worker` being started.
    """
    if threading.current_thread() is threading.main_thread():
        for signum in WORKER_IGNORED_SIGNALS:
            signal.signal(signum, signal.SIG_IGN)
    quiet = _WhileClosing(worker)
    for handler in logging.getLogger("distributed").handlers:  # the one printing to stderr
        handler.addFilter(quiet)


class _WhileClosing(logging.Filter):
    """A logging filter that drops every record while its worker closes (or once it has closed)."""

    CLOSING = frozenset({"closing", "closing_gracefully", "closed"})

    def __init__(self, worker: Any):
        super().__init__()
        self._worker = weakref.ref(worker)

    def filter(self, record: logging.LogRecord) -> bool:
        worker = self._worker()
        status = getattr(getattr(worker, "status", None), "name", None)
        return worker is not None and status not in self.CLOSING


#: Loggers of this process quietened while a local cluster shuts down: a worker busy with a
#: cancelled task is killed after a few seconds, and tasks cancelled on a Ctrl-C are reported as
#: lost or not found; none of it is worth a line on the user's terminal.
SHUTDOWN_LOGGERS = ("distributed.nanny", "distributed.scheduler", "distributed.core", "distributed.client")


@contextlib.contextmanager
def _quiet_shutdown() -> Iterator[None]:
    """Raise :data:`SHUTDOWN_LOGGERS` to ERROR for the block (their errors still show)."""
    loggers = [logging.getLogger(name) for name in SHUTDOWN_LOGGERS]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(max(logger.getEffectiveLevel(), logging.ERROR))
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels):
            logger.setLevel(level)


def _restore_environ(saved: dict[str, str | None]) -> None:
    """Put back the environment variables ``saved`` (None: unset)."""
    for key, value in saved.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value


def scheduler_arguments(*, local_default: bool = False) -> tuple:
    """``--scheduler ADDRESS`` and ``--workers N`` (mutually exclusive), as the
    :class:`~impactid.rigs.base.Argument` declarations of a command.

    Parameters
    ----------
    local_default : without either option, run on a local cluster of one worker per core (the
        campaign); False: run serially in this process (the sweeps; ``--workers N`` asks for a
        local cluster).
    """
    from impactid.commandline import integer_in
    from impactid.rigs.base import Argument

    default = (f"default: {default_workers()}, one per core" if local_default
               else "default: serially in this process")
    return (
        Argument(("--scheduler",), {"metavar": "ADDRESS", "default": None,
                                    "help": "run on an existing dask cluster (tcp://HOST:8786 or a scheduler file "
                                            ".json), used as it is"}, exclusive="scheduler"),
        Argument(("--workers",), {"type": integer_in(0, 4096), "default": None, "metavar": "N",
                                  "help": f"run on a local dask cluster of N single-threaded worker processes; 0: "
                                          f"serially in this process ({default})"}, exclusive="scheduler"),
    )


def add_scheduler_arguments(parser, *, local_default: bool = False) -> None:
    """Add :func:`scheduler_arguments` to an argparse parser (or a sub-command's)."""
    for argument in scheduler_arguments(local_default=local_default):
        argument.add_to(parser)


def cluster_from_args(args, *, local_default: bool = False, what: str = "this command"):
    """The cluster of :func:`add_scheduler_arguments`' options: a callable that returns the context
    manager of :func:`connect`, or None to run serially. Checks that dask is installed."""
    address = getattr(args, "scheduler", None)
    workers = getattr(args, "workers", None)
    if address is None and (workers == 0 or (workers is None and not local_default)):
        return None
    require("distributed", what=what)
    return lambda: connect(address, workers, what=what)


@contextlib.contextmanager
def scheduler_client(args, *, local_default: bool = False, what: str = "this command") -> Iterator[Any]:
    """The client of :func:`add_scheduler_arguments`' options for a ``with`` block (None: serially)."""
    factory = cluster_from_args(args, local_default=local_default, what=what)
    if factory is None:
        yield None
        return
    with factory() as client:
        yield client


def iter_tasks(fn: Callable[[Any], Any], items: Sequence[Any], *, client: Any = None) -> Iterator[tuple[int, Any]]:
    """``(index, fn(items[index]))`` for every item, in the order the results arrive.

    Serially (``client=None``) that is the order of ``items``; on a cluster, the order in which the
    workers finish. An exception of ``fn`` is raised here (the other tasks are cancelled).
    """
    if client is None:
        for k, item in enumerate(items):
            yield k, fn(item)
        return
    from distributed import as_completed

    futures = client.map(fn, list(items), pure=False)
    index = {f.key: k for k, f in enumerate(futures)}
    try:
        for future in as_completed(futures):
            yield index[future.key], future.result()
    finally:
        client.cancel([f for f in futures if not f.done()])


def map_tasks(fn: Callable[[Any], Any], items: Iterable[Any], *, client: Any = None,
              progress: ProgressFn | None = None) -> list[Any]:
    """``[fn(item) for item in items]``, on the cluster of ``client`` or serially (``client=None``).

    Parameters
    ----------
    fn : a function of one item; on a cluster it and the items are pickled (module-level
        functions, :func:`functools.partial` of them, dataclasses).
    items : the independent inputs.
    client : a :class:`distributed.Client`, or None to run here, in order.
    progress : ``progress(done, total)`` after each finished item.

    Returns
    -------
    list
        the results in the order of ``items`` (the same on a cluster as serially).
    """
    items = list(items)
    results: list[Any] = [None] * len(items)
    for done, (k, value) in enumerate(iter_tasks(fn, items, client=client), start=1):
        results[k] = value
        if progress is not None:
            progress(done, len(items))
    return results
