"""ftin.profiles: the scale and spread from walks of known length, applying it, and the store."""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np
import pytest

from ftin.data.types import Trajectory
from ftin.profiles import apply_scale, profile_scale, scale_sample
from ftin.profiles.scale import ONE_WALK_LOG_SPREAD, SCALE_SIGMA_FLOOR
from ftin.profiles.store import DISTANCE, ProfileStore, UnknownProfileError, Walk
from ftin.uncertainty import uncertainty_of


def test_one_walk_states_the_prior_and_more_walks_their_own_spread() -> None:
    one = profile_scale([1.3])
    assert one.scale == pytest.approx(1.3) and one.log_spread == pytest.approx(ONE_WALK_LOG_SPREAD)
    assert one.spread_sigma == pytest.approx(ONE_WALK_LOG_SPREAD * math.sqrt(2))
    assert one.scale_sigma == max(one.spread_sigma, SCALE_SIGMA_FLOOR)  # what the uncertainty takes
    assert profile_scale([0.6, 1.4]).scale_sigma > SCALE_SIGMA_FLOOR  # walks that disagree widen it
    # in log space: 0.5x and 2x average to 1x
    assert profile_scale([0.5, 2.0]).scale == pytest.approx(1.0)
    # the median: one odd walk of three does not move it
    assert profile_scale([1.2, 1.21, 3.0]).scale == pytest.approx(1.21)
    steady = profile_scale([1.2] * 20)
    assert steady.log_spread < 0.25 * ONE_WALK_LOG_SPREAD  # twenty agreeing walks outweigh the prior
    assert profile_scale([1.0, 1.6]).log_spread > ONE_WALK_LOG_SPREAD  # two that disagree widen it


def test_a_sample_no_stride_explains_is_refused() -> None:
    assert scale_sample(130.0, 100.0) == pytest.approx(1.3)
    for distance, predicted, words in (
        (5.0, 4.0, "too short"),
        (-1.0, 10.0, "positive"),
        (10.0, 0.0, "no length"),
        (500.0, 10.0, "outside"),
    ):
        with pytest.raises(ValueError, match=words):
            scale_sample(distance, predicted)


@dataclass(frozen=True)
class Pred:
    """The fields ``apply_scale`` reads, in a dataclass as ``ftin.infer.Prediction`` is."""

    trajectory: Trajectory
    velocity_m_s: np.ndarray
    truth: Trajectory


def test_apply_scale_stretches_the_path_about_its_start_and_the_velocities() -> None:
    t = np.linspace(0.0, 10.0, 11)
    p = np.column_stack([5.0 + t, 2.0 + 0.5 * t**1.5, 1.0 + 0.1 * t])
    truth = Trajectory(t, p.copy())
    scaled = apply_scale(Pred(Trajectory(t, p), np.ones((4, 3)), truth), 1.5)
    q = scaled.trajectory.p_world_m
    np.testing.assert_allclose(q[:, :2] - q[0, :2], 1.5 * (p[:, :2] - p[0, :2]))
    np.testing.assert_allclose(q[0], p[0])
    np.testing.assert_allclose(q[:, 2], p[:, 2])  # height as it was
    np.testing.assert_allclose(scaled.velocity_m_s, [[1.5, 1.5, 1.0]] * 4)
    assert scaled.truth is truth


def test_the_profile_spread_sets_the_speed_scale_term() -> None:
    t = np.linspace(0.0, 60.0, 601)
    p = np.column_stack([1.2 * t, np.zeros_like(t), np.zeros_like(t)])
    starts = np.arange(0, 590, 10)
    prediction = SimpleNamespace(
        trajectory=Trajectory(t, p),
        span_t_s=np.column_stack([t[starts], t[starts + 10]]),
        velocity_m_s=np.tile([1.2, 0.0, 0.0], (len(starts), 1)),
        features=None,
        orientation_filter="vqf 9d",
        window_s=1.0,
    )
    population = uncertainty_of(prediction, "ronin_resnet-walking")
    narrow = uncertainty_of(prediction, "ronin_resnet-walking", scale_sigma=0.05)
    wide = uncertainty_of(prediction, "ronin_resnet-walking", scale_sigma=1.0)
    # along the walk (x) the scale term is the whole difference; across it (y) nothing changes
    assert narrow.cov_m2[-1, 0] < population.cov_m2[-1, 0] < wide.cov_m2[-1, 0]
    assert narrow.cov_m2[-1, 2] == pytest.approx(population.cov_m2[-1, 2])
    assert narrow.end_radius_95_m < population.end_radius_95_m and "profile" in narrow.calibration


def walk(run_id: str, distance_m: float, added_s: float = 1.0) -> Walk:
    return Walk(run_id, distance_m, 100.0, DISTANCE, added_s)


def test_the_store_keeps_profiles_replaces_a_run_and_deletes(tmp_path) -> None:
    store = ProfileStore.in_runs_dir(tmp_path / "runs")
    assert store.list() == [] and store.get("x") is None and not store.path.exists()  # reading makes no file
    store.add_walk("x", walk("run-a", 120.0, 1.0))
    made = store.add_walk("x", walk("run-b", 140.0, 2.0))
    assert [w.run_id for w in made.walks] == ["run-a", "run-b"]
    replaced = store.add_walk("x", walk("run-a", 100.0, 3.0))  # the same run again: its walk replaced
    assert sorted(w.distance_m for w in replaced.walks) == [100.0, 140.0]
    again = ProfileStore(store.path).get("x")  # another process's view: the same file
    assert again == replaced
    assert store.delete("x") and not store.delete("x") and store.get("x") is None
    with pytest.raises(UnknownProfileError, match="unknown profile 'x'"):
        store.require("x")
    with pytest.raises(ValueError, match="profile name"):
        store.add_walk("../etc", walk("run-c", 100.0))


def test_writers_at_once_lose_no_walk(tmp_path) -> None:
    path = tmp_path / "index.sqlite"
    threads = [
        threading.Thread(
            target=lambda i=i: ProfileStore(path).add_walk("many", walk(f"run-{i:03d}", 100.0 + i))
        )
        for i in range(16)
    ]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(ProfileStore(path).require("many").walks) == 16
