"""``ftin bench``: speed, real-time factor, peak memory and parameters of models side by side."""

from __future__ import annotations

import json
import math
import resource
import sys

import numpy as np
import pytest
import torch

from ftin.bench.profile import count_parameters
from ftin.bench.side_by_side import (
    BenchConfig,
    Phase,
    _training_windows_per_second,
    bench_json,
    bench_model,
    bench_models,
    measure_phase,
)
from ftin.models import UnknownModelError, create_model

# Two small reference models at a short window and a tiny batch keep every measurement well under
# a second; rnin cannot take 50-sample windows (it needs multiples of 100) and must say so.
TINY = BenchConfig(window=50, batch=4, threads=1, repeats=1, stride=10, rate_hz=100.0, memory=False)
MODELS = ["ronin_lstm", "ronin_tcn"]


def _peak_rss_mib() -> float:
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == "darwin" else peak / 1024.0


def test_speed_rtf_and_parameters_in_process():
    results = bench_models([*MODELS, "rnin"], TINY)
    assert [r.model for r in results] == [*MODELS, "rnin"]
    for r in results[:2]:
        assert r.error is None and r.window == 50
        assert r.parameters == count_parameters(create_model(r.model))
        for phase in (r.inference, r.training):
            assert math.isfinite(phase.windows_per_s) and phase.windows_per_s > 0
            assert phase.peak_rss_mib is None and phase.peak_increase_mib is None  # memory off
        # RTF: seconds of IMU per second of compute = windows/s x stride / rate
        assert r.real_time_factor == pytest.approx(r.inference.windows_per_s * 10 / 100.0)
    rnin = results[2]
    assert rnin.inference is None and rnin.training is None and rnin.real_time_factor is None
    assert "rnin" in rnin.error and "multiple of 100" in rnin.error

    data = bench_json(results, TINY)
    assert set(data) == {"machine", "config", "memory_method", "real_time_factor", "models"}
    assert data["config"]["batch"] == 4 and data["memory_method"] is None
    row = data["models"][0]
    assert set(row) == {"model", "window", "parameters", "inference", "training", "real_time_factor", "error"}
    assert set(row["inference"]) == {"windows_per_s", "peak_rss_mib", "peak_increase_mib"}
    json.dumps(data, allow_nan=False)  # strict JSON


def test_timed_training_steps_update_the_weights():
    """The training phase times real optimizer steps (a step that changed nothing would time nothing)."""
    torch.manual_seed(0)
    model = create_model("ronin_tcn")
    before = [p.detach().clone() for p in model.parameters()]
    speed = _training_windows_per_second(model, TINY)
    assert math.isfinite(speed) and speed > 0
    changed = [not torch.equal(b, p) for b, p in zip(before, model.parameters(), strict=True)]
    assert all(changed), f"{changed.count(False)} parameter tensors were not updated"
    assert measure_phase("ronin_tcn", Phase.TRAINING, TINY)["parameters"] == count_parameters(model)


def test_memory_in_a_fresh_process_is_not_the_parents():
    """Each phase runs in a process forked from a small fork server: its ru_maxrss must not carry the
    peak of this (deliberately inflated) test process, as a plain subprocess's would on Linux."""
    ballast = np.ones(96 * 2**20)  # 768 MiB, touched
    parent_peak = _peak_rss_mib()
    config = BenchConfig(window=50, batch=8, threads=1, repeats=1, memory=True, timeout_s=120.0)
    result = bench_model("ronin_lstm", config)
    del ballast
    assert result.error is None
    for phase in (result.inference, result.training):
        assert math.isfinite(phase.peak_rss_mib) and math.isfinite(phase.peak_increase_mib)
        assert 50.0 < phase.peak_rss_mib < parent_peak - 500.0  # the torch runtime, not 768 MiB more
        assert 0.0 <= phase.peak_increase_mib < phase.peak_rss_mib
    assert result.training.peak_rss_mib >= result.training.peak_increase_mib > 0.0  # Adam state at least


def test_bad_config_and_unknown_model():
    with pytest.raises(ValueError, match="batch must be >= 1"):
        BenchConfig(batch=0)
    with pytest.raises(ValueError, match="rate_hz must be > 0"):
        BenchConfig(rate_hz=0.0)
    with pytest.raises(UnknownModelError, match="no_such_model.*valid models"):
        bench_models(["ronin_lstm", "no_such_model"], TINY)
