"""ftin.uncertainty.coverage: which true positions lie inside the 1 / 2 sigma ellipses, counted exactly on
a constructed walk and on a bundled recording with ground truth; ``ftin evaluate`` reports them per
sequence, pooled, and in its JSON."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from ftin.checkpoint import load_model
from ftin.cli import app
from ftin.data import Trajectory
from ftin.data.loading import load_sequences
from ftin.evaluate import evaluate_checkpoint
from ftin.infer import predict_trajectory
from ftin.metrics.alignment_modes import Alignment, fit_alignment
from ftin.uncertainty import uncertainty_of
from ftin.uncertainty.coverage import Coverage, coverage_of, pooled
from ftin.uncertainty.radius import radius_holding

ROOT = Path(__file__).resolve().parents[2]
CHECKPOINT = ROOT / "checkpoints" / "ronin_resnet-walking"
SAMPLE = ROOT / "ftin" / "sim" / "samples" / "sim_handheld.csv"  # a bundled walk with ground truth


def straight_walk(n: int = 301, rate: float = 10.0) -> Trajectory:
    t = np.arange(n) / rate
    return Trajectory(t, np.column_stack([1.0 * t, np.zeros(n), np.zeros(n)]))


def test_counts_the_samples_inside_each_ellipse() -> None:
    est = straight_walk()
    t = est.t_s
    # The truth equals the estimate over the first 10 s (the start alignment fits nothing), then lies
    # 0.5 m, 1.5 m or 3 m to the side in turn; unit variance in x and y: inside 1 sigma only at 0.5 m,
    # inside 2 sigma at 0.5 and 1.5 m.
    offset = np.where(t <= 10.0, 0.0, np.array([0.5, 1.5, 3.0])[np.arange(len(t)) % 3])
    truth = Trajectory(t, est.p_world_m + np.column_stack([np.zeros_like(t), offset, np.zeros_like(t)]))
    cov = np.column_stack([np.ones_like(t), np.zeros_like(t), np.ones_like(t)])
    cov[0] = 0.0  # the start: left out
    found = coverage_of(est, cov, truth, end_radius_95_m=2.0)
    late = t > 10.0
    assert found.samples == len(t) - 1
    assert found.inside_1sigma == np.sum(~late[1:]) + np.sum(offset[late] == 0.5)
    assert found.inside_2sigma == np.sum(~late[1:]) + np.sum(offset[late] <= 1.5)
    assert found.end_error_m == pytest.approx(offset[-1])
    assert found.end_inside == (offset[-1] <= 2.0)


def test_a_wrong_covariance_shape_is_refused() -> None:
    est = straight_walk()
    with pytest.raises(ValueError, match="cov_m2 must be"):
        coverage_of(est, np.ones((5, 3)), est, 1.0)


def test_pooled_weighs_samples_and_counts_ends() -> None:
    a = Coverage(samples=100, inside_1sigma=40, inside_2sigma=90, end_error_m=1.0, end_radius_95_m=2.0)
    b = Coverage(samples=300, inside_1sigma=60, inside_2sigma=210, end_error_m=5.0, end_radius_95_m=2.0)
    summary = pooled([a, None, b])
    assert summary.recordings == 2 and summary.samples == 400
    assert summary.share_1sigma == pytest.approx(100 / 400) and summary.share_2sigma == pytest.approx(
        300 / 400
    )
    assert summary.end_inside_share == pytest.approx(0.5)
    assert pooled([None]) is None


@pytest.fixture(scope="module")
def handheld() -> tuple:
    if not CHECKPOINT.with_suffix(".safetensors").exists():
        pytest.skip(f"the default checkpoint {CHECKPOINT.name} is not in checkpoints/")
    loaded = load_model(CHECKPOINT)
    (seq,) = load_sequences([SAMPLE], "--data", "auto")
    prediction = predict_trajectory(loaded, seq, keep_prepared=False)
    return loaded, seq, prediction


def test_coverage_on_a_bundled_walk_matches_a_direct_end_check(handheld: tuple) -> None:
    loaded, _seq, prediction = handheld
    found = uncertainty_of(prediction, loaded.name)
    truth = prediction.truth
    cov = coverage_of(prediction.trajectory, found.cov_m2, truth, found.end_radius_95_m)
    assert cov.samples > 0.9 * len(prediction.trajectory.t_s)
    assert 0.0 <= cov.share_1sigma <= cov.share_2sigma <= 1.0
    # The end, computed here on its own: the truth moved by the evaluation's start alignment, the
    # exact 95 % radius of the end's covariance.
    fit = fit_alignment(prediction.trajectory, truth, Alignment.START)
    true_end = fit.gt_in_estimate_frame(truth).p_world_m[-1, :2]
    error = float(np.linalg.norm(true_end - prediction.trajectory.p_world_m[-1, :2]))
    c = found.cov_m2[-1]
    radius = radius_holding(np.array([[c[0], c[1]], [c[1], c[2]]]), 0.95)
    assert cov.end_error_m == pytest.approx(error, abs=1e-6)
    assert cov.end_radius_95_m == pytest.approx(radius)
    assert cov.end_inside == (error <= radius)


def test_evaluate_reports_coverage_per_sequence_and_pooled(handheld: tuple, tmp_path: Path) -> None:
    loaded, seq, _prediction = handheld
    report = evaluate_checkpoint(loaded, [seq])
    (result,) = report.sequences
    assert result.coverage is not None and report.coverage.samples == result.coverage.samples
    data = report.to_json()
    assert data["sequences"][0]["uncertainty_coverage"]["inside_2sigma"] == pytest.approx(
        result.coverage.share_2sigma, abs=1e-4
    )
    assert data["uncertainty_coverage"]["expected"]["inside_2sigma"] == pytest.approx(0.8647, abs=1e-4)

    out = tmp_path / "report.json"
    cli = CliRunner().invoke(
        app, ["evaluate", "--checkpoint", str(CHECKPOINT), "--data", str(SAMPLE), "--json", str(out)]
    )
    assert cli.exit_code == 0, cli.output
    assert "Uncertainty coverage" in cli.output and "inside 2σ (86%)" in cli.output
    written = json.loads(out.read_text())
    assert (
        written["sequences"][0]["uncertainty_coverage"]["end_inside_radius_95"] == result.coverage.end_inside
    )
