"""The batch engine (warpcontact.studies.batch): cases as tasks on dask.distributed.

A worker killed mid-sweep loses nothing finished and its case is computed again; the per-worker
model cache gives the numbers of a fresh model; errors cross the process boundary whole; local
clusters are sized to the machine and pinned to GPUs; a sweep runs on a scheduler given by address.

Every test that starts a cluster uses at most 2 worker processes (CI has 2 CPU cores), small
grids, and an alarm that ends it (the cluster closed) instead of letting it hang.
"""

import json
import os
import pickle
import signal
import sys
import threading
import time
from pathlib import Path

import pytest

from warpcontact.studies import batch
from warpcontact.studies.batch import Placement, Task, run_tasks
from warpcontact.errors import InputError

ROOT = Path(__file__).resolve().parents[1]
HERTZ_CASE = ROOT / "examples" / "hertz.toml"
#: seconds a test that starts a cluster may take before the alarm ends it
ALARM_S = 240


@pytest.fixture
def alarm():
    """SIGALRM after ALARM_S seconds raises in the test (run_tasks closes its cluster on the way out)."""

    def ring(signum, frame):
        raise TimeoutError(f"the batch test took more than {ALARM_S} s")

    previous = signal.signal(signal.SIGALRM, ring)
    signal.alarm(ALARM_S)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.fixture
def by_value():
    """This module's functions travel to the workers by value (the workers need not import it)."""
    import cloudpickle

    module = sys.modules[__name__]
    cloudpickle.register_pickle_by_value(module)
    yield
    cloudpickle.unregister_pickle_by_value(module)


def marked_task(folder: str, key: str, seconds: float) -> dict:
    """A case for the engine's own tests: writes ``started-<key>-<pid>`` in ``folder``, waits
    ``seconds`` and returns which process computed it."""
    Path(folder, f"started-{key}-{os.getpid()}").write_text("")
    time.sleep(seconds)
    return {"key": key, "pid": os.getpid()}


def raise_input_error(key: str, problem: str):
    raise InputError(key, problem)


def _starts(folder: Path) -> dict:
    """key -> pids of the processes that started it."""
    out = {}
    for p in folder.glob("started-*"):
        _, key, pid = p.name.split("-")
        out.setdefault(key, []).append(int(pid))
    return out


def _children(pid: int) -> list[int]:
    """Processes whose parent is ``pid`` (Linux /proc)."""
    kids = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                kids.append(int(entry.name))
    return kids


def _kill_when(condition, pick_pid, timeout=120):
    """A thread that waits for ``condition()`` and SIGKILLs ``pick_pid()``; returns (thread, killed)."""
    killed = []

    def watch():
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout:
            if condition():
                pid = pick_pid()
                if pid is not None:
                    os.kill(pid, signal.SIGKILL)
                    killed.append(pid)
                    return
            time.sleep(0.05)

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    return thread, killed


def has_default_client() -> bool:
    from distributed import default_client

    try:
        default_client()
    except ValueError:  # "No clients found"
        return False
    return True


@pytest.mark.skipif(not Path("/proc").exists(), reason="finds the worker processes through /proc")
def test_a_worker_killed_mid_run_loses_nothing_and_its_case_is_rerun(tmp_path, alarm, by_value):
    """Six 1.5 s cases on 2 workers (the run's process and one local worker process); once two
    cases are handed back, the worker process computing a third is killed (SIGKILL). Every case is
    handed back exactly once, the two finished before the kill among them, and the killed worker's
    case was started again by another process. So was any case that worker had finished but not
    yet handed back: its result died with the worker's memory, and dask computes it again."""
    folder = tmp_path / "marks"
    folder.mkdir()
    tasks = [Task(f"c{i}", f"case {i}", marked_task, (str(folder), f"c{i}", 1.5)) for i in range(6)]
    results = {}

    def running_elsewhere():
        """A case started and not handed back, on a worker process (not this one, which computes
        cases too) that is not running another's end."""
        if len(results) < 2:
            return None
        for key, pids in _starts(folder).items():
            if key not in results and len(pids) == 1 and pids[0] != os.getpid():
                return pids[0]
        return None

    watcher, killed = _kill_when(lambda: running_elsewhere() is not None, running_elsewhere)
    before_kill = {}

    defaults = []

    def on_result(task, value):
        results[task.key] = value
        defaults.append(has_default_client())
        if not killed:
            before_kill[task.key] = value

    stats = run_tasks(tasks, on_result, Placement(workers=2))
    watcher.join(timeout=5)
    # the run's client is not dask's default: distributed closes that one again at exit, and after
    # a stop (workers killed, the run's close cut short) it printed a traceback there
    assert defaults and not any(defaults)
    assert killed, "no worker was killed: the cases ended before the watcher saw one running"
    assert sorted(results) == [t.key for t in tasks]  # each case handed back, once (a dict keyed by case)
    assert all(results[k] == v for k, v in before_kill.items()) and len(before_kill) >= 2
    starts = _starts(folder)
    # its running case, and any it had finished whose result was not yet handed back
    victims = [k for k, pids in starts.items() if killed[0] in pids and k not in before_kill]
    assert victims, starts
    for key in victims:
        assert len(starts[key]) == 2 and results[key]["pid"] != killed[0], starts  # computed again, elsewhere
    assert stats.workers == 2 and len(stats.task_times) == 6


