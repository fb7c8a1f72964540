"""``ftin table``: the paper's Table 1 layout, its figures and JSON, on tiny untrained checkpoints."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

import ftin.cli.report  # noqa: F401  (registers `table` and `bench` until ftin.cli imports it)
from ftin.checkpoint import save_checkpoint
from ftin.cli import app
from ftin.cli.report import parse_dataset_options
from ftin.data.readers.generic_csv import write_csv
from ftin.metrics import Convention, describe
from ftin.models import create_model
from ftin.models.ftin_net import TINY_FTIN_KWARGS
from ftin.report import (
    PAPER_COLUMNS,
    ReportError,
    evaluate_checkpoints,
    find_checkpoints,
    load_checkpoints,
    load_datasets,
    paper_table,
    write_report,
)
from ftin.report.evaluation import representative_sequence
from ftin.report.render import improvement_percent
from ftin.sim import SimConfig, simulate

RATE_HZ = 50.0
WINDOW = 25
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
FTIN_TINY = {**TINY_FTIN_KWARGS, "window": WINDOW}
# Four of the table's nine models; ronin_lstm, rnin, imunet, tlio and resnet_tdl stay missing.
TINY_MODELS = {
    "ronin_resnet": {"window": WINDOW, "blocks_per_group": (1, 1, 1, 1), "trans_channels": 8, "fc_dim": 16},
    "ronin_tcn": {"channels": (8, 8)},
    "ftin": FTIN_TINY,
    "resnet_fdl": FTIN_TINY,
}
MISSING_LABELS = ["RoNIN LSTM", "RNIN", "IMUNet", "TLIO", "+TDL"]


@pytest.fixture(scope="module")
def checkpoint_dir(tmp_path_factory):
    directory = tmp_path_factory.mktemp("checkpoints")
    for i, (name, kwargs) in enumerate(TINY_MODELS.items()):
        torch.manual_seed(i)
        meta = {
            "model_name": name,
            "imu_rate_hz": RATE_HZ,
            "window": WINDOW,
            "stride": 5,
            "training_data": {"paths": ["sim/train"]},
        }
        save_checkpoint(directory / f"{name}_sim", create_model(name, **kwargs), meta)
    # Files of a training run folder that are no checkpoint pair must be skipped.
    (directory / "config.json").write_text("{}")
    (directory / "resume.safetensors").write_bytes(b"")
    return directory


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory):
    """Two datasets: "walk" (two sequences in one folder) and "pocket" (two files given separately)."""
    root = tmp_path_factory.mktemp("data")
    (root / "walk").mkdir()
    for seed in (1, 2):
        write_csv(
            simulate(SimConfig(duration_s=12.0, rate_hz=RATE_HZ, seed=seed)), root / "walk" / f"w{seed}.csv"
        )
    for seed in (3, 4):
        seq = simulate(SimConfig(duration_s=12.0, rate_hz=RATE_HZ, carry="pocket", seed=seed))
        write_csv(seq, root / f"pocket{seed}.csv")
    return root


def dataset_options(data_dir) -> list[str]:
    return [
        f"walk={data_dir / 'walk'}",
        f"pocket={data_dir / 'pocket3.csv'}",
        f"pocket={data_dir / 'pocket4.csv'}",
    ]


@pytest.fixture(scope="module")
def results(checkpoint_dir, data_dir):
    checkpoints = load_checkpoints(find_checkpoints(checkpoint_dir))
    datasets = load_datasets(parse_dataset_options(dataset_options(data_dir)))
    calls = []
    results = evaluate_checkpoints(checkpoints, datasets, on_evaluation=lambda *args: calls.append(args))
    results.calls = calls  # the progress callback's record, for the test below
    return results


@pytest.fixture(scope="module")
def report_dir(results, tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    write_report(results, out)
    return out


def test_parse_dataset_options_merges_repeated_names(tmp_path):
    specs = parse_dataset_options(["OxIOD=a/imu1.csv", "EuRoC=b", "OxIOD=a/imu2.csv"])
    assert [s.name for s in specs] == ["OxIOD", "EuRoC"]
    assert [str(p) for p in specs[0].paths] == ["a/imu1.csv", "a/imu2.csv"]
    for bad in ("OxIOD", "=path", "OxIOD="):
        with pytest.raises(ReportError, match="expected NAME=PATH"):
            parse_dataset_options([bad])
    with pytest.raises(ReportError, match="no such folder"):
        find_checkpoints(tmp_path / "nope")
    with pytest.raises(ReportError, match="no checkpoints there"):
        find_checkpoints(tmp_path)


def test_every_pair_evaluated_once(results, data_dir):
    assert sorted(c.model_name for c in results.checkpoints) == sorted(TINY_MODELS)
    assert results.sequence_names == {"walk": ["w1", "w2"], "pocket": ["pocket3", "pocket4"]}
    assert len(results.calls) == len(TINY_MODELS) * 4 == len(set(results.calls))
    for c in results.checkpoints:
        assert list(c.reports) == ["walk", "pocket"]
        report = c.reports["walk"]
        assert report.convention is Convention.RONIN
        assert report.mean.ate == pytest.approx(np.mean([r.metrics.ate for r in report.sequences]))
        # trajectories are kept for the figure models only
        assert bool(c.trajectories) == (c.model_name in ("ftin", "ronin_resnet"))


def test_table_layout_and_percentage(results, report_dir):
    table = paper_table(results)
    assert [(r.dataset, r.metric) for r in table.rows] == [
        ("walk", "ATE"),
        ("walk", "RTE"),
        ("walk", "Path ratio"),
        ("pocket", "ATE"),
        ("pocket", "RTE"),
        ("pocket", "Path ratio"),
    ]
    labels = [c.label for c in PAPER_COLUMNS]
    assert [c.label for c in table.missing] == MISSING_LABELS
    resnet = next(c for c in results.checkpoints if c.model_name == "ronin_resnet")
    ftin = next(c for c in results.checkpoints if c.model_name == "ftin")
    for row in table.rows:
        cells = dict(zip(labels, row.cells, strict=True))
        mean_r, mean_f = resnet.reports[row.dataset].mean, ftin.reports[row.dataset].mean
        still = results.stand_still[row.dataset]
        attr = {"ATE": "ate", "RTE": "rte", "Path ratio": "path_length_ratio"}[row.metric]
        r, f = getattr(mean_r, attr), getattr(mean_f, attr)
        assert cells["RoNIN ResNet"] == r and cells["FTIN"] == f and cells["+FDL&TDL"] == f
        assert cells["Stand still"] == getattr(still, attr)
        if row.metric == "Path ratio":
            assert cells["Stand still"] == 0.0 and cells["FTIN vs RoNIN ResNet"] is None
        else:
            assert cells["FTIN vs RoNIN ResNet"] == pytest.approx(100.0 * (r - f) / r)
        assert all(cells[label] is None for label in MISSING_LABELS)
    # the stand-still baseline: standing at each recording's start, scored like the models
    walk_truths = results.ground_truth["walk"].values()
    expected = np.mean(
        [np.sqrt(np.mean((gt.p_world_m[:, :2] - gt.p_world_m[0, :2]) ** 2)) for gt in walk_truths]
    )
    assert results.stand_still["walk"].ate == pytest.approx(expected)

    md = (report_dir / "table.md").read_text()
    assert describe(Convention.RONIN) in md
    assert "ronin_resnet_sim" in md and "sim/train" in md and "walk: 2 sequences" in md
    assert "No checkpoint for: RoNIN LSTM (`ronin_lstm`)" in md
    table_lines = [line for line in md.splitlines() if line.startswith("|")]
    assert table_lines[0] == "| Dataset | Metric | " + " | ".join(labels) + " |"
    assert len(table_lines) == 2 + 6
    walk_ate = [cell.strip() for cell in table_lines[2].strip("|").split("|")]
    walk_rte = [cell.strip() for cell in table_lines[3].strip("|").split("|")]
    assert walk_ate[:2] == ["walk", "ATE"] and walk_rte[:2] == ["", "RTE"]
    row = table.rows[0]
    cells = dict(zip(labels, walk_ate[2:], strict=True))
    assert cells["RoNIN LSTM"] == "—" and cells["+TDL"] == "—"
    assert cells["FTIN vs RoNIN ResNet"] == f"{row.cells[labels.index('FTIN vs RoNIN ResNet')]:.1f}%"
    assert cells["Stand still"] == f"{row.cells[0]:.3f}"  # a reference, never bold
    # bold: the lowest of the compared models, and separately of the ablation columns
    groups = {c.label: c.group.value for c in PAPER_COLUMNS}
    compared = {
        lab: v
        for lab, v in zip(labels, row.cells, strict=True)
        if groups[lab] == "compared" and v is not None
    }
    best = min(compared, key=compared.get)
    assert cells[best] == f"**{compared[best]:.3f}**"
    assert sum(cells[lab].startswith("**") for lab in compared) == 1
    ablation = {
        lab: v
        for lab, v in zip(labels, row.cells, strict=True)
        if groups[lab] == "ablation" and v is not None
    }
    assert sum(cells[lab].startswith("**") for lab in ablation) == 1
    assert cells[min(ablation, key=ablation.get)].startswith("**")

    rows = list(csv.reader(io.StringIO((report_dir / "table.csv").read_text())))
    assert rows[0][:4] == ["dataset", "metric", "Stand still", "RoNIN ResNet"]
    assert "FTIN vs RoNIN ResNet (%)" in rows[0]
    assert len(rows) == 7
    first = dict(zip(rows[0], rows[1], strict=True))
    assert first["RoNIN LSTM"] == "" and float(first["FTIN"]) == row.cells[labels.index("FTIN")]
    r, f = float(first["RoNIN ResNet"]), float(first["FTIN"])
    assert float(first["FTIN vs RoNIN ResNet (%)"]) == pytest.approx(100 * (r - f) / r)


def test_results_json_and_figures(results, report_dir):
    data = json.loads((report_dir / "results.json").read_text())
    assert data["convention"] == "ronin" and data["description"] == describe(Convention.RONIN)
    assert [d["name"] for d in data["datasets"]] == ["walk", "pocket"]
    by_name = {c["name"]: c for c in data["checkpoints"]}
    ftin = by_name["ftin_sim"]["results"]["pocket"]
    assert [s["name"] for s in ftin["sequences"]] == ["pocket3", "pocket4"]
    assert ftin["mean"]["pde"] == pytest.approx(np.mean([s["pde"] for s in ftin["sequences"]]))
    assert data["table"]["missing_columns"] == MISSING_LABELS
    assert data["representative_sequences"] == {
        name: representative_sequence(results, name) for name in ("walk", "pocket")
    }
    for name in ("pde.png", "trajectories.png"):
        blob = (report_dir / name).read_bytes()
        assert blob.startswith(PNG_SIGNATURE) and len(blob) > 5000


def test_improvement_percent():
    assert improvement_percent(6.799, 3.875) == pytest.approx(43.0, abs=0.05)  # the paper's RoNIN ATE
    assert improvement_percent(1.445, 1.479) == pytest.approx(-2.4, abs=0.05)  # FTIN worse: negative
    assert improvement_percent(None, 1.0) is None and improvement_percent(0.0, 1.0) is None


@pytest.fixture
def two_of_one_model(tmp_path):
    """``tcn-oxiod`` and ``tcn-sim``: two checkpoints for the RoNIN TCN column."""
    directory = tmp_path / "checkpoints"
    for i, name in enumerate(("tcn-oxiod", "tcn-sim")):
        torch.manual_seed(i)
        meta = {"model_name": "ronin_tcn", "imu_rate_hz": RATE_HZ, "window": WINDOW, "stride": 5}
        save_checkpoint(directory / name, create_model("ronin_tcn", channels=(8,)), meta)
    return directory


def test_duplicate_model_is_an_error_unless_a_pattern_selects(two_of_one_model, checkpoint_dir):
    with pytest.raises(ReportError, match="2 checkpoints of model 'ronin_tcn'.*--pattern"):
        load_checkpoints(find_checkpoints(two_of_one_model))
    assert [p.name for p in find_checkpoints(two_of_one_model, ["*-oxiod"])] == ["tcn-oxiod"]
    assert [m.name for m in load_checkpoints(find_checkpoints(two_of_one_model, ["*-sim"]))] == ["tcn-sim"]
    # several patterns: any may match; a pattern matching nothing names what is there
    both = find_checkpoints(checkpoint_dir, ["ronin_*", "ftin_sim"])
    assert [p.name for p in both] == ["ftin_sim", "ronin_resnet_sim", "ronin_tcn_sim"]
    with pytest.raises(
        ReportError, match=r"--pattern '\*-OXIOD' matches no checkpoint.*there: tcn-oxiod, tcn-sim"
    ):
        find_checkpoints(two_of_one_model, ["*-OXIOD"])


runner = CliRunner()


def test_cli_table(checkpoint_dir, data_dir, tmp_path):
    options = [arg for value in dataset_options(data_dir)[:2] for arg in ("--dataset", value)]
    out = tmp_path / "report"
    result = runner.invoke(
        app,
        ["table", "--checkpoints", str(checkpoint_dir), *options, "--out", str(out), "--convention", "se2"],
    )
    assert result.exit_code == 0, result.output
    for name in ("table.md", "table.csv", "results.json", "pde.png", "trajectories.png"):
        assert (out / name).stat().st_size > 0
    assert describe(Convention.SE2) in (out / "table.md").read_text()
    assert json.loads((out / "results.json").read_text())["convention"] == "se2"
    assert "table.md" in result.output


def test_cli_table_pattern(two_of_one_model, data_dir, tmp_path):
    dataset = f"pocket={data_dir / 'pocket3.csv'}"
    out = tmp_path / "report"
    base = ["table", "--checkpoints", str(two_of_one_model), "--dataset", dataset, "--out", str(out)]
    result = runner.invoke(app, base)
    assert result.exit_code == 2 and result.output.count("\n") == 1, result.output
    assert "2 checkpoints of model 'ronin_tcn'" in result.output and not out.exists()

    result = runner.invoke(app, [*base, "--pattern", "*-oxiod"])
    assert result.exit_code == 0, result.output
    data = json.loads((out / "results.json").read_text())
    assert [c["name"] for c in data["checkpoints"]] == ["tcn-oxiod"]
    assert "`tcn-oxiod`" in (out / "table.md").read_text() and "tcn-sim" not in (out / "table.md").read_text()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--checkpoints", "{tmp}/missing", "--dataset", "x={data}"], "no such folder"),
        (
            ["--checkpoints", "{ckpt}", "--dataset", "x={data}", "--pattern", "*-euroc"],
            "matches no checkpoint",
        ),
        (["--checkpoints", "{ckpt}", "--dataset", "no-equals-sign"], "expected NAME=PATH"),
        (["--checkpoints", "{ckpt}", "--dataset", "x={tmp}/nothing.csv"], "no such file"),
    ],
)
def test_cli_table_bad_input(args, message, checkpoint_dir, data_dir, tmp_path):
    args = [a.format(tmp=tmp_path, data=data_dir / "walk", ckpt=checkpoint_dir) for a in args]
    result = runner.invoke(app, ["table", *args, "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0], result.output
    assert not (tmp_path / "out").exists()
