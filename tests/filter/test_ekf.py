"""The EKF of ``ftin.filter`` on simulated walks: Jacobians against finite differences, convergence of
tilt and biases, consistency (NEES) with a perfect measurement model, causality, and the network
wrapper on the shipped default checkpoint."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ftin.checkpoint import load_model
from ftin.data import frames
from ftin.evaluate import score
from ftin.filter import FilterConfig, NetworkVelocity, filter_prediction, run_filter
from ftin.filter.consistency import chi2_bounds, tilt_error_deg
from ftin.filter.ekf import boxminus, boxplus, step, velocity_measurement
from ftin.filter.state import BG, EVOLVING, NominalState, so3_exp, yaw_jacobian, yaw_of
from ftin.sim import SimConfig, simulate
from tests.filter.simulated import WINDOW, perfect_measure, sim_config, sim_walk, tilted_start
from tests.utils.paths import REPO_ROOT

DEFAULT_CHECKPOINT = REPO_ROOT / "checkpoints" / "ronin_resnet-walking"


def random_state(rng: np.random.Generator, clones: int = 0, speed_scale: float | None = None) -> NominalState:
    def rot() -> np.ndarray:
        return Rotation.from_rotvec(rng.normal(0.0, 1.0, 3)).as_matrix()

    state = NominalState(rot(), *(rng.normal(0.0, s, 3) for s in (1.0, 5.0, 0.01, 0.1)), k=speed_scale)
    for k in range(clones):
        state.clone_index.append(k)
        state.clone_R.append(rot())
        state.clone_p.append(rng.normal(0.0, 5.0, 3))
    return state


def propagate_nominal(state: NominalState, *samples) -> NominalState:
    """The nominal state one IMU interval later (``step``'s ``R``, ``v``, ``p``)."""
    out = state.copy()
    out.R, out.v, out.p, _, _ = step(state, *samples)
    return out


@pytest.mark.parametrize("speed_scale", [None, 0.7])
def test_propagation_jacobian_matches_finite_differences(speed_scale) -> None:
    rng = np.random.default_rng(1)
    state = random_state(rng, speed_scale=speed_scale)
    gyro, acc, dt = np.array([0.8, -1.2, 0.5]), np.array([1.5, -0.7, 9.6]), 0.01
    samples = (gyro, acc, dt, 9.81, gyro + [0.3, 0.1, -0.2], acc + [0.5, -1.0, 0.4])
    _, _, _, A, B = step(state, *samples)
    nominal = propagate_nominal(state, *samples)
    dim = state.evolving_dim
    assert A.shape == (dim, dim) and dim == EVOLVING + (speed_scale is not None)
    eps = 1e-6
    for j in range(dim):
        d = np.zeros(dim)
        d[j] = eps
        plus = boxminus(propagate_nominal(boxplus(state, d), *samples), nominal)
        minus = boxminus(propagate_nominal(boxplus(state, -d), *samples), nominal)
        np.testing.assert_allclose((plus - minus) / (2 * eps), A[:, j], atol=1e-6, err_msg=f"column {j}")
    for j in range(6):  # white noise n over the interval acts as a bias of the interval
        d = np.zeros(dim)
        d[BG.start + j] = eps
        bumped = boxminus(propagate_nominal(boxplus(state, d), *samples), nominal)[: BG.start]
        np.testing.assert_allclose(bumped / eps, B[: BG.start, j], atol=1e-5, err_msg=f"noise column {j}")
    assert not B[BG.start :].any()  # white noise leaves the biases alone


@pytest.mark.parametrize("speed_scale", [None, 0.7])
def test_measurement_jacobian_matches_finite_differences(speed_scale) -> None:
    rng = np.random.default_rng(2)
    state = random_state(rng, clones=2, speed_scale=speed_scale)
    dt = 1.0
    for clone in (0, 1):
        _, H = velocity_measurement(state, clone, dt)
        eps = 1e-6
        for j in range(H.shape[1]):
            d = np.zeros(H.shape[1])
            d[j] = eps
            plus, _ = velocity_measurement(boxplus(state, d), clone, dt)
            minus, _ = velocity_measurement(boxplus(state, -d), clone, dt)
            np.testing.assert_allclose((plus - minus) / (2 * eps), H[:, j], atol=1e-6, err_msg=f"column {j}")


def test_yaw_jacobian_matches_finite_differences_and_is_pure_z_when_level() -> None:
    rng = np.random.default_rng(3)
    for _ in range(5):
        R = Rotation.from_rotvec(rng.normal(0.0, 0.8, 3)).as_matrix()
        eps = 1e-6
        numeric = [
            (yaw_of(so3_exp(eps * e) @ R) - yaw_of(so3_exp(-eps * e) @ R)) / (2 * eps) for e in np.eye(3)
        ]
        np.testing.assert_allclose(numeric, yaw_jacobian(R), atol=1e-6)
    level = Rotation.from_euler("z", 1.0).as_matrix()
    np.testing.assert_allclose(yaw_jacobian(level), [0.0, 0.0, 1.0], atol=1e-12)


def test_tilt_and_biases_converge_on_a_simulated_walk() -> None:
    seq, motion, errors = sim_walk(seed=3)
    config = sim_config()
    start = tilted_start(seq, np.radians([2.0, -1.5, 0.0]))  # 2.5 deg of tilt, zero biases assumed
    measure = perfect_measure(seq, motion, 0.03, 0.03, np.random.default_rng(0))
    run = run_filter(None, start, WINDOW, config, start_position_m=seq.gt.p_world_m[0], measure=measure)
    tilt = tilt_error_deg(run.q_world_device_wxyz, seq.gt.q_world_body_wxyz)
    assert tilt[0] == pytest.approx(2.5, abs=0.01)
    assert tilt[-1000:].mean() < 0.3  # from 2.5 deg to a few tenths
    gyro_error = np.linalg.norm(run.gyro_bias_rad_s - errors.gyro_bias_rad_s, axis=1)
    acc_error = np.linalg.norm(run.acc_bias_m_s2 - errors.acc_bias_m_s2, axis=1)
    assert gyro_error[-1000:].mean() < 0.5 * gyro_error[0]
    assert acc_error[-1000:].mean() < 0.5 * acc_error[0]
    assert len(run.nis) == (len(seq) - 1) // WINDOW and run.applied.all()
    assert run.position_cov_xy.shape == (len(seq), 2, 2)
    assert np.all(np.linalg.eigvalsh(run.position_cov_xy) > 0)


def test_the_speed_scale_learns_a_network_that_reads_slow_and_keeps_the_walked_distance() -> None:
    """A network that reads 0.6 of the true speed (a damped bounce): with the speed scale state the
    filter finds 0.6 from the IMU's velocity changes and walks the true distance; without it the
    filter follows the slow network."""
    seq, motion, _ = sim_walk(seed=4, duration_s=90.0)
    exact = perfect_measure(seq, motion, 0.05, 0.03, np.random.default_rng(0))

    def slow(rows, start, end, R_start):
        v, cov = exact(rows, start, end, R_start)
        return np.array([0.6 * v[0], 0.6 * v[1], v[2]]), cov

    def distance(p: np.ndarray) -> float:  # once a second: the steps' sway is no distance
        return float(np.linalg.norm(np.diff(p[::100, :2], axis=0), axis=1).sum())

    walked = distance(seq.gt.p_world_m)
    ratios = {}
    for std in (None, 0.3):
        config = sim_config(speed_scale_std=std, velocity_std_m_s=0.05)
        start = seq.gt.p_world_m[0]
        run = run_filter(None, seq, WINDOW, config, start_position_m=start, measure=slow)
        ratios[std] = distance(run.p_world_m) / walked
        if std is None:
            assert (run.speed_scale == 1.0).all() and run.covariance.shape[1:] == (EVOLVING, EVOLVING)
        else:
            assert run.speed_scale[0] == 1.0 and run.covariance.shape[1:] == (EVOLVING + 1, EVOLVING + 1)
            assert run.speed_scale[-3000:] == pytest.approx(0.6, abs=0.05)
    assert ratios[None] < 0.8
    assert 0.85 < ratios[0.3] < 1.2


def truth_state(seq, motion, errors, k: int) -> NominalState:
    t = seq.t_s[k : k + 1]
    return NominalState(
        frames.rotation_from_wxyz(seq.gt.q_world_body_wxyz[k]).as_matrix(),
        motion.velocity_m_s(t)[0],
        seq.gt.p_world_m[k],
        errors.gyro_bias_rad_s[k],
        errors.acc_bias_m_s2[k],
    )


def test_nees_within_its_bounds_with_a_perfect_measurement_model() -> None:
    """Monte Carlo over walks whose start errors are drawn from the filter's own prior: the mean
    15-dof NEES over runs at each update time stays within its 95 % chi-square bounds."""
    config = sim_config()
    prior = np.sqrt(np.diag(config.initial_covariance()))
    nees = []
    for seed in range(4):
        seq, motion, errors = sim_walk(seed=10 + seed, duration_s=40.0)
        rng = np.random.default_rng(seed)
        start = tilted_start(seq, rng.normal(0.0, prior[:3]))
        run = run_filter(
            None,
            start,
            WINDOW,
            config,
            start_position_m=seq.gt.p_world_m[0] + rng.normal(0.0, prior[6:9]),
            measure=perfect_measure(seq, motion, 0.03, 0.03, rng),
        )
        per_update = []
        for i, k in enumerate(run.update_span[:, 1]):
            est = NominalState(
                frames.rotation_from_wxyz(run.q_world_device_wxyz[k]).as_matrix(),
                run.velocity_state_m_s[k],
                run.p_world_m[k],
                run.gyro_bias_rad_s[k],
                run.acc_bias_m_s2[k],
            )
            e = boxminus(truth_state(seq, motion, errors, k), est)
            per_update.append(e @ np.linalg.solve(run.covariance[i], e))
        nees.append(per_update[5:])  # after the first 5 s: the start's tilt is then small enough to be linear
    mean = np.mean(nees, axis=0)
    low, high = chi2_bounds(EVOLVING, len(nees))
    assert np.mean((mean >= low) & (mean <= high)) >= 0.9, mean
    assert low < mean.mean() < high


def test_the_estimate_at_a_time_does_not_change_when_later_samples_arrive() -> None:
    loaded = load_model(DEFAULT_CHECKPOINT)
    seq = simulate(SimConfig(duration_s=30.0, seed=5))
    network = NetworkVelocity(loaded, FilterConfig())
    cut = 1500
    short = run_filter(network, seq.slice(0, cut), WINDOW, FilterConfig())
    full = run_filter(network, seq, WINDOW, FilterConfig())
    np.testing.assert_array_equal(short.p_world_m, full.p_world_m[:cut])
    np.testing.assert_array_equal(short.q_world_device_wxyz, full.q_world_device_wxyz[:cut])
    np.testing.assert_array_equal(short.position_cov_xy, full.position_cov_xy[:cut])
    np.testing.assert_array_equal(short.velocity_m_s, full.velocity_m_s[: len(short.velocity_m_s)])
    assert len(full.velocity_m_s) > len(short.velocity_m_s)


def test_filter_prediction_scores_like_a_prediction_and_refuses_what_it_cannot_run() -> None:
    loaded = load_model(DEFAULT_CHECKPOINT)
    seq = simulate(SimConfig(duration_s=30.0, seed=6))
    prediction, run = filter_prediction(loaded, seq)
    assert prediction.trajectory.p_world_m.shape == (len(seq), 3)
    assert prediction.orientation_filter == "ekf"
    scored = score(prediction, "start")
    assert scored.metrics is not None and np.isfinite(scored.metrics.ate)
    assert scored.metrics.ate < 0.5 * seq.gt.path_length_m  # a walk, not a wild drift
    with pytest.raises(ValueError, match="too short"):
        run_filter(NetworkVelocity(loaded, FilterConfig()), seq.slice(0, WINDOW), WINDOW)
    with pytest.raises(ValueError, match="update_every"):
        FilterConfig(update_every=0)


def test_a_heading_reference_holds_the_heading_the_gyro_bias_would_turn() -> None:
    """Heading is unobservable from the network: with a gyro bias about z left to the filter, its own
    heading drifts; a heading reference (an orientation filter's) holds it."""
    seq, motion, errors = sim_walk(seed=4)
    biased = seq.with_(gyro_rad_s=seq.gyro_rad_s + [0.0, 0.0, 0.01])  # 0.6 deg/s the filter must find
    truth_yaw = np.unwrap(frames.yaw_rad(seq.gt.q_world_body_wxyz))
    config = sim_config(init_gyro_bias_std_rad_s=0.003)
    final_error = {}
    for name, reference in (("own", None), ("reference", truth_yaw)):
        run = run_filter(
            None,
            biased,
            WINDOW,
            config,
            start_position_m=seq.gt.p_world_m[0],
            measure=perfect_measure(seq, motion, 0.03, 0.03, np.random.default_rng(0)),
            heading_ref_rad=reference,
        )
        own_yaw = np.unwrap(frames.yaw_rad(run.q_world_device_wxyz))
        final_error[name] = abs(np.degrees(own_yaw[-1] - truth_yaw[-1]))
    assert final_error["reference"] < 2.0 < final_error["own"]
