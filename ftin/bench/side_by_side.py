"""Side-by-side speed and memory of every model on this machine (``ftin bench``).

Per model, on random ``(batch, 6, window)`` inputs at the model's default configuration (built for
``window``, as ``ftin models`` does):

* inference windows/s: eval mode under ``torch.inference_mode``, one warm-up pass, then the fastest
  of ``repeats`` timed passes (``ftin.bench.profile.windows_per_second``: the fastest pass is the
  one least disturbed by other processes on a shared machine);
* training windows/s: one step = zero_grad + forward + the training loss (MSE on velocity, Gaussian
  NLL for models with an uncertainty head, as ``ftin train`` by default) + backward + Adam step; one
  warm-up step (it also allocates Adam's moments), then the fastest of ``repeats`` timed steps;
* real-time factor: seconds of IMU that one second of compute turns into velocities when predicting
  with ``stride`` at ``rate_hz``, i.e. ``inference windows/s x stride / rate_hz`` (a recording
  needs ``rate_hz / stride`` windows per second of data);
* peak memory, measured with ``getrusage(RUSAGE_SELF).ru_maxrss`` (the kernel's peak resident set
  size of the process) when ``memory`` is on. Each model and each phase (inference, training) runs in
  its own process, forked from a ``multiprocessing`` fork server that has only imported torch and
  ``ftin`` and never run a model, so no earlier model or phase raises the peak. Reported are the
  process's peak RSS after the phase and its increase over the peak just before the phase's first
  pass (model built): the working memory of the input batch, activations, gradients, Adam's state
  and allocator caches (a phase needing less than building the model did reads 0). The
  absolute peak includes the Python and torch runtime (~200-350 MiB). Why not ``subprocess``: Linux
  carries a parent's ``ru_maxrss`` across fork + exec (measured: a child of a 1.5 GiB parent reports
  1.5 GiB), so a worker started from the CLI or pytest process would report the parent's peak; a
  child forked from the small fork server inherits only the server's import-time peak. With
  ``memory`` off everything runs in this process and memory is not reported.

Every phase uses ``torch.set_num_threads(threads)``, by default 1: measured on the project's 2-core
machine while one other process kept a core busy, RoNIN ResNet ran 1,534 windows/s on 1 thread and
246 on 2 (the second thread waits on the busy core at every parallel region), so 1 thread gives
numbers that are stable and comparable between models on a shared machine; ``--threads 2`` measures
a machine of one's own.
"""

from __future__ import annotations

import multiprocessing
import os
import platform
import resource
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, fields
from enum import Enum
from multiprocessing.connection import Connection
from typing import Any

import torch

from ftin.bench.profile import count_parameters, torch_threads, windows_per_second
from ftin.files import to_json_safe
from ftin.models.registry import check_known_models, create_model, list_models
from ftin.train.config import TrainConfig
from ftin.train.losses import velocity_loss

MEMORY_METHOD = (
    "each model and phase in its own process forked from a fork server that only imported torch; "
    "peak = ru_maxrss (peak resident set size) after the phase, incl. the ~200-350 MiB runtime; "
    "increase = that minus ru_maxrss just before the phase's first pass"
)
# What the fork server imports once, so that each forked worker starts in milliseconds.
_SERVER_PRELOAD = ("ftin.bench.side_by_side", "ftin.train.loop")
_MIB = 1024.0 * 1024.0


class Phase(str, Enum):
    INFERENCE = "inference"
    TRAINING = "training"


@dataclass(frozen=True)
class BenchConfig:
    window: int = 100  # samples: the paper's 1 s window at 100 Hz
    batch: int = 128  # windows per pass / step (the paper trains with 512: --batch 512, ~4x slower)
    threads: int = 1  # see the module docstring
    repeats: int = 2  # timed passes / steps after one warm-up
    stride: int = 10  # for the real-time factor
    rate_hz: float = 100.0  # for the real-time factor
    lr: float = 1e-4  # Adam, as the paper
    memory: bool = True  # measure peak memory in subprocesses (see the module docstring)
    timeout_s: float = 600.0  # per isolated phase

    def __post_init__(self) -> None:
        for key in ("window", "batch", "threads", "repeats", "stride"):
            if getattr(self, key) < 1:
                raise ValueError(f"{key} must be >= 1, got {getattr(self, key)}")
        for key in ("rate_hz", "lr", "timeout_s"):
            if not getattr(self, key) > 0:
                raise ValueError(f"{key} must be > 0, got {getattr(self, key)}")


@dataclass(frozen=True)
class PhaseResult:
    windows_per_s: float
    peak_rss_mib: float | None = None  # None when memory was not measured
    peak_increase_mib: float | None = None


@dataclass(frozen=True)
class BenchResult:
    model: str
    window: int
    parameters: int | None
    inference: PhaseResult | None
    training: PhaseResult | None
    real_time_factor: float | None
    error: str | None = None  # why (part of) the model could not be measured

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


# --- one phase (the subprocess body) -----------------------------------------------------------------


def _peak_rss_bytes() -> float:
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return float(peak) if sys.platform == "darwin" else float(peak) * 1024.0  # bytes on macOS, KiB else


def peak_rss_mib() -> float:
    """This process's peak resident set size so far (``getrusage``'s ``ru_maxrss``), in MiB."""
    return _peak_rss_bytes() / _MIB


