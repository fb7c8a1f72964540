"""Ray for the campaign: a local Ray with N one-thread workers, or an existing cluster (``--address``).

Every job is one Ray task (one CPU, ``gpus_per_job`` GPUs) that runs ``ftin.campaign.job.run_job``
on the job's frozen code, the copy in the campaign folder, first on the task's path (Ray takes a
local ``working_dir`` only for a whole driver, not per task, and the campaign folder must be shared
by every node anyway: results and checkpoints land in one folder). Jobs on different copies run in
different worker processes (their runtime environments differ); every job gets a fresh worker. A
worker that dies is retried (``RETRIES``) and its job continues from its last resume state. Stopping
the driver (Ctrl-C, SIGTERM, ``stop``) cancels the running tasks: each job writes its resume state at
its next step and the next ``run`` continues it; a task that does not return within ``STOP_GRACE_S``
is killed. Jobs come from ``Campaign.pending`` each time a slot frees, so a choice made on finished
jobs (FTIN's variant) adds its jobs while the campaign runs.

Ray Tune would add trial folders, its own checkpoints and a second resume mechanism on top of the
training loop's; plain tasks keep one run folder and one resume state per job.
"""

from __future__ import annotations

import contextlib
import importlib
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

from ftin.campaign import INSTALL_HINT, CampaignError
from ftin.campaign.folder import FAILED_FILE, Campaign, write_json
from ftin.interrupts import stop_on_signals

RETRIES = 3  # a task whose worker died runs again this many times
STOP_GRACE_S = 120.0  # how long cancelled jobs get to write their resume state
POLL_S = 0.25  # how often the driver looks for finished jobs and a stop request
THREAD_ENV = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")


def import_ray() -> Any:
    """Ray, or the hint that names the extra to install."""
    try:
        import ray  # here: an optional extra ("[cluster]"); the CLI imports this module without it
    except ImportError:
        raise CampaignError(INSTALL_HINT) from None
    return ray


