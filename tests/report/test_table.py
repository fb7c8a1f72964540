"""``ftin table``: the paper's Table 1 layout, its figures and JSON, on tiny untrained checkpoints."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest

from ftin.cli.table import parse_dataset_options
from ftin.metrics import Convention, describe, list_metrics
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
from tests.utils.tables import TINY_MODELS, dataset_options

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
MISSING_LABELS = ["RoNIN LSTM", "RNIN", "IMUNet", "TLIO", "+TDL"]


@pytest.fixture(scope="module")
def results(table_checkpoints, table_data):
    checkpoints = load_checkpoints(find_checkpoints(table_checkpoints))
    datasets = load_datasets(parse_dataset_options(dataset_options(table_data)))
    calls = []
    # The networks alone: made equivariant (turned copies, cycled turns), these untrained models
    # score alike (ties in the bold column), and a table of ties would not test its layout.
    alone = {"yaw_copies": 1, "cyclic_turns": False}
    results = evaluate_checkpoints(
        checkpoints, datasets, on_evaluation=lambda *args: calls.append(args), **alone
    )
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


def test_every_pair_evaluated_once(results, table_data):
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
        # each recording's uncertainty against its truth, as ftin evaluate reports it (the campaign's
        # job records carry it too: ftin.campaign.job.part_rows)
        for r in report.sequences:
            assert r.coverage is not None and r.coverage.samples > 0 and 0.0 <= r.coverage.share_2sigma <= 1.0


def test_table_layout_and_percentage(results, report_dir):
    table = paper_table(results)
    shown = list_metrics(in_tables=True)  # one row per registered table metric and dataset
    assert [(r.dataset, r.metric, r.name) for r in table.rows] == [
        (dataset, m.label, m.name) for dataset in ("walk", "pocket") for m in shown
    ]
    assert [m.label for m in shown][:2] == ["ATE", "ATE evo"]  # both ATE conventions, labelled
    labels = [c.label for c in PAPER_COLUMNS]
    assert [c.label for c in table.missing] == MISSING_LABELS
    resnet = next(c for c in results.checkpoints if c.model_name == "ronin_resnet")
    ftin = next(c for c in results.checkpoints if c.model_name == "ftin")
    for row in table.rows:
        cells = dict(zip(labels, row.cells, strict=True))
        mean_r, mean_f = resnet.reports[row.dataset].mean, ftin.reports[row.dataset].mean
        still = results.stand_still[row.dataset]
        r, f = mean_r[row.name], mean_f[row.name]
        assert cells["RoNIN ResNet"] == r and cells["FTIN"] == f and cells["+FDL&TDL"] == f
        assert cells["Stand still"] == still[row.name]
        if row.name == "path_length_ratio":
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
    assert "ronin_resnet_sim" in md and "trained on sim (1 recording)" in md and "walk: 2 sequences" in md
    assert "No checkpoint for: RoNIN LSTM (`ronin_lstm`)" in md
    table_lines = [line for line in md.splitlines() if line.startswith("|")]
    assert table_lines[0] == "| Dataset | Metric | " + " | ".join(labels) + " |"
    assert len(table_lines) == 2 + 2 * len(shown)
    walk_ate = [cell.strip() for cell in table_lines[2].strip("|").split("|")]
    walk_evo = [cell.strip() for cell in table_lines[3].strip("|").split("|")]
    assert walk_ate[:2] == ["walk", "ATE"] and walk_evo[:2] == ["", "ATE evo"]  # the dataset named once
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
    assert len(rows) == 1 + len(table.rows)
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


def test_duplicate_model_is_an_error_unless_a_pattern_selects(two_of_one_model, table_checkpoints):
    with pytest.raises(ReportError, match="2 checkpoints of model 'ronin_tcn'.*--pattern"):
        load_checkpoints(find_checkpoints(two_of_one_model))
    assert [p.name for p in find_checkpoints(two_of_one_model, ["*-oxiod"])] == ["tcn-oxiod"]
    assert [m.name for m in load_checkpoints(find_checkpoints(two_of_one_model, ["*-sim"]))] == ["tcn-sim"]
    # several patterns: any may match; a pattern matching nothing names what is there
    both = find_checkpoints(table_checkpoints, ["ronin_*", "ftin_sim"])
    assert [p.name for p in both] == ["ftin_sim", "ronin_resnet_sim", "ronin_tcn_sim"]
    with pytest.raises(
        ReportError, match=r"--pattern '\*-OXIOD' matches no checkpoint.*there: tcn-oxiod, tcn-sim"
    ):
        find_checkpoints(two_of_one_model, ["*-OXIOD"])
