"""``ftin bench``'s product benchmarks: the memory measurement in-process and its launcher, the options'
checks, and the subcommands registered without loading the app."""

from __future__ import annotations

import pytest

from ftin.bench import memory
from ftin.bench.options import LoadOptions, PredictOptions
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


def test_bench_subcommands_listed_without_the_app():
    result = runner.invoke(app, ["bench", "--help"])
    assert result.exit_code == 0, result.output
    for name in ("memory", "yaw-copies", "predict", "live", "scene", "load"):
        assert name in result.output


def test_bench_product_bad_option_is_one_error_line():
    result = runner.invoke(app, ["bench", "predict", "--runs", "0"])
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and "--runs" in lines[0], result.output
