"""EuRoC ASL reader: real sequences from ../shared/data and small files written here in that layout."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.readers import euroc
from ftin.data.windows import world_imu

IMU_HEADER = (
    "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
    "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]"
)
GT_HEADER = (
    "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], "
    "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], "
    "b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]"
)
T0_NS = 1403636579758555392


# ---------------------------------------------------------------- real data


@pytest.fixture(scope="module")
def euroc_root(shared_dataset) -> Path:
    return shared_dataset("euroc")


@pytest.fixture(scope="module")
def real_sequences(euroc_root: Path):
    return [euroc.read(path) for path in euroc.discover(euroc_root)]


def test_discover_finds_every_sequence_folder(euroc_root: Path):
    found = euroc.discover(euroc_root)
    assert [p.name for p in found] == [
        "MH_04_difficult",
        "MH_05_difficult",
        "V1_02_medium",
        "V2_01_easy",
        "V2_02_medium",
    ]
    assert all((p / "mav0" / "imu0" / "data.csv").is_file() for p in found)
    assert euroc.discover(euroc_root.parent) == found  # recursive from higher up
    assert euroc.discover(found[0]) == [found[0]]


def test_real_sequences_rate_meta_and_ground_truth_span(real_sequences):
    assert len(real_sequences) == 5
    for seq in real_sequences:
        assert seq.meta["dataset"] == "euroc" and seq.meta["carry"] == "mav"
        assert seq.meta["orientation_source"] == "ground_truth"
        assert seq.meta["rate_hz"] == 200.0
        assert seq.rate_hz == pytest.approx(200.0, rel=1e-3)
        assert 80.0 < seq.duration_s < 120.0
        assert seq.gt is not None and len(seq.gt) == len(seq)
        np.testing.assert_array_equal(seq.gt.t_s, seq.t_s)


def test_real_world_frame_specific_force_is_gravity_up(real_sequences):
    for seq in real_sequences:
        _, acc_world = np.split(world_imu(seq, np.float64), 2, axis=1)
        mean = acc_world.mean(axis=0)
        assert mean[2] == pytest.approx(9.81, abs=0.2), seq.name
        assert np.hypot(mean[0], mean[1]) < 0.3, seq.name


def test_real_positions_differentiate_to_the_velocity_column(real_sequences, euroc_root: Path):
    for seq in real_sequences:
        gt_file = euroc_root / seq.name / euroc.GT_FILE
        raw = pd.read_csv(gt_file, comment="#", header=None, dtype={0: np.int64})
        gt_t_s = (raw[0].to_numpy() - seq.meta["t0_ns"]) * 1e-9
        velocity = np.column_stack([np.interp(seq.t_s, gt_t_s, raw[8 + i].to_numpy()) for i in range(3)])
        differenced = np.gradient(seq.gt.p_world_m, seq.t_s, axis=0)
        error = np.linalg.norm(differenced - velocity, axis=1)
        speed = np.linalg.norm(velocity, axis=1)
        # The estimate has a few mm-steps of its own (MH_04), hence median and 95th percentile.
        assert np.median(error) < 0.02 * max(1.0, np.median(speed)), seq.name
        assert np.percentile(error, 95) < 0.05, seq.name


# ---------------------------------------------------------------- files written here


def _write_sequence(folder: Path, n_imu: int = 400, gt_every: int = 2, gt_offset: int = 20) -> dict:
    """A 200 Hz EuRoC-layout sequence: a constant yaw rate about z, moving along x at 1 m/s."""
    t_imu_ns = T0_NS + np.arange(n_imu, dtype=np.int64) * 5_000_000
    yaw_rate = 0.5
    gyro = np.tile([0.0, 0.0, yaw_rate], (n_imu, 1))
    acc = np.tile([0.0, 0.0, 9.81], (n_imu, 1))
    imu_dir = folder / "mav0" / "imu0"
    imu_dir.mkdir(parents=True)
    rows = [IMU_HEADER] + [
        f"{t},{','.join(f'{x:.9f}' for x in (*g, *a))}" for t, g, a in zip(t_imu_ns, gyro, acc, strict=True)
    ]
    (imu_dir / "data.csv").write_text("\n".join(rows) + "\n")

    gt_idx = np.arange(gt_offset, n_imu - gt_offset, gt_every)
    t_gt_ns = t_imu_ns[gt_idx]
    t_gt_s = (t_gt_ns - T0_NS) * 1e-9
    q_wxyz = frames.wxyz_from_rotation(Rotation.from_rotvec(np.outer(yaw_rate * t_gt_s, [0.0, 0.0, 1.0])))
    p = np.column_stack([t_gt_s, np.zeros_like(t_gt_s), np.full_like(t_gt_s, 1.5)])
    gt_dir = folder / "mav0" / "state_groundtruth_estimate0"
    gt_dir.mkdir(parents=True)
    rows = [GT_HEADER] + [
        f"{t},{','.join(f'{x:.6f}' for x in (*pi, *qi, 1.0, 0.0, 0.0, *np.zeros(6)))}"
        for t, pi, qi in zip(t_gt_ns, p, q_wxyz, strict=True)
    ]
    (gt_dir / "data.csv").write_text("\n".join(rows) + "\n")
    return {"t_imu_ns": t_imu_ns, "t_gt_ns": t_gt_ns, "yaw_rate": yaw_rate}


def test_written_sequence_interpolates_ground_truth_onto_imu_times(tmp_path: Path):
    info = _write_sequence(tmp_path / "SEQ_A")
    seq = euroc.read(tmp_path / "SEQ_A")
    # Only IMU samples inside the ground-truth span are kept.
    assert seq.t_s[0] == pytest.approx((info["t_gt_ns"][0] - T0_NS) * 1e-9, abs=1e-9)
    assert seq.t_s[-1] == pytest.approx((info["t_gt_ns"][-1] - T0_NS) * 1e-9, abs=1e-9)
    assert len(seq) == (info["t_gt_ns"][-1] - info["t_gt_ns"][0]) // 5_000_000 + 1
    assert seq.meta["t0_ns"] == T0_NS and seq.name == "SEQ_A"
    # IMU samples halfway between gt rows: positions linear, orientation by Slerp.
    np.testing.assert_allclose(seq.gt.p_world_m[:, 0], seq.t_s, atol=2e-6)
    yaw = frames.yaw_rad(seq.q_world_device_wxyz)
    np.testing.assert_allclose(np.unwrap(yaw), info["yaw_rate"] * seq.t_s, atol=2e-6)
    np.testing.assert_array_equal(seq.gyro_rad_s[:, 2], info["yaw_rate"])


def test_read_accepts_mav0_folder_or_imu_file(tmp_path: Path):
    _write_sequence(tmp_path / "SEQ_B", n_imu=100)
    by_folder = euroc.read(tmp_path / "SEQ_B")
    for other in (tmp_path / "SEQ_B" / "mav0", tmp_path / "SEQ_B" / euroc.IMU_FILE):
        np.testing.assert_array_equal(euroc.read(other).t_s, by_folder.t_s)
    assert euroc.discover(tmp_path) == [tmp_path / "SEQ_B"]


def test_read_reports_bad_files(tmp_path: Path):
    with pytest.raises(DataFormatError, match="not an EuRoC sequence folder"):
        euroc.read(tmp_path)
    with pytest.raises(DataFormatError, match="no such directory"):
        euroc.discover(tmp_path / "missing")

    _write_sequence(tmp_path / "NO_GT", n_imu=100)
    (tmp_path / "NO_GT" / euroc.GT_FILE).unlink()
    with pytest.raises(DataFormatError, match=r"state_groundtruth_estimate0.*missing"):
        euroc.read(tmp_path / "NO_GT")

    _write_sequence(tmp_path / "BAD_VALUE", n_imu=100)
    imu_file = tmp_path / "BAD_VALUE" / euroc.IMU_FILE
    lines = imu_file.read_text().splitlines()
    lines[5] = lines[5].replace(",0.000000000,", ",abc,", 1)
    imu_file.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataFormatError, match=r"imu0/data.csv: line 6, column 1: .*'abc'"):
        euroc.read(tmp_path / "BAD_VALUE")

    _write_sequence(tmp_path / "BACKWARDS", n_imu=100)
    imu_file = tmp_path / "BACKWARDS" / euroc.IMU_FILE
    lines = imu_file.read_text().splitlines()
    lines[10], lines[11] = lines[11], lines[10]
    imu_file.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataFormatError, match="line 12: timestamp .* does not come after"):
        euroc.read(tmp_path / "BACKWARDS")

    _write_sequence(tmp_path / "FEW_COLUMNS", n_imu=100)
    gt_file = tmp_path / "FEW_COLUMNS" / euroc.GT_FILE
    gt_file.write_text("\n".join(",".join(line.split(",")[:5]) for line in gt_file.read_text().splitlines()))
    with pytest.raises(DataFormatError, match="expected at least 8 comma-separated columns"):
        euroc.read(tmp_path / "FEW_COLUMNS")