@pytest.mark.skipif(not Path("/proc").exists(), reason="finds the worker processes through /proc")
def test_a_sweep_whose_worker_is_killed_finishes_with_every_case_written(tmp_path, alarm):
    """A real sweep (frictionless Hertz solves, 5 grids) on 2 local workers; a worker is killed
    (SIGKILL) once the first case is written. The sweep completes: every case written once, the
    first case's file unchanged, sweep.json complete."""
    from warpcontact.studies.sweep import run_sweep
    from warpcontact.studies.sweep_spec import load_sweep

    (tmp_path / "sweep.toml").write_text(f'base = "{HERTZ_CASE.as_posix()}"\n[sweep]\n'
                                         '"load.steps" = [3, 4, 5, 6, 7]\n[run]\ntask = "solve"\n')
    sweep = load_sweep(tmp_path / "sweep.toml")
    out = tmp_path / "out"
    first = {}

    def written():
        files = sorted((out / "cases").glob("*.json")) if (out / "cases").exists() else []
        if files and not first:
            first.update(path=files[0], data=files[0].read_bytes())
        return bool(files)

    def a_worker():
        workers = [p for p in _children(os.getpid()) if "spawn" in Path(f"/proc/{p}/cmdline").read_text()]
        return workers[0] if workers else None

    watcher, killed = _kill_when(written, a_worker)
    report = run_sweep(sweep, out, quiet=True, placement=Placement(workers=2))
    watcher.join(timeout=5)
    assert killed, "no worker was killed"
    assert not report.interrupted and report.write_error is None
    assert len(report.records) == 5 and all(r["converged"] for r in report.records), report.records
    assert sorted(p.stem for p in (out / "cases").glob("*.json")) == sorted(sc.id for sc in sweep.cases)
    assert first["path"].read_bytes() == first["data"]  # finished before the kill: kept as written
    status = json.loads((out / "sweep.json").read_text())
    assert status["complete"] is True and status["finished"] == 5


def test_the_model_cache_reuses_the_model_and_gives_a_fresh_models_numbers():
    """Two cases of one grid in one process: the second reuses the first's model (built once) and
    its forces equal those of a case solved with a model of its own, to the bit (same operations)."""
    from warpcontact import api
    from warpcontact.records.case import load_case
    from warpcontact.studies.sweep import run_case

    case = load_case(HERTZ_CASE)  # the example's n = 128, one state
    batch.clear_models()
    built = batch._cache_stats["built"]
    reused = batch._cache_stats["reused"]
    one = run_case("solve", 0.01, case)
    two = run_case("solve", 0.01, case)
    assert batch._cache_stats["built"] - built == 1 and batch._cache_stats["reused"] - reused == 1
    fresh = api.solve(case).states[-1]
    for r in (one, two):
        assert r["summary"]["force"] == fresh["force"] and r["summary"]["iterations"] == fresh["iterations"]
    other = case.with_overrides(dtype="float32")  # another model key: built, the last one dropped
    run_case("solve", 0.01, other)
    assert batch._cache_stats["built"] - built == 2 and len(batch._models) == 1
    batch.clear_models()


def _cached_once(key, keep=1):
    """The cache's model of ``key``, a stand-in (the cache holds any object; its builds are counted
    in batch._cache_stats)."""
    return batch.cached_model(key, lambda: ("model", key), keep)


