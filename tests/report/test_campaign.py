"""Table 1 from campaign records: seeds, stand-still row, paired bootstrap difference, variants."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ftin.report.campaign import load_results, paired_difference, per_seed_means, render
from tests.utils.tables import campaign_record, write_campaign_results


@pytest.fixture
def folder(tmp_path):
    return write_campaign_results(tmp_path)


def test_per_seed_means_keep_variants_apart_and_add_stand_still(folder):
    results, _ = load_results(folder)
    means = per_seed_means(results, "oxiod", "test", "ground_truth")
    assert means["ftin"][0]["ate"] == pytest.approx(1.1) and means["ftin"][1]["ate"] == pytest.approx(1.2)
    assert means["ftin_other"][0]["ate"] == pytest.approx(5.0)
    still = means["stand_still"][-1]
    assert {k: still[k] for k in ("ate", "rte", "pde", "path_length_ratio")} == {
        "ate": 2.0,
        "rte": 2.5,
        "pde": 0.5,
        "path_length_ratio": 0.0,
    }
    assert still["ate_euclidean"] is None  # a record written before the metric existed: no number made up


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


def test_render_opens_with_the_paper_layout_of_the_test_results(folder):
    results, manifest = load_results(folder)
    md, _, _ = render(results, manifest)
    layout = md.split("## Test recordings, in the layout of the paper's Table 1")[1].split("\n## ")[0]
    ate_row = next(line for line in layout.splitlines() if "| ATE |" in line)
    cells = [c.strip() for c in ate_row.strip("|").split("|")]
    header = next(line for line in layout.splitlines() if line.startswith("| Dataset"))
    column = {name.strip(): i for i, name in enumerate(header.strip("|").split("|"))}
    assert cells[column["Stand still"]] == "2.000"
    assert cells[column["FTIN"]] == "**1.150 ± 0.071**"  # best compared model (lowest mean)
    assert cells[column["RoNIN ResNet"]] == "1.600 ± 0.071"
    assert cells[column["FTIN vs RoNIN ResNet"]] == "28.1%"  # (1.60 - 1.15) / 1.60
    assert cells[column["RoNIN LSTM"]] == "3.000 †" and "† not shipped" in layout
    assert cells[column["RoNIN TCN"]] == "—"


def test_phone_only_rows_follow_ground_truth_and_device(folder):
    results, manifest = load_results(folder)
    for result in results:  # as a job of the second campaign scores itself: a phone alone, too
        parts = result.record["evaluation"]["parts"]
        for key in [k for k in parts if k.endswith("/device")]:
            parts[key.replace("/device", "/phone_only")] = [
                {**row, "ate": 2 * row["ate"]} for row in parts[key]
            ]
    md, _, summary = render(results, manifest)
    layout = md.split("## Test recordings, in the layout of the paper's Table 1")[1].split("\n## ")[0]
    sources = [line.split("|")[2].strip() for line in layout.splitlines() if line.startswith("| OxIOD")]
    assert sources == ["ground truth", "device", "phone only"]
    assert summary["datasets"]["oxiod"]["test/phone_only"]["ftin"]["ate"]["mean"] == pytest.approx(2 * 1.15)
    assert "### OxIOD, test, phone only (no attitude" in md


def test_a_walking_model_fills_an_inria_column_and_a_row_of_its_own(folder):
    walking = campaign_record("ftin", "walking", 0, (0.5, 0.7), "ordered")
    walking["evaluation"]["parts"] = {  # a walking job is scored on every member's parts
        key.replace("walking", member): rows
        for key, rows in walking["evaluation"]["parts"].items()
        for member in ("oxiod", "ridi", "inria")
    }
    (folder / "walking__ftin-ordered-s0.json").write_text(json.dumps(walking))
    results, manifest = load_results(folder)
    md, _, summary = render(results, manifest)
    assert summary["datasets"]["inria"]["test/ground_truth"]["ftin-walking"]["ate"]["mean"] == 0.6
    assert "### Inria attitude benchmark, test, ground-truth orientation" in md  # the reader's LABEL
    assert "| FTIN-walking (every walking dataset) | 1 | 0.600 |" in md
    layout = md.split("## Test recordings, in the layout of the paper's Table 1")[1].split("\n## ")[0]
    ate_rows = [
        [c.strip() for c in line.strip("|").split("|")] for line in layout.splitlines() if "| ATE |" in line
    ]
    assert ate_rows[-1][0] == "Inria attitude benchmark"
    header = next(line for line in layout.splitlines() if line.startswith("| Dataset"))
    column = [name.strip() for name in header.strip("|").split("|")].index("FTIN-walking")
    assert ate_rows[-1][column] == "**0.600**"  # the only pedestrian column: best of its group


def test_the_default_gets_its_column_marked_and_its_phone_only_cost_stated(folder):
    walking = campaign_record("ronin_resnet", "walking", 0, (0.5, 0.7))
    parts = walking["evaluation"]["parts"]
    parts = {key.replace("walking", "inria"): rows for key, rows in parts.items()}
    parts["inria/test/phone_only"] = [
        {**row, "ate": 1.5 * row["ate"]} for row in parts["inria/test/ground_truth"]
    ]
    walking["evaluation"]["parts"] = parts
    (folder / "walking__ronin_resnet-s0.json").write_text(json.dumps(walking))
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["default"] = {"model": "ronin_resnet-walking", "source": "phone_only"}
    (folder / "manifest.json").write_text(json.dumps(manifest))
    results, manifest = load_results(folder)
    md, _, summary = render(results, manifest)
    assert "| RoNIN ResNet-walking (default) |" in md.split("\n## Per dataset")[0]
    assert summary["default"]["phone_only_over_ground_truth"] == {"inria": pytest.approx(1.5)}
    assert "The app's default, `ronin_resnet-walking`" in md and "Inria attitude benchmark 1.50x" in md


def test_each_part_folds_out_every_recordings_path_ratio(folder):
    results, manifest = load_results(folder)
    for result in results:  # recording "b" of FTIN's seed 1 walks short
        if result.job == "oxiod/ftin-s1":
            for row in result.record["evaluation"]["parts"]["oxiod/test/ground_truth"]:
                row["path_length_ratio"] = 0.5 if row["name"] == "b" else row["path_length_ratio"]
    md, _, _ = render(results, manifest)
    block = md.split("### OxIOD, test, ground-truth orientation")[1].split("###")[0]
    table = block.split("<summary>Path ratio per recording (mean over seeds)</summary>")[1]
    header = [c.strip() for c in table.strip().splitlines()[0].strip("|").split("|")]
    cells = {
        line.split("|")[1].strip(): [c.strip() for c in line.strip("|").split("|")]
        for line in table.splitlines()
        if line.startswith(("| a ", "| b "))
    }
    ftin = header.index("FTIN")
    assert cells["a"][ftin] == "0.90" and cells["b"][ftin] == "0.70"  # (0.9 + 0.5) / 2