def _training_windows_per_second(model: torch.nn.Module, config: BenchConfig) -> float:
    # ``ftin train``'s default clamp of the log-std (the config cannot be built without data paths)
    log_std_range = next(f.default for f in fields(TrainConfig) if f.name == "log_std_range")

    generator = torch.Generator().manual_seed(0)
    x = torch.randn(config.batch, 6, config.window, generator=generator)
    target = torch.randn(config.batch, model.out_dim, generator=generator)
    use_nll = bool(getattr(model, "has_uncertainty", False))
    optimizer = torch.optim.Adam(model.parameters(), lr=config.lr)
    model.train()

    def step() -> None:
        optimizer.zero_grad(set_to_none=True)
        loss = velocity_loss(model(x), target, use_nll, False, log_std_range)
        loss.backward()
        optimizer.step()

    step()  # warm-up: allocator, oneDNN caches, Adam's moment buffers
    seconds = []
    for _ in range(config.repeats):
        start = time.perf_counter()
        step()
        seconds.append(time.perf_counter() - start)
    return config.batch / min(seconds)


def measure_phase(name: str, phase: Phase, config: BenchConfig) -> dict[str, Any]:
    """Time one phase of one model in this process; with ``config.memory`` also its peak RSS.

    Returns ``{"parameters", "windows_per_s", "peak_rss_mib", "peak_increase_mib"}``, or
    ``{"error": ...}`` when the model cannot take ``config.window``. The memory numbers mean what
    the module docstring says only in a fresh process (``bench_models`` runs one per phase).
    """
    phase = Phase(phase)
    torch.manual_seed(0)
    with torch_threads(config.threads):
        try:
            model = create_model(name, window=config.window)
        except ValueError as exc:
            return {"error": str(exc)}
        before = _peak_rss_bytes()
        if phase is Phase.INFERENCE:
            speed = windows_per_second(model, config.window, config.batch, None, config.repeats)
        else:
            speed = _training_windows_per_second(model, config)
        after = _peak_rss_bytes()
    result: dict[str, Any] = {"parameters": count_parameters(model), "windows_per_s": speed}
    if config.memory:
        result["peak_rss_mib"] = after / _MIB
        result["peak_increase_mib"] = max(0.0, after - before) / _MIB
    return result


def _phase_worker(connection: Connection, name: str, phase: Phase, config: BenchConfig) -> None:
    """Body of an isolated worker process: measure, send the result dict, exit."""
    try:
        result = measure_phase(name, phase, config)
    except Exception as exc:  # reported in the table's row, not as a crash of the whole bench
        result = {"error": f"{phase.value} failed: {type(exc).__name__}: {exc}"}
    connection.send(result)
    connection.close()


def _measure_isolated(name: str, phase: Phase, config: BenchConfig) -> dict[str, Any]:
    """``measure_phase`` in a fresh process forked from the fork server (module docstring)."""
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(list(_SERVER_PRELOAD))
    receiver, sender = context.Pipe(duplex=False)
    worker = context.Process(target=_phase_worker, args=(sender, name, phase, config), daemon=True)
    worker.start()
    sender.close()  # ours; the worker holds its own copy, so EOF means the worker is gone
    try:
        if not receiver.poll(config.timeout_s):
            worker.terminate()
            return {"error": f"{phase.value} timed out after {config.timeout_s:g} s"}
        try:
            return receiver.recv()
        except EOFError:
            worker.join()
            return {"error": f"{phase.value} failed: the worker exited with status {worker.exitcode}"}
    finally:
        worker.join()
        receiver.close()


# --- all models --------------------------------------------------------------------------------------


def _phase_result(data: dict[str, Any]) -> PhaseResult | None:
    if "error" in data:
        return None
    return PhaseResult(data["windows_per_s"], data.get("peak_rss_mib"), data.get("peak_increase_mib"))


def bench_model(name: str, config: BenchConfig) -> BenchResult:
    """Inference and training measurements of one model (see the module docstring)."""
    measure = _measure_isolated if config.memory else measure_phase
    data = {phase: measure(name, phase, config) for phase in Phase}
    errors = [d["error"] for d in data.values() if "error" in d]
    inference = _phase_result(data[Phase.INFERENCE])
    parameters = next((d["parameters"] for d in data.values() if "parameters" in d), None)
    rtf = None if inference is None else inference.windows_per_s * config.stride / config.rate_hz
    return BenchResult(
        model=name,
        window=config.window,
        parameters=parameters,
        inference=inference,
        training=_phase_result(data[Phase.TRAINING]),
        real_time_factor=rtf,
        error="; ".join(dict.fromkeys(errors)) or None,
    )


def bench_models(
    names: Sequence[str] | None = None,
    config: BenchConfig | None = None,
    on_model: Callable[[str], None] | None = None,
) -> list[BenchResult]:
    """``bench_model`` for each name (default: every registered model), one after the other, so that
    no two measurements share the CPU. Unknown names raise ``UnknownModelError`` before any work."""
    config = config or BenchConfig()
    names = list_models() if names is None else list(names)
    check_known_models(names)
    results = []
    for name in names:
        if on_model is not None:
            on_model(name)
        results.append(bench_model(name, config))
    return results


def machine_info(config: BenchConfig) -> dict[str, Any]:
    return {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "torch": torch.__version__,
        "threads": config.threads,
    }


def bench_json(results: Sequence[BenchResult], config: BenchConfig) -> dict[str, Any]:
    """The JSON document ``ftin bench --json`` writes (non-finite numbers as null)."""
    return to_json_safe(
        {
            "machine": machine_info(config),
            "config": asdict(config),
            "memory_method": MEMORY_METHOD if config.memory else None,
            "real_time_factor": f"inference windows/s x stride {config.stride} / {config.rate_hz:g} Hz",
            "models": [r.to_dict() for r in results],
        }
    )