def test_the_cache_keeps_at_most_keep_models_the_most_recently_used():
    """keep = 1 (sweeps, tables): another key drops the last model. keep = 3 (a fit of three
    rows' models): the three are kept, a fourth drops the least recently used, and a later call
    with keep = 1 (an unrelated sweep on the same worker) leaves one; never more than
    MAX_KEPT_MODELS."""
    batch.clear_models()
    built = batch._cache_stats["built"]
    for key in ("a", "b", "a"):
        _cached_once(key)
    assert batch._cache_stats["built"] - built == 3 and list(batch._models) == ["a"]
    batch.clear_models()
    built = batch._cache_stats["built"]
    for key in ("a", "b", "c", "a", "b", "c"):
        _cached_once(key, keep=3)
    assert batch._cache_stats["built"] - built == 3 and list(batch._models) == ["a", "b", "c"]
    _cached_once("a", keep=3)  # used: the most recent
    _cached_once("d", keep=3)  # drops b, the least recently used
    assert list(batch._models) == ["c", "a", "d"]
    _cached_once("a", keep=1)
    assert list(batch._models) == ["a"]
    for i in range(batch.MAX_KEPT_MODELS + 4):
        _cached_once(i, keep=100)
    assert len(batch._models) == batch.MAX_KEPT_MODELS
    batch.clear_models()


def test_kept_models_are_dropped_and_built_again_when_the_new_one_does_not_fit():
    """A new model refused for memory (InputError on grid.n) while others are kept: they are
    dropped and it is built again, so keeping models never refuses a case that fits alone."""
    batch.clear_models()
    _cached_once("a", keep=2)
    tries = []

    def build():
        tries.append(len(batch._models))
        if batch._models:
            raise InputError("grid.n", "does not fit")
        return "b"

    assert batch.cached_model("b", build, keep=2) == "b"
    assert tries == [1, 0] and list(batch._models) == ["b"]
    with pytest.raises(InputError):  # refused alone: the error stands
        batch.cached_model("c", lambda: (_ for _ in ()).throw(InputError("grid.n", "does not fit")), keep=2)
    batch.clear_models()


def _task_on_model(key):
    _cached_once(key, keep=2)
    return key


def test_a_series_of_batches_in_this_process_keeps_its_models_until_the_series_ends():
    """The fit's batches (one per Jacobian) in this process: run_tasks(keep_models=True) inside
    session() keeps the models from one batch to the next (two models, built once for three
    batches); the series' end drops them. A run_tasks without keep_models drops them at its end, as
    before (a sweep, a table)."""
    batch.clear_models()
    built = batch._cache_stats["built"]
    with batch.session(Placement(workers=1), 2) as (placement, where):
        assert placement == Placement(workers=1) and where is None
        for _ in range(3):
            tasks = [Task(k, k, _task_on_model, (k,), group=k) for k in ("row 1", "row 2")]
            stats = run_tasks(tasks, lambda t, v: None, placement, keep_models=True)
            assert list(batch._models) == ["row 1", "row 2"]
        assert batch._cache_stats["built"] - built == 2 and stats.models_built == 0
    assert not batch._models
    run_tasks([Task("x", "x", _task_on_model, ("row 1",))], lambda t, v: None, Placement(workers=1))
    assert not batch._models


def test_errors_of_warpcontact_cross_the_process_boundary_whole():
    """InputError's two arguments do not survive pickling as an exception: call_task carries them."""
    carried = batch.call_task(raise_input_error, ("grid.n", "must be at least 8, got 4"))
    back = pickle.loads(pickle.dumps(carried)).error()
    assert isinstance(back, InputError) and back.key == "grid.n" and back.problem == "must be at least 8, got 4"
    done = batch.call_task(lambda x: x + 1, (1,))
    assert done.value == 2 and done.seconds >= 0


def test_a_local_cluster_that_does_not_start_leaves_the_run_to_this_process(monkeypatch, tmp_path):
    """Beside a local cluster this process computes too; when the cluster cannot start (here its
    start raises at once), every case is still computed, here, and a warning says why (the
    cases take 0.3 s each, so the start has failed before the first ends)."""
    def no_cluster(self, placement, pending, envs=None):
        raise RuntimeError("no worker could start")

    monkeypatch.setattr(batch._Cluster, "__init__", no_cluster)
    seen = []
    tasks = [Task(f"c{i}", f"case {i}", marked_task, (str(tmp_path), f"c{i}", 0.3)) for i in range(3)]
    with pytest.warns(RuntimeWarning, match="did not start .no worker could start.; the cases run in this process"):
        stats = run_tasks(tasks, lambda t, v: seen.append((t.key, v["pid"])), Placement(workers=2))
    assert sorted(seen) == [("c0", os.getpid()), ("c1", os.getpid()), ("c2", os.getpid())]
    assert stats.where.startswith("this process alone") and len(stats.task_times) == 3


