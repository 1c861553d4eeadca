"""The batch engine: many cases as tasks on dask.distributed, each result handed back as it arrives.

Every command of many cases (``sweep``, ``table2``) gives its cases to :func:`run_tasks`, which
runs them where :class:`Placement` says and calls ``on_result`` in this process for each finished
case, in the order they finish: the command writes it there (atomically), so nothing finished is
lost whatever happens to the run or its workers afterwards, and a rerun skips it.

Where the cases run:

- ``workers=1`` and no scheduler: in this process, one after another; no cluster is started and
  the states of the running case are shown on a terminal.
- ``workers=N`` (N > 1), or ``workers=None`` (sized to the machine: one worker per GPU when the
  cases run on CUDA, one per CPU core otherwise): N workers, of which the first is the run's own
  process and the others a local cluster of N - 1 worker processes started for the run and closed
  at its end (dask.distributed's ``SpecCluster`` of ``Nanny`` workers, as ``LocalCluster`` builds
  it, with one thread per worker). The run's process computes cases from the start, while the
  cluster starts in a thread (a worker's start, interpreter, imports and CUDA, takes seconds), and
  takes the next case whenever each worker process holds its CASES_PER_WORKER; a cluster that
  fails to start leaves the run to this process (:class:`BatchRun`). On CUDA each worker is
  pinned to one GPU (the run's process to the first, the worker processes by
  ``CUDA_VISIBLE_DEVICES``; the workers take the GPUs in turn when there are more workers than
  GPUs) and a case's ``cuda`` or ``cuda:N`` runs on its worker's GPU.
- ``scheduler="tcp://host:8786"``: the workers of a cluster started by hand (``dask scheduler``,
  ``dask worker``; several GPUs, several hosts: docs/scaling.md).

A worker process that dies while computing a case (killed, out of memory, its host lost) has its case
computed again by another worker (dask's scheduler does it; a case whose workers die
``distributed.scheduler.allowed-failures`` + 1 times, 4 by default, is given up and reported as
:class:`LostTask`). The cases finished before are on disk already.

Each worker process keeps the model of its last case (:func:`cached_model`: influence spectra, FFT
plans and buffers, recorded launches; the compiled kernels are the process's anyway), keyed by
materials, sphere, grid, device, float type and FFT backend, so a run of cases of one grid builds
it once per worker and the per-case cost is the solve. Tasks are submitted grouped by that key.
A series of batches on the same models (a fit: one batch per Jacobian, its rows on grids of their
own) keeps one model per distinct key of its cases, at most MAX_KEPT_MODELS and a share of the RAM
(:func:`models_to_keep`), across its batches (:func:`session`); the models go with the series.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import time
import warnings
from collections import OrderedDict, deque
from dataclasses import dataclass, field
from typing import Callable

#: seconds to wait for a scheduler given by address, or for a local cluster's workers, to answer
CONNECT_TIMEOUT_S = 60
#: seconds the closing of a local cluster may take before its worker processes are killed
CLOSE_TIMEOUT_S = 3
#: set in the environment of a local cluster's GPU workers: the case's CUDA device is the worker's
PINNED_GPU_ENV = "WARPCONTACT_WORKER_GPU"


# ---------------------------------------------------------------------------------------------
# Tasks and where they run.


@dataclass(frozen=True)
class Task:
    """One case of a batch, or several solved together (``cases`` > 1: a batched solve's group).

    Attributes:
        key: unique within the run (a case id); names the task on the cluster.
        label: readable name for progress lines and messages.
        fn: a module-level function (picklable by reference), called as ``fn(*args)`` on a worker
            or ``fn(*args, on_state=callback)`` in this process; returns a picklable value, or with
            ``cases`` > 1 a list of one value a case, in the order of its cases.
        args: its arguments (picklable).
        group: tasks of one group share a model (`model_key`); they are submitted together.
        cases: the cases the task computes [-]; they count one by one in the progress line.
    """

    key: str
    label: str
    fn: Callable
    args: tuple = ()
    group: tuple | None = None
    cases: int = 1


@dataclass(frozen=True)
class Placement:
    """Where a batch runs: ``scheduler`` (an address, or None for a cluster of our own), ``workers``
    (None: sized to the machine; 1 without a scheduler: this process) and ``device`` (the cases'
    device: "cpu", "cuda", "cuda:N"; it sizes and pins a local cluster)."""

    scheduler: str | None = None
    workers: int | None = None
    device: str = "cpu"

    def in_process(self, pending: int) -> bool:
        """Whether the cases run in this process: no scheduler given, and one worker asked for, a
        single case (a cluster for one case would only add its start-up), or a machine that a local
        cluster would give one worker (one GPU, one CPU core)."""
        if self.scheduler is not None:
            return False
        return self.workers == 1 or pending <= 1 or len(worker_environments(self, pending)) == 1


class LostTask(RuntimeError):
    """A case whose workers died every time it was tried (killed, out of memory)."""


@dataclass
class Tally:
    """Cases of a run: ``total``, ``before`` (finished by an earlier run), ``done`` (finished now),
    ``failed`` (of those, the ones the command counts as failed), ``running`` (on workers now)."""

    total: int
    before: int = 0
    done: int = 0
    failed: int = 0
    running: int = 0

    def text(self) -> str:
        return f"{self.running} running, {self.failed} failed"


@dataclass
class BatchStats:
    """Times of a run [s]: ``wall_s`` from the first submission to the last result handed back;
    ``start_s`` starting (or reaching) the cluster; ``task_s`` the sum over cases of the time
    inside their functions (on the workers); ``workers`` the workers used (1 in this process)."""

    wall_s: float = 0.0
    start_s: float = 0.0
    task_s: float = 0.0
    tasks: int = 0
    workers: int = 1
    where: str = "this process"
    models_built: int = 0
    task_times: list = field(default_factory=list)


# ---------------------------------------------------------------------------------------------
# Worker side: the model cache, the device, the call.


_models: OrderedDict = OrderedDict()  # this process's models by model_key, the most recently used last
_cache_stats = {"built": 0, "reused": 0}
#: the most models one process keeps for a series of batches (``cached_model``'s ``keep``): a fit
#: keeps one per distinct model of its rows (its rows' grids, say), at most this many
MAX_KEPT_MODELS = 8
#: share of the RAM that the models a CPU process keeps for a fit may take together [-]
#: (``models_to_keep``; each model's influence spectra, spectral buffers and FFT work buffers, as
#: ``resources.breakdown`` counts them). On CUDA the memory check of a new model reads the free
#: memory, which the kept models have taken: ``cached_model`` drops them and builds again when the
#: new model is refused for them.
KEPT_MODELS_RAM_SHARE = 0.25


def model_key(pair, sphere, grid, device: str, dtype: str, fft: str) -> tuple:
    """What a model depends on: materials, sphere (the initial gap), grid, device, float type, FFT
    backend."""
    return (pair, sphere, grid, str(device), str(dtype), str(fft))


def _drop_models(count: int) -> None:
    """Keep this process's ``count`` most recently used models, drop the others."""
    while len(_models) > max(0, count):
        _models.popitem(last=False)


def cached_model(key: tuple, build: Callable, keep: int = 1):
    """The model of ``key`` (:func:`model_key`) when this process holds it, else ``build()``'s.

    The process holds at most ``keep`` models [-] (the most recently used; at most
    MAX_KEPT_MODELS): 1, the last case's, for a sweep or a table, whose cases come grouped by model;
    for a fit the number of distinct models among its rows (:func:`models_to_keep`), so that each of
    its batches (one per Jacobian) finds the models of the batch before. Those beyond ``keep`` are
    dropped before a new one is built, so that its memory check sees them freed; a new one that the
    memory check refuses (InputError on ``grid.n``) while other models are held is built again after
    they are dropped."""
    keep = max(1, min(int(keep), MAX_KEPT_MODELS))
    model = _models.get(key)
    if model is not None:
        _models.move_to_end(key)
        _drop_models(keep)
        _cache_stats["reused"] += 1
        return model
    _drop_models(keep - 1)
    try:
        model = build()
    except Exception as e:
        from ..errors import InputError

        if not (isinstance(e, InputError) and e.key == "grid.n" and _models):
            raise
        _models.clear()  # refused for the memory the kept models hold: they go, the new one is tried again
        model = build()
    _models[key] = model
    _cache_stats["built"] += 1
    return model


def models_to_keep(cases) -> int:
    """How many models [-] a process keeps across a series of batches of ``cases`` (a fit's cases at
    one point: one per data row): the number of distinct models among them (:func:`model_key`), at
    most MAX_KEPT_MODELS and, on the CPU, as many of the largest as fit together in
    KEPT_MODELS_RAM_SHARE of the RAM (at least 1: the case's own, as without keeping)."""
    from ..numerics.resources import breakdown, host_memory_bytes

    sizes = {}
    for c in cases:
        s = c.solver
        key = model_key(c.pair, c.sphere, c.grid, s.device, s.dtype, s.fft)
        if key not in sizes:
            if str(s.device) == "cpu":
                b = breakdown(c.grid.n, s.dtype, "cpu", c.friction is not None, s.fft, adhesion=c.adhesion is not None)
                sizes[key] = b["spectra"] + b["fft_work"]
            else:
                sizes[key] = 0  # CUDA: bounded by cached_model's retry on a refusal (see KEPT_MODELS_RAM_SHARE)
    keep = min(len(sizes), MAX_KEPT_MODELS)
    ram = host_memory_bytes()
    largest = sorted(sizes.values(), reverse=True)
    while keep > 1 and ram and sum(largest[:keep]) > KEPT_MODELS_RAM_SHARE * ram:
        keep -= 1
    return max(1, keep)


def clear_models() -> None:
    """Drop the models this process keeps (the end of a run in this process, or of a fit)."""
    _models.clear()


def worker_device(device: str) -> str:
    """The device a case asking for ``device`` runs on here: on a worker pinned to a GPU
    (``CUDA_VISIBLE_DEVICES`` set to one GPU, which Warp calls cuda:0) any CUDA device is that GPU."""
    if str(device).startswith("cuda") and os.environ.get(PINNED_GPU_ENV) is not None:
        return "cuda:0"
    return str(device)


@dataclass(frozen=True)
class _Raised:
    """An error of warpcontact's raised by a task on a worker, carried back whole (InputError's
    two arguments do not survive pickling as an exception)."""

    kind: str
    args: tuple

    def error(self) -> BaseException:
        from .. import errors

        return getattr(errors, self.kind)(*self.args)


@dataclass(frozen=True)
class _Done:
    value: object
    seconds: float
    worker: str


def _worker_name() -> str:
    gpu = os.environ.get(PINNED_GPU_ENV)
    return f"{socket.gethostname()}:{os.getpid()}" + (f" GPU {gpu}" if gpu is not None else "")


def carried(error: BaseException) -> _Raised | None:
    """An error of warpcontact's as it survives pickling (:func:`call_task`; a batched task's
    case that raised: its value ``raised()`` turns back into the error); None for any other."""
    from ..errors import ConvergenceError, InputError, NonFiniteError

    if isinstance(error, InputError):
        return _Raised("InputError", (error.key, error.problem))
    if isinstance(error, (ConvergenceError, NonFiniteError)):
        return _Raised(type(error).__name__, error.args)
    return None


def raised(value) -> BaseException | None:
    """The error a case's value carries (:func:`carried`), else None."""
    return value.error() if isinstance(value, _Raised) else None


def call_task(fn: Callable, args: tuple) -> _Done | _Raised:
    """Run ``fn(*args)`` on a worker: its value and time, or an error of warpcontact's carried back."""
    from ..errors import ConvergenceError, InputError, NonFiniteError

    t0 = time.perf_counter()
    try:
        value = fn(*args)
    except (InputError, ConvergenceError, NonFiniteError) as e:
        return carried(e)
    return _Done(value, time.perf_counter() - t0, _worker_name())


# ---------------------------------------------------------------------------------------------
# The cluster.


def cpu_cores() -> int:
    """CPU cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def gpu_ordinals(device: str) -> list[int]:
    """The GPUs a local cluster uses for cases on ``device``: every CUDA device for "cuda", the
    one named for "cuda:N"; [] on the CPU. InputError (solver.device) when there is none."""
    device = str(device)
    if not device.startswith("cuda"):
        return []
    from ..numerics.device import resolve_device

    resolve_device(device)  # InputError when absent
    import warp as wp

    return [int(device.split(":")[1])] if ":" in device else list(range(wp.get_cuda_device_count()))


def worker_environments(placement: Placement, pending: int) -> list[dict]:
    """The environment of each worker of a local cluster for ``pending`` cases (one dict each):
    GPU workers pinned to their GPU in turn; as many workers as asked for (default: one per GPU,
    or one per CPU core), never more than the cases."""
    gpus = gpu_ordinals(placement.device)
    count = placement.workers or (len(gpus) if gpus else cpu_cores())
    count = max(1, min(count, pending))
    if not gpus:
        return [{} for _ in range(count)]
    return [{"CUDA_VISIBLE_DEVICES": str(gpus[i % len(gpus)]), PINNED_GPU_ENV: str(gpus[i % len(gpus)])}
            for i in range(count)]


class _Cluster:
    """A dask client on a scheduler given by address, or on a local cluster started here (its
    workers' environments ``envs``; default :func:`worker_environments`)."""

    def __init__(self, placement: Placement, pending: int, envs: list | None = None):
        import logging

        try:
            import dask
            from distributed import Client, Nanny, Scheduler, SpecCluster
        except ImportError as e:  # a dependency of warpcontact, missing from this environment
            from ..errors import InputError

            raise InputError("--workers", f"more than one worker needs dask.distributed, which cannot be "
                                          f"imported here ({e}); install it (pip install distributed) or "
                                          f"run in this process with --workers 1") from None
        self.cluster = None
        if placement.scheduler is not None:
            try:
                self.client = Client(placement.scheduler, timeout=f"{CONNECT_TIMEOUT_S}s", set_as_default=False)
            except (OSError, TimeoutError, ValueError) as e:
                from ..errors import InputError

                raise InputError("--scheduler", f"cannot reach the scheduler at {placement.scheduler!r}: "
                                                f"{e}") from None
            self.where = f"the cluster at {placement.scheduler}"
            return
        envs = worker_environments(placement, pending) if envs is None else envs
        quiet = logging.ERROR
        nanny_log = logging.getLogger("distributed.nanny")
        if _quiet_restart_after_stop not in nanny_log.filters:
            nanny_log.addFilter(_quiet_restart_after_stop)
        workers = {
            f"warpcontact-{i}": {"cls": Nanny, "options": {
                "nthreads": 1, "env": env, "host": "127.0.0.1", "dashboard": False, "memory_limit": 0,
                "silence_logs": quiet, "death_timeout": CONNECT_TIMEOUT_S, "preload": ["warpcontact.studies.batch"]}}
            for i, env in enumerate(envs)
        }
        scheduler = {"cls": Scheduler, "options": {"dashboard_address": None, "host": "127.0.0.1"}}
        started = set(SpecCluster._instances)
        try:
            # a worker takes one case at a time (its thread count) and the rest wait at the scheduler:
            # a worker that dies takes only its running case with it
            with dask.config.set({"distributed.scheduler.worker-saturation": 1.0}):
                self.cluster = SpecCluster(scheduler=scheduler, workers=workers, silence_logs=quiet,
                                           name="warpcontact")
            # not dask's default client: distributed closes that one again at exit, and after a stop
            # (the workers killed, this close cut short) it prints a traceback there
            self.client = Client(self.cluster, timeout=f"{CONNECT_TIMEOUT_S}s", set_as_default=False)
        except BaseException:  # an error while the workers start: they end now
            for cluster in set(SpecCluster._instances) - started:
                _abandon(cluster)
            raise
        gpus = sorted({env[PINNED_GPU_ENV] for env in envs if env})
        self.where = (f"{len(envs)} local worker(s)" + (f" on GPU {', '.join(gpus)}" if gpus else " on the CPU"))

    def threads(self) -> int:
        return max(1, sum(self.client.nthreads().values()))

    def close(self, futures=(), finished: bool = True) -> None:
        """Close the client. A local cluster is closed in order when the run ``finished``; otherwise
        (a stop, an error) its worker processes are killed at once, their cases abandoned. A cluster
        given by address keeps its workers; the cases left are cancelled there."""
        if futures:
            try:
                self.client.cancel(list(futures), force=True)
            except Exception:
                pass
        if self.cluster is not None and not finished:
            _abandon(self.cluster)
        try:
            self.client.close(timeout=CLOSE_TIMEOUT_S)
        except Exception:
            pass
        if self.cluster is not None and finished:
            try:
                self.cluster.close(timeout=CLOSE_TIMEOUT_S)
            except Exception:
                _abandon(self.cluster)


class _ClusterStart:
    """A local cluster of the workers ``envs`` started in a thread of its own, while this process
    computes cases (:class:`BatchRun`): a worker's start (interpreter, imports, CUDA) takes seconds,
    and dask is imported there too. Once :meth:`running` is False, ``cluster`` is the started
    cluster, or None when its start failed (``error``)."""

    def __init__(self, placement: Placement, pending: int, envs: list):
        import threading

        self.cluster: _Cluster | None = None
        self.error: BaseException | None = None
        self.start_s = 0.0
        self._ended = False
        self._before: set | None = None
        self._t0 = time.perf_counter()
        self._thread = threading.Thread(target=self._start, args=(placement, pending, envs),
                                        name="warpcontact-cluster-start", daemon=True)
        self._thread.start()

    def _start(self, placement, pending, envs) -> None:
        try:
            from distributed.deploy.spec import SpecCluster

            self._before = set(SpecCluster._instances)
            cluster = _Cluster(placement, pending, envs)
        except BaseException as e:  # the run goes on in its own process (``BatchRun.started``)
            self.error = e
            return
        if self._ended:  # the run ended while the workers started
            cluster.close(finished=False)
            return
        self.start_s = time.perf_counter() - self._t0
        self.cluster = cluster

    def running(self) -> bool:
        """Whether the cluster is still starting."""
        return self._thread.is_alive()

    def close(self, futures=(), finished: bool = True) -> None:
        """Close the cluster (:meth:`_Cluster.close`). One still starting is not waited for: the
        worker processes started so far are killed (``_abandon``), and the thread closes the
        cluster once it has started."""
        self._ended = True
        if self._thread.is_alive():
            if self._before is not None:
                from distributed.deploy.spec import SpecCluster

                for cluster in set(SpecCluster._instances) - self._before:
                    _abandon(cluster)
            return
        if self.cluster is not None:
            self.cluster.close(futures, finished)


def _abandon(cluster) -> None:
    """End a local cluster's worker processes now (SIGKILL) and keep distributed from closing it
    again at exit (which would wait for them and print a traceback about workers still starting).
    A worker process missed here (being started) ends with this process: it watches its parent."""
    from distributed.deploy.spec import SpecCluster

    nannies = list(getattr(cluster, "workers", {}).values())
    for nanny in nannies:
        # first, so that no nanny starts a new worker when it sees its worker end below: a worker
        # being spawned as this process exits finds its parent's pipe closed and prints a traceback
        # ("EOFError: Ran out of input", seen once in the sweep stop test under load)
        try:
            nanny.close_gracefully(reason="warpcontact-stop")
        except Exception:
            pass
    for nanny in nannies:
        process = getattr(getattr(nanny, "process", None), "process", None)
        pid = getattr(process, "pid", None)
        if pid:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
    cluster.shutdown_on_close = False
    SpecCluster._instances.discard(cluster)
    import logging

    # the start of a worker whose process was killed fails in a task nobody awaits: asyncio would log
    # it with its traceback at exit
    logging.getLogger("asyncio").addFilter(_quiet_abandoned_workers)


def _quiet_abandoned_workers(record) -> bool:
    """A logging filter: False (drop) for asyncio's reports of a local worker that failed to start."""
    return "Nanny failed to start" not in record.getMessage()


def _quiet_restart_after_stop(record) -> bool:
    """A logging filter on distributed's nanny: False (drop) for its reports of a worker it could not
    start or restart once a stop signal has come. The signal reaches the workers of the job too (they
    share its process group); a nanny whose worker ended that way tries to start another while the
    run is closing, and that fails with a traceback on stderr ("Failed to restart worker", or "Nanny
    failed to start process" when the stop comes while a worker is being spawned; both seen under
    load in the stop tests). Reports before any stop signal pass: they are real failures."""
    from .. import interrupts

    if interrupts.received() is None:
        return True
    message = record.getMessage()
    return not any(text in message for text in _WORKER_START_FAILURES)


_WORKER_START_FAILURES = ("Failed to restart worker", "Nanny failed to start")


def dask_setup(worker) -> None:
    """Run by each worker of a local cluster once it has started (Nanny's ``preload``): Ctrl-C at a
    terminal reaches every process of the job, and the run's own process ends its workers, so they
    ignore it (a worker still importing when it comes prints a traceback as it ends)."""
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def _grouped(tasks: list) -> list:
    """``tasks`` with those of one group together (in the order each group first appears)."""
    order: dict = {}
    for t in tasks:
        order.setdefault(t.group, len(order))
    return sorted(tasks, key=lambda t: order[t.group])


# ---------------------------------------------------------------------------------------------
# Running a batch.

#: cases a local worker process holds at once: the one it computes and the next, which it starts
#: while this process computes a case of its own and submits nothing (a worker that dies may take
#: both with it: each is computed again, and the death counts toward its ``allowed-failures``)
CASES_PER_WORKER = 2


class BatchRun:
    """One run of :func:`run_tasks`: its cases not yet started (``queue``, grouped by model), where
    they run, its :class:`Tally` and :class:`BatchStats`, and the cases on a cluster (``futures``,
    each to its task, followed by ``completed``, dask's ``as_completed``).

    Everything happens in the caller's thread, one turn of :meth:`turn` at a time: the cases the
    cluster has finished are handed back, each replaced by the next of the queue, so that the cluster
    holds ``window`` cases at most; beside a local cluster this process computes the next case itself
    whenever the window is full (it is the run's first worker), and the whole run while the cluster
    starts or if it fails to."""

    def __init__(self, tasks, on_result: Callable, placement: Placement, progress=None,
                 failed: Callable | None = None, on_error: Callable | None = None,
                 on_state: Callable | None = None, before: int = 0):
        self.queue = deque(_grouped(list(tasks)))
        self.placement = placement
        self.on_result, self.on_error, self.on_state, self.progress = on_result, on_error, on_state, progress
        self.failed = failed or (lambda value: False)
        self.tally = Tally(total=before + sum(t.cases for t in self.queue), before=before)
        self.stats = BatchStats(tasks=len(self.queue))
        self.here = 0  # cases this process is computing: 1 or 0
        self.beside = placement.scheduler is None  # this process is a worker beside a local cluster
        self.starting: _ClusterStart | None = None  # a local cluster until its start is over
        self.cluster: _Cluster | None = None
        self.slots = 0  # cases the cluster's workers compute at once
        self.window = 0  # cases the cluster holds at once (computing, or waiting for a worker)
        self.futures: dict = {}  # submitted and not yet handed back, each to its task
        self.completed = None  # distributed.as_completed over ``futures``
        self.token = os.urandom(4).hex()  # a rerun's tasks are new tasks on a long-lived cluster

    def run(self, keep_models: bool = False) -> BatchStats:
        """Run every case (:func:`run_tasks`) and return the stats; this process's models are
        dropped at the end unless ``keep_models``."""
        if not self.queue:
            return self.stats
        t0 = time.perf_counter()
        built = _cache_stats["built"]
        try:
            if self.placement.in_process(len(self.queue)):
                self.run_in_process()
            else:
                self.run_on_cluster()
        finally:
            self.stats.models_built = _cache_stats["built"] - built
            if not keep_models:
                clear_models()
        self.stats.wall_s = time.perf_counter() - t0
        self.stats.task_s = sum(self.stats.task_times)
        return self.stats

    # --- the bookkeeping of a case -------------------------------------------------------------

    def show(self, extra: str = "") -> None:
        """Redraw the progress line: cases done, running (here and on the workers), failed."""
        on_cluster = sorted((t.cases for t in self.futures.values()), reverse=True)[:self.slots]
        self.tally.running = self.here + sum(on_cluster)
        if self.progress is not None:
            text = self.tally.text() + ("  " + extra if extra else "")
            self.progress.status(self.tally.before + self.tally.done, extra=text)

    def error(self, task: Task, e: BaseException) -> bool:
        """A case that raised (or a batched task: its cases): to ``on_error`` (False ends the run),
        or raised without one."""
        self.tally.failed += task.cases
        if self.on_error is None:
            raise e
        return self.on_error(task, e) is not False

    def hand_back(self, task: Task, value) -> bool:
        """A finished case (a batched task: its list of cases) to ``on_result``, which writes it;
        False ends the run."""
        values = value if task.cases > 1 else [value]
        self.tally.done += len(values)
        self.tally.failed += sum(1 for v in values if self.failed(v))
        return self.on_result(task, value) is not False

    def run_here(self, task: Task) -> bool:
        """Compute ``task`` in this process, its states to ``on_state``, and hand it back; False ends
        the run. Errors other than warpcontact's end the run."""
        from ..errors import ConvergenceError, InputError, NonFiniteError

        kwargs = {} if self.on_state is None else {"on_state": lambda *a: self.on_state(task, *a)}
        self.here = task.cases
        self.show(task.label)
        t1 = time.perf_counter()
        try:
            value = task.fn(*task.args, **kwargs)
        except (InputError, ConvergenceError, NonFiniteError) as e:
            return self.error(task, e)
        finally:
            self.here = 0
        self.stats.task_times.append(time.perf_counter() - t1)
        return self.hand_back(task, value)

    def run_in_process(self) -> None:
        """Every case in this process, one after another."""
        while self.queue:
            if not self.run_here(self.queue.popleft()):
                return
            self.show()

    # --- a cluster -------------------------------------------------------------------------------

    def run_on_cluster(self) -> None:
        """The cases on a cluster given by address (every case submitted at once: they wait at its
        scheduler for a free worker), or beside a local cluster started in a thread
        (:class:`_ClusterStart`), where this process is the first worker. The cluster is closed at
        the end: in order once every case is handed back, else (a stop, an error, a callback
        ending the run) its worker processes are killed and the cases left abandoned."""
        pending = len(self.queue)
        t0 = time.perf_counter()
        if self.beside:
            envs = worker_environments(self.placement, pending)[1:]  # the first worker's place is this process's
            self.slots, self.window = len(envs), CASES_PER_WORKER * len(envs)
            self.show(f"this process, and {len(envs)} local worker(s) starting")
            self.starting = owner = _ClusterStart(self.placement, pending, envs)
        else:
            self.show("reaching the workers")
            owner = _Cluster(self.placement, pending)
        finished = False
        try:
            if not self.beside:
                self.slots = self.stats.workers = owner.threads()
                self.window = pending
                self.join(owner, time.perf_counter() - t0, owner.where)
            while self.turn():
                pass
            finished = not self.futures and not self.queue
        finally:
            owner.close(list(self.futures), finished)

    def turn(self) -> bool:
        """One turn of the loop: take up the local cluster once started; hand back the cases the
        cluster has finished; compute the next case here when this process is a worker and one is
        left, else wait for the cluster's next. False ends the run: nothing left, or a callback
        said so."""
        if self.starting is not None and not self.starting.running():
            self.started()
        for fut in self.completed.next_batch(block=False) if self.completed is not None else ():
            if not self.collect(fut):
                return False
        if self.beside and self.queue:
            return self.run_here(self.queue.popleft())
        if not self.futures:
            return False
        self.show(f"on {self.stats.where}")
        return self.collect(next(self.completed))

    def started(self) -> None:
        """The local cluster's start is over: its workers join the run, or (it failed) this process
        computes every case alone, and a warning says why."""
        start, self.starting = self.starting, None
        if start.cluster is not None:
            self.stats.workers = self.slots + 1
            self.join(start.cluster, start.start_s, f"this process and {start.cluster.where}")
            return
        self.stats.where = f"this process alone (its local workers did not start: {start.error})"
        warnings.warn(f"the {self.slots} local worker process(es) did not start ({start.error}); "
                      f"the cases run in this process alone", RuntimeWarning, stacklevel=2)

    def join(self, cluster: _Cluster, start_s: float, where: str) -> None:
        """Take ``cluster`` for the run and submit its first cases."""
        from distributed import as_completed

        self.cluster = cluster
        self.completed = as_completed(loop=cluster.client.loop)
        self.stats.start_s, self.stats.where = start_s, where
        self.submit()

    def submit(self) -> None:
        """Fill the cluster's window from the front of the queue."""
        while self.queue and len(self.futures) < self.window:
            task = self.queue.popleft()
            fut = self.cluster.client.submit(call_task, task.fn, task.args, key=f"warpcontact-{task.key}-{self.token}",
                                             pure=False)
            self.futures[fut] = task
            self.completed.add(fut)

    def collect(self, fut) -> bool:
        """Hand back the case of a finished future, the next case submitted in its place first (the
        worker need not wait for the writing); False ends the run. A case whose workers died every
        time it was tried is a :class:`LostTask`."""
        from distributed.client import FutureCancelledError
        from distributed.scheduler import KilledWorker

        task = self.futures.pop(fut)
        self.submit()
        try:
            outcome = fut.result()
        except KilledWorker as e:
            lost = LostTask(f"the case {task.label} was given up: the workers computing it died ({e})")
            return self.error(task, lost)
        except FutureCancelledError:
            return True
        if isinstance(outcome, _Raised):
            return self.error(task, outcome.error())
        self.stats.task_times.append(outcome.seconds)
        return self.hand_back(task, outcome.value)


def run_tasks(tasks, on_result: Callable, placement: Placement | None = None, progress=None,
              failed: Callable | None = None, on_error: Callable | None = None,
              on_state: Callable | None = None, before: int = 0, keep_models: bool = False) -> BatchStats:
    """Run ``tasks`` ([`Task`][warpcontact.studies.batch.Task]) where ``placement`` says; hand each value
    back as it arrives.

    Args:
        tasks: the cases to compute (those finished by an earlier run left out by the caller).
        on_result: ``on_result(task, value)`` in this process, as each case finishes (in the order
            they finish; a batched task's cases together, ``value`` their list): the caller writes
            it. Returning False ends the run (the cases still running are abandoned).
        placement: where (default: this process).
        progress: a `warpcontact.records.progress.Progress` over all the cases; its line is redrawn
            with the cases done, running and failed.
        failed: ``failed(value)``: whether a finished case counts as failed in the progress line
            (a batched task: each of its values).
        on_error: ``on_error(task, error)`` for a case that raised (an error of warpcontact's, or
            `LostTask`); returning False ends the run. By default the error is raised and
            the run ends (the cases finished are written).
        on_state: ``on_state(task, *state_args)`` for the states of a case run in this process
            (passed to its function as ``on_state``).
        before: cases finished by an earlier run (counted in the progress line).
        keep_models: in this process, keep the models after the run (one of a series of batches on
            the same models, inside `session`, which drops them at its end); by default they
            are dropped at the end of the run. Workers keep theirs either way (``cached_model``).

    Returns:
        [`BatchStats`][warpcontact.studies.batch.BatchStats].

    A stop (KeyboardInterrupt: Ctrl-C, SIGTERM, SIGHUP) ends the run at once: a local cluster's
    workers end with it, and the stop is raised after them.
    """
    return BatchRun(tasks, on_result, placement or Placement(workers=1), progress, failed, on_error, on_state,
                    before).run(keep_models)


def each_case(on_result, members: dict, after=None):
    """``on_result(task, value)`` for :func:`run_tasks` where tasks of several cases (``Task.cases``
    > 1) hand back their values together: each to ``on_result`` with its case's own task
    (``members``: a group task's key to its cases' own tasks, ``sweep.batched_tasks``), then
    ``after()`` where given (a table written once for the group); False from any ends the run."""
    def on_task(task, outcome):
        if task.cases == 1:
            return on_result(task, outcome)
        for case_task, each in zip(members[task.key], outcome):
            if on_result(case_task, each) is False:
                return False
        if after is not None:
            after()
        return True

    return on_task


@contextlib.contextmanager
def session(placement: Placement, pending: int):
    """Where a series of batches runs on the same workers and models (a fit: one batch per
    Jacobian). Yields (the placement to give each batch's :func:`run_tasks`, a description of where
    they run or None when each batch says it). Without a scheduler and for more than one worker
    (``pending``: the cases of the first batch), a local cluster is started once for the series and
    given to each batch by its address (:func:`run_tasks` would start one per batch: the workers'
    start and their models would be paid at every batch); it ends with the series. In this process
    (one worker) the models that the batches keep (``run_tasks(..., keep_models=True)``) are dropped
    at the end of the series, as at the end of a single run."""
    if placement.scheduler is not None or placement.in_process(pending):
        try:
            yield placement, None
        finally:
            clear_models()
        return
    cluster = _Cluster(placement, pending)
    finished = False
    try:
        yield Placement(scheduler=cluster.cluster.scheduler_address, device=placement.device), cluster.where
        finished = True
    finally:
        cluster.close(finished=finished)


__all__ = ["BatchStats", "LostTask", "Placement", "Task", "Tally", "cached_model", "call_task", "carried", "clear_models",
           "each_case", "model_key", "models_to_keep", "raised", "run_tasks", "session", "worker_device",
           "worker_environments"]
