"""``FilterSession`` (``ftin.filter.session``): the EKF fed a stream in chunks of any size gives, per
sample, what ``run_filter`` gives on the whole recording; an estimate does not change when later
samples arrive; the live shape (``extend`` with a causal orientation) starts from that orientation
and holds its heading. The default checkpoint measures every window, on a simulated walk."""

from __future__ import annotations

import numpy as np
import pytest

from ftin.checkpoint import load_model
from ftin.data import frames
from ftin.filter import FilterConfig, NetworkVelocity, run_filter
from ftin.filter.session import FilterRun, FilterSession
from ftin.sim import SimConfig, simulate
from tests.utils.paths import REPO_ROOT

WINDOW = 100
DEFAULT_CHECKPOINT = REPO_ROOT / "checkpoints" / "ronin_resnet-walking"
PER_SAMPLE = ("p_world_m", "velocity_state_m_s", "q_world_device_wxyz", "gyro_bias_rad_s", "acc_bias_m_s2")
PER_SAMPLE += ("position_cov_xy", "tilt_cov", "imu_world")
PER_UPDATE = ("update_span", "velocity_m_s", "nis", "applied", "covariance")
CONFIG = FilterConfig(heading_reference="causal")


@pytest.fixture(scope="module")
def walk():
    """A 20 s simulated walk (its true orientation is the causal one a phone would stream), the
    default checkpoint as the measurement, and ``run_filter`` on the whole of it."""
    seq = simulate(SimConfig(duration_s=20.0, seed=7))
    network = NetworkVelocity(load_model(DEFAULT_CHECKPOINT), CONFIG)
    heading = np.unwrap(frames.yaw_rad(seq.q_world_device_wxyz))
    whole = run_filter(network, seq, WINDOW, CONFIG, heading_ref_rad=heading)
    return seq, network, whole


def fed_in_chunks(seq, network, sizes) -> tuple[FilterSession, list[int]]:
    session = FilterSession(network, WINDOW, CONFIG)
    i, new_updates = 0, []
    for size in sizes:
        j = min(len(seq), i + size)
        new_updates.append(
            session.extend(seq.t_s[i:j], seq.gyro_rad_s[i:j], seq.acc_m_s2[i:j], seq.q_world_device_wxyz[i:j])
        )
        i = j
        if i == len(seq):
            break
    assert i == len(seq)
    return session, new_updates


def assert_same(run: FilterRun, whole: FilterRun, n: int | None = None) -> None:
    for name in PER_SAMPLE:
        got, want = getattr(run, name), getattr(whole, name)[:n]
        assert got.shape == want.shape, name
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9, err_msg=name)
    m = len(run.nis)
    for name in PER_UPDATE:
        np.testing.assert_allclose(
            getattr(run, name), getattr(whole, name)[:m], rtol=0, atol=1e-9, err_msg=name
        )


@pytest.mark.parametrize(
    "chunking",
    [
        "one sample at a time",
        "half a second",
        "a window and one",
        "uneven",
        "all at once",
    ],
)
def test_any_chunking_gives_the_whole_recordings_estimates(walk, chunking: str) -> None:
    seq, network, whole = walk
    n = len(seq)
    sizes = {
        "one sample at a time": [1] * n,
        "half a second": [50] * (n // 50 + 1),
        "a window and one": [WINDOW + 1] * (n // WINDOW + 1),
        "uneven": list(np.random.default_rng(3).integers(1, 260, n)),
        "all at once": [n],
    }[chunking]
    session, new_updates = fed_in_chunks(seq, network, sizes)
    run = session.result()
    assert_same(run, whole)
    assert sum(new_updates) == len(whole.nis) == (n - 1) // WINDOW  # extend says how many updates it ran
    assert len(whole.nis) > 10 and whole.applied.all()


def test_an_estimate_does_not_change_when_later_samples_arrive(walk) -> None:
    seq, network, _ = walk
    session = FilterSession(network, WINDOW, CONFIG)
    cut = 1234  # mid-window: a clone waits for samples that have not come yet
    session.extend(seq.t_s[:cut], seq.gyro_rad_s[:cut], seq.acc_m_s2[:cut], seq.q_world_device_wxyz[:cut])
    early = {name: np.array(getattr(session.result(), name), copy=True) for name in (*PER_SAMPLE, "nis")}
    assert session.covered_until_s == pytest.approx(seq.t_s[cut - 1])
    session.extend(seq.t_s[cut:], seq.gyro_rad_s[cut:], seq.acc_m_s2[cut:], seq.q_world_device_wxyz[cut:])
    late = session.result()
    assert len(late.t_s) == len(seq) > cut
    for name, before in early.items():
        np.testing.assert_array_equal(getattr(late, name)[: len(before)], before, err_msg=name)
    assert len(late.nis) > len(early["nis"])


def test_the_live_shape_starts_from_the_given_orientation_and_grows_as_a_run(walk) -> None:
    seq, network, _ = walk
    session = FilterSession(network, WINDOW, CONFIG)
    assert session.n_spans == 0 and session.covered_until_s is None
    session.extend(
        seq.t_s[:WINDOW], seq.gyro_rad_s[:WINDOW], seq.acc_m_s2[:WINDOW], seq.q_world_device_wxyz[:WINDOW]
    )
    assert session.n_spans == 0  # a window needs its end sample: no run yet
    np.testing.assert_allclose(
        session.result().q_world_device_wxyz[0], seq.q_world_device_wxyz[0], atol=1e-12
    )
    session.extend(
        seq.t_s[WINDOW:], seq.gyro_rad_s[WINDOW:], seq.acc_m_s2[WINDOW:], seq.q_world_device_wxyz[WINDOW:]
    )
    starts, ends, velocity = session.spans()
    assert np.array_equal(ends - starts, np.full(len(starts), WINDOW))
    mid, span_t = session.span_times()
    np.testing.assert_allclose(span_t, seq.t_s[np.column_stack([starts, ends])])
    # The heading follows the causal orientation's (its reference), the walk moves, nothing is revised.
    run = session.result()
    dpsi = np.angle(
        np.exp(1j * (frames.yaw_rad(run.q_world_device_wxyz) - frames.yaw_rad(seq.q_world_device_wxyz)))
    )
    assert np.degrees(np.abs(dpsi)).max() < 5.0
    steps = np.linalg.norm(np.diff(run.p_world_m[:, :2], axis=0), axis=1).sum()
    assert session.path_length_m() == pytest.approx(steps) and steps > 5.0
    gyro, acc, q = session.imu()  # what was given, as given
    assert np.array_equal(q, seq.q_world_device_wxyz) and np.array_equal(gyro, seq.gyro_rad_s)


def test_a_session_without_a_start_orientation_or_a_network_says_so() -> None:
    with pytest.raises(ValueError, match="network or a measure"):
        FilterSession(None, WINDOW)
    session = FilterSession(lambda rows: (np.zeros(3), np.eye(2)), WINDOW)
    with pytest.raises(ValueError, match="start orientation"):
        session.update(np.arange(3) / 100.0, np.zeros((3, 3)), np.tile([0.0, 0.0, 9.8], (3, 1)))
