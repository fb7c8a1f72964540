"""The uncertainty's constants: the default model's entry in ``ftin/uncertainty/calibration.json``, the
fallback for a checkpoint without one, the probe that fits them (reproducible from its walks), and the
whole chain on a real prediction of the shipped default."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from app.settings import BUNDLED_SAMPLES_DIR
from ftin.checkpoint import load_model
from ftin.data.readers.generic_csv import read_csv
from ftin.data.types import Trajectory
from ftin.infer import Prediction, predict_trajectory
from ftin.uncertainty import path_uncertainty, uncertainty_of
from ftin.uncertainty.calibration import FALLBACK, Calibration, calibration_for, save_calibration
from tests.utils.paths import CHECKPOINTS, REPO_ROOT

# Written by experiments/probe_uncertainty.py, one folder per default's weights.
_DEFAULT_SHA = json.loads((CHECKPOINTS / f"{FALLBACK}.json").read_text())["weights_sha256"]
PROBE_CACHE = REPO_ROOT / "runs" / "uncertainty_walks" / _DEFAULT_SHA[:12]


def test_the_default_model_has_its_own_constants() -> None:
    c = calibration_for(FALLBACK)
    assert c.model == FALLBACK and "walker-held-out" in c.fitted_on
    for value in (
        c.sigma_a,
        c.sigma_b,
        c.scale_sigma,
        c.gyro_drift_rad_s,
        c.heading_sigma_rad,
        c.position_scale,
    ):
        assert math.isfinite(value) and value >= 0
    assert c.sigma_a > 0 and c.position_scale > 0
    assert c.describe(FALLBACK).startswith(f"fitted for {FALLBACK}")


def test_a_checkpoint_without_constants_borrows_the_defaults_and_says_so() -> None:
    c = calibration_for("tlio-ridi")
    assert c == calibration_for(FALLBACK).without_head()  # another head's scale (and factor) is not its own
    assert c.describe("tlio-ridi").startswith("not calibrated for tlio-ridi")


def test_carry_modes_take_their_own_spread_where_measured() -> None:
    c = Calibration("m", 0.1, 0.1, 0.3, 0.0, 0.0, scale_sigma_by_carry={"pocket": 0.2})
    assert c.scale_sigma_for("pocket") == 0.2
    assert c.scale_sigma_for("unknown") == c.scale_sigma_for(None) == 0.3


def test_saving_adds_an_entry_and_keeps_the_others(tmp_path: Path) -> None:
    path = tmp_path / "calibration.json"
    save_calibration(Calibration("a", 0.1, 0.2, 0.3, 0.001, 0.1), path)
    save_calibration(Calibration("b", 0.2, 0.2, 0.3, 0.001, 0.1), path)
    text = path.read_text()
    assert '"a"' in text and '"b"' in text


def test_the_probe_reproduces_the_stored_constants() -> None:
    """The stored entry is what the held-out probe's rule chooses (issue 54): its refit (the speed-scale
    term and factor fitted on walks the network never trained on) where that brings more held-out groups
    into 85-98 %, else the validation probe's fit."""
    ilc_cache = REPO_ROOT / "runs" / "uncertainty_ilc" / _DEFAULT_SHA[:12]
    if not PROBE_CACHE.is_dir() or len(list(PROBE_CACHE.glob("*.npz"))) < 64 or not ilc_cache.is_dir():
        pytest.skip(
            "the probes' predicted walks are not cached here "
            "(python -m experiments.probe_uncertainty_heldout)"
        )
    from experiments import probe_uncertainty_heldout as probe  # noqa: PLC0415 (a probe, only here)

    walks = [dict(np.load(f)) for f in sorted(PROBE_CACHE.glob("*.npz"))]
    walks += [dict(np.load(f)) for f in sorted(ilc_cache.glob("*/*.npz"))]
    stored = calibration_for(FALLBACK)
    before, _, refit, adopted = probe.refits(probe.grouped(walks), walks, stored)
    chosen = refit if adopted else before  # the probe's rule: the refit where it brings more groups in
    for name, value in chosen.to_json().items():
        assert value == (
            pytest.approx(getattr(stored, name)) if isinstance(value, float) else getattr(stored, name)
        )


def test_a_real_prediction_gets_a_covariance_and_a_radius() -> None:
    frame = pd.read_csv(BUNDLED_SAMPLES_DIR / "sim_handheld.csv", nrows=6000)  # a minute at 100 Hz
    loaded = load_model(CHECKPOINTS / "ronin_resnet-walking.json")
    prediction = predict_trajectory(loaded, read_csv(frame.to_csv(index=False).encode()), keep_prepared=False)
    found = uncertainty_of(prediction, loaded.name)
    cov = found.cov_m2
    assert cov.shape == (len(prediction.trajectory.t_s), 3) and np.all(np.isfinite(cov))
    assert np.all(cov[:, 0] * cov[:, 2] - cov[:, 1] ** 2 >= -1e-9)
    assert found.end_radius_95_m > 0 and found.sigma_m().shape == (len(cov), 2)
    half = uncertainty_of(first_half(prediction), loaded.name)  # a shorter walk is surer of its end
    assert 0 < half.end_radius_95_m < found.end_radius_95_m
    assert path_uncertainty(replace(prediction, span_t_s=None), loaded.name) is None


def first_half(prediction: Prediction) -> Prediction:
    traj = prediction.trajectory
    n = len(traj.t_s) // 2
    keep = prediction.span_t_s[:, 1] <= traj.t_s[n - 1]
    return replace(
        prediction,
        trajectory=Trajectory(traj.t_s[:n], traj.p_world_m[:n], None),
        span_t_s=prediction.span_t_s[keep],
        velocity_m_s=prediction.velocity_m_s[keep],
        features={k: v[keep] for k, v in (prediction.features or {}).items()},  # the head's log-std
    )


def test_a_prediction_without_the_heads_sigma_takes_the_constants_fitted_without_it() -> None:
    """A live walk or a restored run of the default carries no per-window log-std: its uncertainty is
    ``a + b |v|`` with the factor fitted for it, not the head's factor on another sigma."""
    c = calibration_for(FALLBACK)
    assert c.log_std_scale is not None and c.position_scale_without_head is not None  # the default has a head
    plain = c.without_head()
    assert plain.log_std_scale is None and plain.position_scale == c.position_scale_without_head
    assert plain.sigma_a == c.sigma_a and plain.without_head() == plain
    assert "variance head" in c.describe(FALLBACK) and "|v|" in plain.describe(FALLBACK)
    frame = pd.read_csv(BUNDLED_SAMPLES_DIR / "sim_handheld.csv", nrows=3000)
    loaded = load_model(CHECKPOINTS / "ronin_resnet-walking.json")
    prediction = predict_trajectory(loaded, read_csv(frame.to_csv(index=False).encode()), keep_prepared=False)
    with_head = uncertainty_of(prediction, loaded.name)
    without = uncertainty_of(replace(prediction, features=None), loaded.name)
    assert "variance head" in with_head.calibration and "|v|" in without.calibration
    assert without.end_radius_95_m > 0 and without.end_radius_95_m != with_head.end_radius_95_m
