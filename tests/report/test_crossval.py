"""Walker-wise cross-validation of the generalisation campaign, on synthetic records: pairing, the
walker-clustered bootstrap against a per-pair one, the tables, the files and the command."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from ftin.cli import app
from ftin.protocol import walker
from ftin.report.crossval import (
    A_BETTER,
    NO_DIFFERENCE,
    Score,
    carry_of,
    carry_table,
    crossval_summary,
    load_fold_runs,
    pairs,
    validation_scores,
)
from ftin.report.crossval_render import crossval_report
from tests.utils.cli import fails_cleanly, runner

A, B = "ftin-ordered-yaw", "ronin_resnet-yaw"
STILL = 6.0  # stand-still ATE of every synthetic recording
# Validation recordings of each fold, named as the real ones are; ten walkers in all, as the protocol's:
# OxIOD user1, trolley-data1 | user2, trolley-data2; RIDI dan | hang, hao, ma; Inria Guillaume | Thibaud.
FOLD_RECORDINGS = {
    0: {
        "oxiod": ["handheld/data1/imu2", "handheld/data1/imu3", "trolley/data1/imu7"],
        "ridi": ["dan_bag1", "dan_body3"],
        "inria": [
            "Guillaume_Nexus5_NoDist_AR",
            "Guillaume_iPhone5_Dist_Texting",
            "Guillaume_Nexus5_Dist_Swinging",
        ],
    },
    1: {
        "oxiod": ["multi users/user2/imu4", "multi users/user2/imu5", "trolley/data2/imu3"],
        "ridi": ["hang_bag_side1", "hao_body1", "ma_handheld3"],
        "inria": ["Thibaud_Nexus5_NoDist_AR", "Thibaud_iPhone5_Dist_Texting", "Thibaud_Nexus5_Dist_Swinging"],
    },
}
WALKER_NAMES = sorted(
    {
        walker(dataset, name)
        for fold in FOLD_RECORDINGS.values()
        for dataset, names in fold.items()
        for name in names
    }
)
WALKERS = len(WALKER_NAMES)
WOBBLE = {name: 0.05 * (-1) ** i for i, name in enumerate(WALKER_NAMES)}  # each walker 0.05 m off, up or down

AteOf = Callable[[str, int, int, str, str, str], float]  # (arm, fold, seed, dataset, recording, orientation)


def baseline_ate(arm: str, fold: int, seed: int, dataset: str, recording: str, orientation: str) -> float:
    """Arm b's ATE: differs per seed, recording and orientation, so a wrong pairing shows."""
    return 3.0 + 0.3 * seed + 0.01 * len(recording) + (0.4 if orientation == "device" else 0.0)


def write_record(
    folder: Path,
    arm: str,
    fold: int,
    seed: int,
    ate_of: AteOf,
    skip: tuple[str, ...] = (),
    best_val_mse: float = 0.05,
) -> None:
    """One collected job record; its test parts hold 99 m everywhere (the report must never read them)."""
    parts = {}
    for dataset, recordings in FOLD_RECORDINGS[fold].items():
        for orientation in ("ground_truth", "device"):
            parts[f"{dataset}/val/{orientation}"] = [
                _row(name, ate_of(arm, fold, seed, dataset, name, orientation))
                for name in recordings
                if name not in skip
            ]
            parts[f"{dataset}/test/{orientation}"] = [_row(f"{dataset}_test1", 99.0)]
    job = f"walking-f{fold}/{arm}-s{seed}"
    training = {"job": job, "model": arm.split("-")[0], "dataset": "walking", "seed": seed, "fold": fold}
    record = {
        "training": {**training, "variant": None, "best_val_mse": best_val_mse, "epochs": 9},
        "history": [],
        "evaluation": {"parts": parts},
    }
    (folder / f"{job.replace('/', '__')}.json").write_text(json.dumps(record))


def _row(name: str, ate: float) -> dict:
    return {
        "name": name,
        "duration_s": 60.0,
        "ate": ate,
        "ate_euclidean": ate * 1.3,
        "rte": ate,
        "pde": 0.05,
        "path_length_ratio": 0.9,
        "stand_still": {"ate": STILL, "ate_euclidean": STILL * 1.3, "rte": 5.0, "pde": 0.7},
    }