def test_in_process_errors_go_to_on_error_and_the_run_goes_on():
    seen, errors = [], []
    tasks = [Task("a", "a", raise_input_error, ("k", "bad")), Task("b", "b", lambda: 2)]
    stats = run_tasks(tasks, lambda t, v: seen.append((t.key, v)), Placement(workers=1),
                      on_error=lambda t, e: errors.append((t.key, e.key)))
    assert seen == [("b", 2)] and errors == [("a", "k")] and stats.workers == 1
    with pytest.raises(InputError):  # without on_error the error ends the run
        run_tasks(tasks, lambda t, v: None, Placement(workers=1))


def test_local_clusters_are_sized_to_the_machine_and_pinned_to_gpus(monkeypatch):
    monkeypatch.setattr(batch, "cpu_cores", lambda: 16)
    assert len(batch.worker_environments(Placement(), pending=100)) == 16  # one per core
    assert len(batch.worker_environments(Placement(), pending=3)) == 3  # never more than the cases
    assert batch.worker_environments(Placement(workers=2), pending=100) == [{}, {}]
    monkeypatch.setattr(batch, "gpu_ordinals", lambda device: [0, 1] if device == "cuda" else [1])
    envs = batch.worker_environments(Placement(device="cuda"), pending=100)
    assert [e["CUDA_VISIBLE_DEVICES"] for e in envs] == ["0", "1"]  # one per GPU
    envs = batch.worker_environments(Placement(device="cuda", workers=3), pending=100)
    assert [e["CUDA_VISIBLE_DEVICES"] for e in envs] == ["0", "1", "0"]  # in turn
    envs = batch.worker_environments(Placement(device="cuda:1"), pending=100)
    assert [e["CUDA_VISIBLE_DEVICES"] for e in envs] == ["1"]


def test_a_pinned_worker_runs_any_cuda_device_on_its_gpu(monkeypatch):
    monkeypatch.delenv(batch.PINNED_GPU_ENV, raising=False)
    assert batch.worker_device("cuda:1") == "cuda:1" and batch.worker_device("cpu") == "cpu"
    monkeypatch.setenv(batch.PINNED_GPU_ENV, "3")
    assert batch.worker_device("cuda:1") == "cuda:0" and batch.worker_device("cuda") == "cuda:0"
    assert batch.worker_device("cpu") == "cpu"


def test_tasks_of_one_model_are_submitted_together():
    tasks = [Task(str(i), str(i), None, (), group=g) for i, g in enumerate("abab")]
    assert [t.key for t in batch._grouped(tasks)] == ["0", "2", "1", "3"]


def test_in_process_placement(monkeypatch):
    monkeypatch.setattr(batch, "cpu_cores", lambda: 2)
    assert Placement(workers=1).in_process(10) and Placement().in_process(1)
    assert not Placement().in_process(2) and not Placement(scheduler="tcp://h:1", workers=1).in_process(1)
    monkeypatch.setattr(batch, "cpu_cores", lambda: 1)  # a machine a local cluster gives one worker
    assert Placement().in_process(10)
    monkeypatch.setattr(batch, "gpu_ordinals", lambda device: [0])  # one GPU: no cluster, no dask
    assert Placement(device="cuda").in_process(10)
    monkeypatch.setattr(batch, "gpu_ordinals", lambda device: [0, 1])
    assert not Placement(device="cuda").in_process(10) and Placement(device="cuda", workers=1).in_process(10)


