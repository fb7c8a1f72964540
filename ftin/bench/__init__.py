"""Benchmarks of the models on this machine, as a library; ``ftin models`` and ``ftin bench`` print them.

* ``ftin.bench.profile``: size and speed of one model at a window — parameters, FLOPs per window
  (with the formulas PyTorch lacks), measured eval-mode windows/s (``ftin models``);
* ``ftin.bench.side_by_side``: every model's inference and training windows/s, real-time factor and
  peak memory, each phase in its own forked process (``ftin bench``).

The scripts ``scripts/bench_predict.py``, ``scripts/bench_memory.py`` and ``scripts/load_test.py``
measure the product end to end (the REST upload round trip, the peak memory of one long prediction in
a fresh process, the server under concurrent clients); they start servers and processes, so they stay
scripts and use this package for what they share with it (``peak_rss_mib``).
"""

from ftin.bench.profile import (
    DEFAULT_WINDOW,
    ModelProfile,
    count_parameters,
    flops_per_window,
    profile_model,
    profile_models,
    torch_threads,
    windows_per_second,
)
from ftin.bench.side_by_side import (
    MEMORY_METHOD,
    BenchConfig,
    BenchResult,
    Phase,
    PhaseResult,
    bench_json,
    bench_model,
    bench_models,
    measure_phase,
    peak_rss_mib,
)

__all__ = [
    "DEFAULT_WINDOW",
    "MEMORY_METHOD",
    "BenchConfig",
    "BenchResult",
    "ModelProfile",
    "Phase",
    "PhaseResult",
    "bench_json",
    "bench_model",
    "bench_models",
    "count_parameters",
    "flops_per_window",
    "measure_phase",
    "peak_rss_mib",
    "profile_model",
    "profile_models",
    "torch_threads",
    "windows_per_second",
]