def write_campaign(folder: Path, a_ate: AteOf, b_ate: AteOf = baseline_ate) -> Path:
    """Arms a and b on both folds and both seeds, plus a fixed-split record the report must skip."""
    for fold in (0, 1):
        for seed in (0, 1):
            write_record(folder, A, fold, seed, a_ate)
            write_record(folder, B, fold, seed, b_ate)
    old = {
        "training": {"job": "ridi/ftin-mixed-s0", "dataset": "ridi", "seed": 0},
        "evaluation": {"parts": {}},
    }
    (folder / "ridi__ftin-mixed-s0.json").write_text(json.dumps(old))
    return folder


def shifted(by: float, walker_name: str | None = None) -> AteOf:
    """Arm a: b's ATE + ``by`` (on one walker's recordings only, with ``walker_name``), each walker
    0.05 m above or below that, as walkers differ."""

    def ate(arm: str, fold: int, seed: int, dataset: str, recording: str, orientation: str) -> float:
        name = walker(dataset, recording)
        hit = walker_name in (None, name)
        return (
            baseline_ate(arm, fold, seed, dataset, recording, orientation)
            + (by if hit else 0.0)
            + WOBBLE[name]
        )

    return ate


def overall(summary: dict, orientation: str = "ground_truth", dataset: str = "all") -> dict:
    return next(
        row
        for row in summary["comparisons"]
        if (row["a"], row["b"], row["orientation"], row["dataset"]) == (A, B, orientation, dataset)
    )


def test_pairs_match_only_the_same_fold_seed_recording_and_orientation(tmp_path):
    def a_ate(arm, fold, seed, dataset, recording, orientation):
        return baseline_ate(arm, fold, seed, dataset, recording, orientation) + (
            -0.5 if orientation == "ground_truth" else 0.3
        )

    for fold in (0, 1):
        for seed in (0, 1):
            write_record(tmp_path, A, fold, seed, a_ate, skip=("dan_bag1",) if (fold, seed) == (0, 0) else ())
            if (fold, seed) != (1, 1):  # b's fold-1 seed-1 job has not finished
                write_record(tmp_path, B, fold, seed, baseline_ate)
    scores = validation_scores(load_fold_runs(tmp_path))
    ground_truth = pairs(scores, A, B, "ground_truth")
    device = pairs(scores, A, B, "device")
    # fold 0 seed 0: 8 - 1 recordings; fold 0 seed 1: 8; fold 1 seed 0: 9; fold 1 seed 1: b missing.
    assert len(ground_truth) == len(device) == 7 + 8 + 9
    # Any pairing across seeds, recordings or orientations would move these off the exact shift.
    assert [p.a - p.b for p in ground_truth] == pytest.approx([-0.5] * 24)
    assert [p.a - p.b for p in device] == pytest.approx([0.3] * 24)
    assert {p.walker for p in pairs(scores, A, B, "ground_truth", "oxiod")} == {
        ("oxiod", "user1"),
        ("oxiod", "trolley-data1"),
        ("oxiod", "user2"),
        ("oxiod", "trolley-data2"),
    }


def test_a_better_on_every_walker_is_a_better_with_an_interval_around_minus_half(tmp_path):
    summary = crossval_summary(load_fold_runs(write_campaign(tmp_path, shifted(-0.5))), resamples=2000)
    row = overall(summary)
    assert row["walkers"] == WALKERS == 10 and row["pairs"] == 2 * (8 + 9)
    assert row["verdict"] == A_BETTER and row["lower_mean"] == "a"
    low, high = row["ci95_m"]
    assert -0.55 <= low < row["mean_m"] < high <= -0.45 and row["mean_m"] == pytest.approx(-0.5, abs=0.05)
    assert row["relative_ci95"][0] < row["relative"] < row["relative_ci95"][1] < 0
    # A single dataset has at most 4 walkers: its sub-row shows the direction, never a winner.
    ridi = overall(summary, dataset="ridi")
    assert ridi["walkers"] == 4 and ridi["ci95_m"][1] < 0 and ridi["verdict"] == NO_DIFFERENCE


