"""TUM export (evo's reader parses it) and resampling at other timestamps."""

from __future__ import annotations

import io

import numpy as np
import pytest
from evo.tools import file_interface
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.trajectory_io import at_times, read_tum, tum_text
from ftin.data.types import Trajectory


def spiral(n: int = 200, rate_hz: float = 100.0, with_q: bool = True) -> Trajectory:
    t = np.arange(n) / rate_hz + 3.0
    p = np.column_stack([np.cos(t), np.sin(t), 0.1 * t])
    q = frames.wxyz_from_rotation(Rotation.from_euler("z", t[:, None])) if with_q else None
    return Trajectory(t, p, q)


@pytest.mark.parametrize("with_q", [True, False])
def test_tum_round_trip_and_evo_reads_it(with_q):
    traj = spiral(with_q=with_q)
    text = tum_text(traj, "a comment\non two lines")
    back = read_tum(text)
    np.testing.assert_array_equal(back.t_s, traj.t_s)
    np.testing.assert_array_equal(back.p_world_m, traj.p_world_m)
    if with_q:
        np.testing.assert_array_equal(back.q_world_body_wxyz, traj.q_world_body_wxyz)
    else:
        assert "identity quaternions" in text
    evo = file_interface.read_tum_trajectory_file(io.StringIO(text))
    np.testing.assert_allclose(evo.positions_xyz, traj.p_world_m)
    np.testing.assert_allclose(evo.timestamps, traj.t_s)
    if with_q:  # evo stores wxyz too
        np.testing.assert_allclose(
            np.abs(np.sum(evo.orientations_quat_wxyz * traj.q_world_body_wxyz, axis=1)), 1.0
        )


def test_read_tum_names_the_bad_line():
    with pytest.raises(DataFormatError, match="line 2 has 3 values"):
        read_tum("# header\n1 2 3\n")


def test_at_times_interpolates_inside_the_span_only():
    traj = spiral(n=101)  # 3.00 .. 4.00 s at 100 Hz
    fine = np.arange(2.99, 4.02, 0.005)
    out = at_times(traj, fine)
    assert out.t_s[0] >= 3.0 - 1e-9 and out.t_s[-1] <= 4.0 + 1e-9 and len(out) == 201
    np.testing.assert_allclose(out.p_world_m[:, 0], np.cos(out.t_s), atol=5e-5)
    np.testing.assert_allclose(
        frames.yaw_rad(out.q_world_body_wxyz), out.t_s - 2 * np.pi * (out.t_s > np.pi), atol=1e-9
    )