def test_a_sweep_runs_on_a_scheduler_given_by_address(tmp_path, alarm):
    """The cluster of another process (here a LocalCluster of one worker process started by the
    test, as `dask scheduler` and `dask worker` would be): [run] scheduler sends the cases there;
    the cluster keeps running after the sweep."""
    from distributed import LocalCluster

    from warpcontact.studies.sweep import run_sweep
    from warpcontact.studies.sweep_spec import load_sweep

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1") as cluster:
        (tmp_path / "sweep.toml").write_text(
            f'base = "{HERTZ_CASE.as_posix()}"\n[sweep]\n"grid.n" = [32, 48]\n'
            f'[run]\ntask = "solve"\nscheduler = "{cluster.scheduler_address}"\n')
        sweep = load_sweep(tmp_path / "sweep.toml")
        assert sweep.scheduler == cluster.scheduler_address
        report = run_sweep(sweep, tmp_path / "out", quiet=True, placement=Placement(scheduler=sweep.scheduler))
        assert len(report.records) == 2 and all(r["converged"] for r in report.records)
        assert report.batch.where == f"the cluster at {cluster.scheduler_address}"
        assert len(cluster.scheduler.workers) == 1  # still there


def test_an_unreachable_scheduler_is_an_input_error(tmp_path, monkeypatch):
    monkeypatch.setattr(batch, "CONNECT_TIMEOUT_S", 1)
    with pytest.raises(InputError) as e:
        run_tasks([Task("a", "a", int, ())], lambda t, v: None, Placement(scheduler="tcp://127.0.0.1:9"))
    assert e.value.key == "--scheduler"


def test_bad_run_scheduler_names_the_key(tmp_path):
    from warpcontact.studies.sweep_spec import load_sweep

    (tmp_path / "sweep.toml").write_text(f'base = "{HERTZ_CASE.as_posix()}"\n[sweep]\n"grid.n" = [32]\n'
                                         "[run]\nscheduler = 8786\n")
    with pytest.raises(InputError) as e:
        load_sweep(tmp_path / "sweep.toml")
    assert e.value.key == "run.scheduler"


@pytest.mark.parametrize("message", ["Failed to restart worker after its process exited",
                                     "Nanny failed to start process"])
def test_worker_start_failures_are_dropped_only_after_a_stop_signal(message, monkeypatch):
    """A nanny's report that a worker could not start is a real failure before any stop signal and
    passes; after one (the signal reached the workers too) it is the run closing, and is dropped."""
    import logging

    from warpcontact import interrupts

    record = logging.LogRecord("distributed.nanny", logging.ERROR, __file__, 1, message, None, None)
    interrupts.reset()
    assert batch._quiet_restart_after_stop(record) is True
    monkeypatch.setattr(interrupts, "_received", int(signal.SIGTERM))
    assert batch._quiet_restart_after_stop(record) is False
    other = logging.LogRecord("distributed.nanny", logging.ERROR, __file__, 1, "Worker process died", None, None)
    assert batch._quiet_restart_after_stop(other) is True


def test_abandoning_a_local_cluster_stops_its_nannies_restarting_first(monkeypatch):
    """A stop kills the local workers (``batch._abandon``); each nanny is told to close gracefully
    before its worker is killed, so that none spawns a new worker as the run exits (a worker spawned
    then finds its parent gone and prints a traceback: seen once in the sweep stop test)."""
    import os
    import signal
    from types import SimpleNamespace

    from warpcontact.studies import batch

    events = []

    class FakeNanny:
        def __init__(self, pid):
            self.process = SimpleNamespace(process=SimpleNamespace(pid=pid))

        def close_gracefully(self, reason=""):
            events.append(("graceful", self.process.process.pid))

    def fake_kill(pid, signum):
        events.append(("kill", pid))
        assert signum == signal.SIGKILL

    monkeypatch.setattr(os, "kill", fake_kill)
    class FakeCluster:  # weakly referable, as distributed's registry of clusters needs
        workers = {"a": FakeNanny(101), "b": FakeNanny(102)}
        shutdown_on_close = True

    cluster = FakeCluster()
    batch._abandon(cluster)
    assert events == [("graceful", 101), ("graceful", 102), ("kill", 101), ("kill", 102)]
    assert cluster.shutdown_on_close is False