def test_one_walker_carrying_the_difference_shows_none_where_a_per_pair_bootstrap_would_claim_one(
    tmp_path,
):
    folder = write_campaign(tmp_path, shifted(-2.5, walker_name="Guillaume"))
    runs = load_fold_runs(folder)
    row = overall(crossval_summary(runs, resamples=10_000))
    assert row["mean_m"] < -0.4  # the one walker drags the mean well below 0
    assert row["ci95_m"][0] < 0 < row["ci95_m"][1] and row["verdict"] == NO_DIFFERENCE
    assert row["lower_mean"] == "a"  # no claim, yet a choice between the two still takes a
    # The naive bootstrap over pairs treats Guillaume's six pairs as six independent pieces of evidence.
    d = np.array([p.a - p.b for p in pairs(validation_scores(runs), A, B, "ground_truth")])
    naive = np.random.default_rng(0).choice(d, size=(10_000, len(d)), replace=True).mean(axis=1)
    assert np.percentile(naive, 97.5) < 0  # it would name a winner


def test_validation_table_means_seeds_per_fold_and_dataset_and_never_reads_test_parts(tmp_path):
    write_campaign(tmp_path, shifted(-0.5))
    (tmp_path / "walking-f1__ronin_resnet-yaw-s1.json").unlink()  # b: seed 1 lacks fold 1
    validation = crossval_summary(load_fold_runs(tmp_path), resamples=200)["validation"]
    assert list(validation) == ["ground_truth", "device"]
    b = validation["ground_truth"]["arms"][B]
    expected = {
        (fold, seed): np.mean(
            [
                baseline_ate(B, fold, seed, d, name, "ground_truth")
                for d, names in FOLD_RECORDINGS[fold].items()
                for name in names
            ]
        )
        for fold in (0, 1)
        for seed in (0, 1)
    }
    # Seed means of the validation rows only: the 99 m test rows would show.
    assert b["fold 0"]["seeds"] == 2 and b["fold 0"]["ate"] == pytest.approx(
        (expected[0, 0] + expected[0, 1]) / 2
    )
    assert b["fold 1"]["seeds"] == 1 and b["fold 1"]["ate"] == pytest.approx(expected[1, 0])
    assert b["both folds"]["seeds"] == 1  # seed 1 is not averaged over one fold's walkers alone
    assert b["fold 0"]["stand_still_ratio"] == pytest.approx(b["fold 0"]["ate"] / STILL)
    assert b["fold 0"]["best_val_mse"] == pytest.approx(0.05) and b["both folds"]["best_val_mse"] is None
    inria = np.mean([baseline_ate(B, 1, 0, "inria", n, "ground_truth") for n in FOLD_RECORDINGS[1]["inria"]])
    assert b["fold 1"]["datasets"]["inria"]["ate"] == pytest.approx(inria)
    assert validation["ground_truth"]["stand_still"]["both folds"] == {
        "ate": STILL,
        "recordings": 17,
        "datasets": {d: {"ate": STILL} for d in ("oxiod", "ridi", "inria")},
    }


def test_walker_table_names_each_walker_once_with_its_fold(tmp_path):
    walkers = crossval_summary(load_fold_runs(write_campaign(tmp_path, shifted(-0.5))), resamples=200)[
        "walkers"
    ]
    names = [(row["dataset"], row["walker"]) for row in walkers]
    assert len(names) == WALKERS and names[0][0] == "oxiod" and names[-1][0] == "inria"
    user1 = walkers[names.index(("oxiod", "user1"))]
    assert user1["folds"] == [0] and user1["recordings"] == 2 and user1["stand_still"] == STILL
    handheld = [
        baseline_ate(B, 0, s, "oxiod", n, "ground_truth")
        for s in (0, 1)
        for n in FOLD_RECORDINGS[0]["oxiod"][:2]
    ]
    assert user1["arms"][B]["ate"] == pytest.approx(np.mean(handheld))


def test_a_folder_without_fold_records_is_refused(tmp_path):
    old = {
        "training": {"job": "oxiod/ftin-mixed-s0", "dataset": "oxiod", "seed": 0},
        "evaluation": {"parts": {}},
    }
    (tmp_path / "oxiod__ftin-mixed-s0.json").write_text(json.dumps(old))
    with pytest.raises(ValueError, match="no records of a walker-fold job"):
        crossval_report(tmp_path, tmp_path / "out")
    with pytest.raises(ValueError, match="no such folder"):
        crossval_report(tmp_path / "missing", tmp_path / "out")