@contextlib.contextmanager
def ray_session(address: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """Ray for this process: the one already initialised, else a cluster at ``address``, else a local
    Ray with ``workers`` CPUs (shut down on exit)."""
    ray = import_ray()
    if ray.is_initialized():
        yield ray
        return
    options: dict[str, Any] = {"logging_level": "WARNING", "log_to_driver": False}
    if address:
        try:
            ray.init(address=address, **options)
        except ConnectionError as exc:
            raise CampaignError(
                f"{exc}. A cluster started by `ray start` takes drivers with RAY_AUTH_MODE=token set and "
                "its token in ~/.ray/auth_token (or RAY_AUTH_TOKEN)"
            ) from None
    else:
        ray.init(address="local", num_cpus=workers, **options)  # never a cluster found running here
    try:
        yield ray
    finally:
        ray.shutdown()


def train_job(code: str, runs: str, spec: dict[str, Any], data_root: str, device: str, threads: int) -> str:
    """The Ray task: one job on its frozen code. Ray puts the driver's folder first on a worker's
    path (a checkout there would shadow the frozen copy), so the task is pickled by value, puts
    ``code`` first itself and only then imports ftin. It names nothing of ftin (its module's imports
    of ftin would be unpickled on the worker before ``code`` is on the path): Ray is imported here,
    where it is always installed, not through ``import_ray``."""
    import ray  # optional extra; ``import_ray`` would pull ftin into this by-value task

    sys.path.insert(0, code)
    loaded = sys.modules.get("ftin")
    if loaded is not None and not str(loaded.__file__).startswith(code):
        raise RuntimeError(
            f"this worker already holds ftin from {loaded.__file__}, not the job's code {code}"
        )
    job = importlib.import_module("ftin.campaign.job")
    node = ray.get_runtime_context().get_node_id()[:12]
    return job.run_job(runs, spec, data_root, device=device, threads=threads, where=f"ray node {node}")


def run(
    campaign: Campaign,
    *,
    workers: int | None = None,
    address: str | None = None,
    gpus_per_job: float = 0.0,
    threads: int = 1,
    stop: threading.Event | None = None,
    on_event: Callable[[str], None] = print,
) -> dict[str, str]:
    """Run every pending job, ``workers`` at a time (default: the cluster's CPUs); each job's outcome
    by name (``done``, a training stop reason, ``failed: ...``)."""
    stop = stop or threading.Event()
    with ray_session(address, workers) as ray, stop_on_signals(stop):
        slots = workers or max(int(ray.cluster_resources().get("CPU", 1)), 1)
        ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # train_job, by value
        # A fresh worker per job (max_calls=1): a cancel that lands while a worker still imports torch
        # leaves a half-initialised module behind that fails the next job on that worker.
        task = ray.remote(max_calls=1)(train_job)
        device = "cuda" if gpus_per_job > 0 else "cpu"
        jobs = InFlight(ray, campaign, on_event)
        while True:
            if not stop.is_set():
                busy = set(jobs.refs.values()) | set(jobs.outcomes)
                for job in [j for j in campaign.pending() if j.name not in busy][: slots - len(jobs.refs)]:
                    code = campaign.code_for(job).resolve()
                    env = {"PYTHONPATH": str(code), **{name: str(threads) for name in THREAD_ENV}}
                    ref = task.options(
                        num_cpus=1,
                        num_gpus=gpus_per_job,
                        max_retries=RETRIES,
                        name=job.name,
                        runtime_env={"env_vars": env},
                    ).remote(
                        str(code), str(campaign.runs), job.to_json(), str(campaign.data_root), device, threads
                    )
                    jobs.refs[ref] = job.name
                    on_event(f"{job.name}: submitted (code {code.name})")
            if not jobs.refs:
                break
            if stop.is_set():
                jobs.stop(grace_s=STOP_GRACE_S)
                break
            jobs.collect(timeout=POLL_S)
    return jobs.outcomes


@dataclass
class InFlight:
    """The jobs a driver has submitted and not yet heard back from, and the outcomes heard so far."""

    ray: Any
    campaign: Campaign
    on_event: Callable[[str], None]
    refs: dict[Any, str] = field(default_factory=dict)  # Ray object ref -> job name
    outcomes: dict[str, str] = field(default_factory=dict)

    def collect(self, *, timeout: float, wait_all: bool = False) -> None:
        """Record the outcome of one finished job (every one with ``wait_all``) within ``timeout``."""
        ray = self.ray
        count = len(self.refs) if wait_all else 1
        ready, _ = ray.wait(list(self.refs), num_returns=count, timeout=timeout)
        for ref in ready:
            name = self.refs.pop(ref)
            try:
                outcome = ray.get(ref)
            except ray.exceptions.TaskCancelledError:
                outcome = "cancelled"
            except ray.exceptions.RayTaskError as exc:  # the job raised: it wrote failed.json
                outcome = f"failed: {exc.cause!r}"
            except ray.exceptions.RayError as exc:  # its worker died more often than RETRIES
                outcome = f"failed: {type(exc).__name__}"
                write_json(self.campaign.runs / name / FAILED_FILE, {"error": str(exc)[:2000]})
            self._record(name, outcome)

    def stop(self, *, grace_s: float) -> None:
        """Cancel every running job: it saves its resume state at its next step and returns. One that
        has not returned within ``grace_s`` is killed: it had no safe point (still reading its data,
        where a cancel was seen to be lost and the worker to outlive its driver, holding the job's
        lock) and loses nothing since its last saved state."""
        for ref in self.refs:
            self.ray.cancel(ref)  # a KeyboardInterrupt in the worker: training stops at its next step
        self.collect(timeout=grace_s, wait_all=True)
        for ref, name in list(self.refs.items()):
            self.ray.cancel(ref, force=True)  # the worker process ends
            del self.refs[ref]
            self._record(
                name, f"killed: no safe point within {grace_s:.0f} s (resumes from its last saved state)"
            )

    def _record(self, name: str, outcome: str) -> None:
        self.outcomes[name] = outcome
        self.on_event(f"{time.strftime('%H:%M:%S')} {name}: {outcome}")


def map_tasks(
    fn: Callable[..., Any],
    items: Sequence[Any],
    *shared: Any,
    workers: int | None = None,
    address: str | None = None,
    on_done: Callable[[int], None] | None = None,
) -> list[Any]:
    """``fn(item, *shared)`` for every item as Ray tasks (one CPU each, ``workers`` at a time; default:
    the cluster's CPUs), results in the items' order. ``shared`` goes to the object store once;
    ``on_done(index)`` is called as each item finishes (progress bars)."""
    with ray_session(address, workers) as ray:
        slots = workers or max(int(ray.cluster_resources().get("CPU", 1)), 1)
        env = {name: "1" for name in THREAD_ENV}
        task = ray.remote(fn).options(num_cpus=1, max_retries=RETRIES, runtime_env={"env_vars": env})
        refs = [ray.put(value) for value in shared]
        results: list[Any] = [None] * len(items)
        queue, in_flight = list(enumerate(items)), {}
        while queue or in_flight:
            while queue and len(in_flight) < slots:
                index, item = queue.pop(0)
                in_flight[task.remote(item, *refs)] = index
            ready, _ = ray.wait(list(in_flight), num_returns=1)
            for ref in ready:
                index = in_flight.pop(ref)
                results[index] = ray.get(ref)
                if on_done is not None:
                    on_done(index)
        return results