def test_table2_cells_searched_together_on_a_worker_record_what_this_process_records(tmp_path, alarm):
    """``warpcontact table2 --batch 2 --scheduler ADDRESS``: the cells go to the cluster's worker
    as tasks of two cells of one grid searched together (``table2.search_cells``: their records
    and their checks' messages cross the process boundary), each counted as a cell; each record is
    what the batched searches in this process write: the same states and delta_x_max, mu within
    2e-9 (another process's FFTW plans may round otherwise, as in the batched sweep's test)."""
    from distributed import LocalCluster

    from warpcontact.cli import main
    from warpcontact.studies import table2

    sel = ["table2", "--no-adhesion", "--n", "24", "--k-tau", "0.8", "0.95", "--delta-z-um", "5e-5", "1e-5",
           "--batch", "2", "--quiet"]
    tasks = []
    run = batch.BatchRun.run

    def counted(self, keep_models=False):  # (in this process the batched searches run before: no tasks)
        tasks.extend(self.queue)
        stats = run(self, keep_models)
        assert self.tally.done == (4 if tasks else 0) and self.tally.total == 4
        return stats

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1") as cluster:
        batch.BatchRun.run = counted
        try:
            codes = [main([*sel, "--out", str(tmp_path / "here")]),
                     main([*sel, "--scheduler", cluster.scheduler_address, "--out", str(tmp_path / "there")])]
        finally:
            batch.BatchRun.run = run
    assert codes[0] == codes[1] and codes[0] in (0, 3)
    assert [(t.fn, t.cases) for t in tasks] == [(table2.search_cells, 2)] * 2
    here, there = (json.loads((tmp_path / d / "table2.json").read_text()) for d in ("here", "there"))
    assert here["complete"] and there["complete"]
    by_cell = {(c["k_tau"], c["delta_z_um"]): c for c in there["cells"]}
    assert sorted(by_cell) == sorted((c["k_tau"], c["delta_z_um"]) for c in here["cells"])
    for a in here["cells"]:
        b = by_cell[(a["k_tau"], a["delta_z_um"])]
        assert (a["converged"], a["states"], a["delta_x_max_um"]) == (b["converged"], b["states"], b["delta_x_max_um"])
        if a["mu"] is not None:
            assert abs(a["mu"] - b["mu"]) <= 2e-9


def test_sweep_cases_solved_together_on_a_worker_record_what_one_at_a_time_records(tmp_path, alarm):
    """``warpcontact sweep --batch 2 --scheduler ADDRESS``: the cases of normal contact go to the
    cluster's worker as tasks of two cases of one grid solved together
    (``sweep.run_cases_batched``), a contact past the domain's edge among them; each record is what
    one case at a time in this process writes: statuses, errors, states and contact areas the same,
    forces within 1e-8 (both solves stop at a relative residual of 1e-10; the batched and the single
    solve's iterates differ in rounding, as in test_sweep's batched sweep)."""
    from distributed import LocalCluster

    from warpcontact.studies import sweep as sweep_module
    from warpcontact.studies.sweep import run_sweep
    from warpcontact.studies.sweep_spec import load_sweep

    (tmp_path / "sweep.toml").write_text(
        f'base = "{HERTZ_CASE.as_posix()}"\n[sweep]\n"grid.n" = [32]\n"sphere.E" = [106e9, 150e9]\n'
        '"load.path" = [[[0.0, 0.0, 4e-11], [0.0, 0.0, 1.0e-10]], [[0.0, 0.0, 7e-11]], [[0.0, 0.0, 3.9e-10]]]\n'
        '[run]\ntask = "solve"\n')
    sweep = load_sweep(tmp_path / "sweep.toml")
    one = run_sweep(sweep, tmp_path / "one", quiet=True, placement=Placement(workers=1), batch=0)
    tasks = []
    run = batch.BatchRun.run

    def counted(self, keep_models=False):
        tasks.extend(self.queue)
        return run(self, keep_models)

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
                      host="127.0.0.1") as cluster:
        batch.BatchRun.run = counted
        try:
            together = run_sweep(sweep, tmp_path / "together", quiet=True,
                                 placement=Placement(scheduler=cluster.scheduler_address), batch=2)
        finally:
            batch.BatchRun.run = run
    assert [(t.fn, t.cases) for t in tasks] == [(sweep_module.run_cases_batched, 2)] * 3
    assert together.batch.where == f"the cluster at {cluster.scheduler_address}"
    assert [r["id"] for r in one.records] == [r["id"] for r in together.records]
    assert [r["status"] for r in together.records] == ["ok", "ok", "error"] * 2
    for x, y in zip(one.records, together.records):
        assert (x["status"], x["converged"], x.get("error")) == (y["status"], y["converged"], y.get("error"))
        if "summary" in x:
            s, t = x["summary"], y["summary"]
            assert (s["n_states"], s["contact_area"]) == (t["n_states"], t["contact_area"])
            assert t["force"]["z"] == pytest.approx(s["force"]["z"], rel=1e-8)
    assert json.loads((tmp_path / "together" / "sweep.json").read_text())["complete"]