def test_the_report_writes_markdown_json_and_figure(tmp_path):
    results = tmp_path / "results"
    results.mkdir()
    written = crossval_report(write_campaign(results, shifted(-0.5)), tmp_path / "out")
    assert [p.name for p in written] == ["crossval.md", "crossval.json", "crossval.png"]
    md = written[0].read_text()
    assert "walker-held-out validation" in md and "test parts are untouched" in md
    assert "### FTIN vs RoNIN ResNet: a = `ftin-ordered-yaw`, b = `ronin_resnet-yaw`" in md
    assert "**`ftin-ordered-yaw` better**" in md and "too few for a verdict" in md
    assert json.loads(written[1].read_text())["bootstrap"]["resamples"] == 10_000
    assert written[2].read_bytes().startswith(b"\x89PNG")


def test_the_command_writes_the_three_files_and_refuses_a_folder_without_fold_records(tmp_path):
    results = tmp_path / "results"
    results.mkdir()
    write_campaign(results, shifted(-0.5))
    out = tmp_path / "out"
    result = runner.invoke(app, ["campaign", "crossval", "--results", str(results), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert (
        "# Walker-wise cross-validation" in result.stdout and f"wrote {out / 'crossval.png'}" in result.stdout
    )
    assert sorted(p.name for p in out.iterdir()) == ["crossval.json", "crossval.md", "crossval.png"]
    empty = tmp_path / "empty"
    empty.mkdir()
    bad = runner.invoke(app, ["campaign", "crossval", "--results", str(empty), "--out", str(out)])
    fails_cleanly(bad, "no records of a walker-fold job")


def test_a_campaign_with_one_fold_done_has_no_both_folds_rows(tmp_path):
    for seed in (0, 1):
        write_record(tmp_path, A, 0, seed, baseline_ate)
    validation = crossval_summary(load_fold_runs(tmp_path), resamples=200)["validation"]["ground_truth"]
    assert validation["stand_still"]["fold 0"] is not None
    assert validation["stand_still"]["both folds"] is None and validation["stand_still"]["fold 1"] is None
    assert validation["arms"][A]["both folds"] is None


def test_carry_table_counts_the_walks_each_arm_carries_far_enough_phone_only():
    def score(arm, seed, dataset, recording, ratio, orientation="phone_only"):
        return Score(arm, 0, seed, dataset, recording, orientation, 1.0, STILL, ratio)

    scores = [
        score(A, 0, "inria", "Guillaume_Nexus5_NoDist_Swinging", 0.6),
        score(A, 1, "inria", "Guillaume_Nexus5_NoDist_Swinging", 0.9),
        score(A, 0, "inria", "Guillaume_iPhone5_Dist_Swinging", 0.85),
        score(A, 0, "inria", "Guillaume_Nexus5_NoDist_RunningHand", 0.75),  # within running's 0.7-1.3
        score(B, 0, "inria", "Guillaume_Nexus5_NoDist_Swinging", 1.0),
        score(B, 0, "ridi", "dan_leg1", 0.5),
        score(B, 0, "oxiod", "trolley/data1/imu7", 1.0),
        score(B, 0, "oxiod", "trolley/data1/imu7", 0.1, orientation="ground_truth"),  # not phone only
    ]
    rows = {(r["dataset"], r["carry"]): r for r in carry_table(scores)}
    assert list(rows) == [
        ("oxiod", "trolley"),
        ("ridi", "pocket"),
        ("inria", "RunningHand"),
        ("inria", "Swinging"),
    ]
    swinging = rows["inria", "Swinging"]
    assert swinging["recordings"] == 2 and swinging["bounds"] == [0.8, 1.2]
    # seed 0: mean(0.6, 0.85); seed 1: 0.9; then the mean over seeds
    assert swinging["arms"][A]["path_length_ratio"] == pytest.approx((0.725 + 0.9) / 2)
    assert (swinging["arms"][A]["within"], swinging["arms"][A]["runs"]) == (2, 3)
    assert rows["inria", "RunningHand"]["arms"][A]["within"] == 1
    assert rows["ridi", "pocket"]["arms"][B]["within"] == 0
    assert rows["oxiod", "trolley"]["arms"][B] == {"path_length_ratio": 1.0, "within": 1, "runs": 1}
    assert carry_of("oxiod", "handheld/data1/imu2") == "handheld" and carry_of("ridi", "dan_bag1") == "bag"
