"""``ftin bench``'s product benchmarks: the memory measurement in-process and its launcher, the options'
checks, and the subcommands registered without loading the app."""

from __future__ import annotations

import pytest

from ftin.bench import memory
from ftin.bench.options import HourOptions, LiveDrawingOptions, LoadOptions, PredictOptions
from ftin.cli import app
from tests.utils.cli import runner


def test_memory_measure_in_process_and_describe():
    result = memory.measure(memory.MemoryConfig(minutes=0.05, batch_size=64), materialised=False)
    assert result["windows"] > 0 and result["after_peak_rss_mib"] >= result["baseline_peak_rss_mib"] > 0
    lines = memory.describe([result])
    assert "streamed: peak RSS" in lines[-1] and "windows of 100 samples" in lines[0]


@pytest.mark.parametrize("bad", [{"minutes": 0}, {"batch_size": 0}, {"threads": 0}])
def test_memory_config_refuses_nonsense(bad):
    with pytest.raises(ValueError):
        memory.MemoryConfig(**bad)


def test_product_options_refuse_nonsense():
    with pytest.raises(ValueError, match="--runs"):
        PredictOptions(runs=0)
    with pytest.raises(ValueError, match="--clients"):
        LoadOptions(clients=0)
    with pytest.raises(ValueError, match="--minutes"):
        HourOptions(minutes=0)
    with pytest.raises(ValueError, match="--updates"):
        LiveDrawingOptions(updates=0)


def test_live_drawing_times_the_same_updates_at_each_mark():
    """A short run of the real scene: a row per minute mark, the ratio to the first mark."""
    marks = ["--minutes", "0.5", "--minutes", "1", "--updates", "3", "--warmup", "1"]
    result = runner.invoke(app, ["bench", "live-drawing", *marks])
    assert result.exit_code == 0, result.output
    rows = [
        line for line in result.output.splitlines() if line.startswith("| 0.5 |") or line.startswith("| 1 |")
    ]
    assert len(rows) == 2 and rows[0].endswith("| 1.00 |")


def test_hour_puts_the_upload_beside_the_plain_forward_pass():
    """Twelve seconds of phone data through a real server in a subprocess: every stage and the upload
    are measured beside the reference pass, the server's memory growth is read."""
    result = runner.invoke(app, ["bench", "hour", "--minutes", "0.2"])
    assert result.exit_code == 0, result.output
    out = result.output
    assert "| reference: one fp32 forward pass, one copy, one thread (mean of" in out and "| 1.00 |" in out
    assert "POST /predict, whole round trip" in out and "stage: read the CSV" in out
    assert "looks per sample" in out and "server peak memory growth during the upload:" in out


def test_bench_subcommands_listed_without_the_app():
    result = runner.invoke(app, ["bench", "--help"])
    assert result.exit_code == 0, result.output
    for name in ("memory", "yaw-copies", "predict", "live", "live-drawing", "hour", "scene", "load"):
        assert name in result.output


def test_bench_product_bad_option_is_one_error_line():
    result = runner.invoke(app, ["bench", "predict", "--runs", "0"])
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and "--runs" in lines[0], result.output
