"""Table 1 from campaign records: seeds, stand-still row, paired bootstrap difference, variants."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import ftin.cli.report  # noqa: F401  (registers the command)
from ftin.cli import app
from ftin.report.campaign import load_results, paired_difference, per_seed_means, render

RECORDINGS = ("a", "b")


def _record(model, dataset, seed, ates, variant=None):
    rows = [
        {
            "name": name,
            "duration_s": 60.0,
            "ate": ate,
            "rte": ate / 2,
            "pde": 0.01,
            "path_length_ratio": 0.9,
            "stand_still": {"ate": 2.0, "rte": 2.5, "pde": 0.5},
        }
        for name, ate in zip(RECORDINGS, ates, strict=True)
    ]
    parts = {f"{dataset}/{part}/{o}": rows for part in ("val", "test") for o in ("ground_truth", "device")}
    training = {
        "job": f"{dataset}/{model}-s{seed}",
        "model": model,
        "dataset": dataset,
        "seed": seed,
        "variant": variant,
        "best_val_mse": 0.01,
    }
    return {"training": training, "history": [], "evaluation": {"parts": parts}}


@pytest.fixture
def folder(tmp_path):
    records = [
        _record("ftin", "oxiod", 0, (1.0, 1.2), "ordered"),
        _record("ftin", "oxiod", 1, (1.1, 1.3), "ordered"),
        _record("ftin", "oxiod", 0, (5.0, 5.0), "mixed"),  # the variant validation did not choose
        _record("ronin_resnet", "oxiod", 0, (1.5, 1.6)),
        _record("ronin_resnet", "oxiod", 1, (1.4, 1.9)),
        _record("ronin_lstm", "oxiod", 0, (3.0, 3.0)),
    ]
    for i, record in enumerate(records):
        (tmp_path / f"oxiod__{i}.json").write_text(json.dumps(record))
    (tmp_path / "manifest.json").write_text(json.dumps({"ftin_variant": "ordered"}))
    return tmp_path


def test_per_seed_means_keep_variants_apart_and_add_stand_still(folder):
    results, _ = load_results(folder)
    means = per_seed_means(results, "oxiod", "test", "ground_truth")
    assert means["ftin"][0]["ate"] == pytest.approx(1.1) and means["ftin"][1]["ate"] == pytest.approx(1.2)
    assert means["ftin_other"][0]["ate"] == pytest.approx(5.0)
    assert means["stand_still"][-1] == {"ate": 2.0, "rte": 2.5, "pde": 0.5, "path_length_ratio": 0.0}


def test_paired_difference_pairs_seed_and_recording(folder):
    results, _ = load_results(folder)
    diff = paired_difference(results, "oxiod", "test", "ground_truth")
    expected = np.mean([1.0 - 1.5, 1.2 - 1.6, 1.1 - 1.4, 1.3 - 1.9])
    assert diff["mean"] == pytest.approx(expected) and diff["pairs"] == 4 and diff["seeds"] == [0, 1]
    assert diff["ci95"][0] <= expected <= diff["ci95"][1]


def test_render_shows_mean_sd_seeds_and_stand_still(folder):
    results, manifest = load_results(folder)
    md, csv_text, summary = render(results, manifest)
    assert "| FTIN | 2 | 1.150 ± 0.071 |" in md
    assert "| Stand still (never moves) | — | 2.000 |" in md
    assert "FTIN, other TDL variant (seed 0)" in md and "FTIN − RoNIN ResNet" in md
    cell = summary["datasets"]["oxiod"]["test/ground_truth"]["ronin_lstm"]
    assert cell["ate"] == {"mean": 3.0, "sd": None, "n": 1}
    assert csv_text.splitlines()[0].startswith("dataset,part,orientation,model,seeds,ate_mean")


def test_table_command_with_campaign(folder, tmp_path):
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["table", "--campaign", str(folder), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert {p.name for p in out.iterdir()} == {
        "table.md",
        "table.csv",
        "campaign_results.json",
        "campaign_ate.png",
    }


def test_table_command_needs_checkpoints_or_campaign(tmp_path):
    result = CliRunner().invoke(app, ["table", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "--campaign" in result.stderr
