"""RoNIN, RIDI, IMUNet, TLIO and RNIN-VIO readers on small files written in each published layout.

Every file is generated from one known motion (device orientation ``R_world_device``, positions
``p_world_m`` and the IMU they imply), stored the way the dataset stores it — other world frames,
scalar-last quaternions, calibration applied backwards, IMU rotated into the world — so each test
checks that the reader undoes exactly that: device-frame IMU, a gravity-aligned orientation, and
ground truth expressed in the orientation's world frame.
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.errors import DataFormatError
from ftin.data.readers import imunet, ridi, rnin, ronin, tlio

G = 9.81
PSI0_DEG = 40.0  # yaw between the dataset's ground-truth world and the device's world
R_GT_DEVICEWORLD = Rotation.from_euler("z", PSI0_DEG, degrees=True)


class Motion:
    """A walk with turns and a swinging phone, 200 Hz, every quantity consistent with the others."""

    def __init__(self, n: int = 1200, rate_hz: float = 200.0) -> None:
        self.t_s = 50.0 + np.arange(n) / rate_hz
        tt = self.t_s - self.t_s[0]
        euler = np.column_stack(
            [0.5 * tt + 0.4 * np.sin(0.8 * tt), 0.3 * np.sin(1.9 * tt), 0.25 * np.sin(1.3 * tt)]
        )
        self.R_world_device = Rotation.from_euler("ZYX", euler)
        self.q_wxyz = frames.make_continuous(frames.wxyz_from_rotation(self.R_world_device))
        self.p_world_m = np.column_stack(
            [1.2 * tt + 0.3 * np.sin(tt), 0.8 * np.sin(0.5 * tt), 0.05 * np.sin(4 * tt)]
        )
        self.v_world_m_s = np.gradient(self.p_world_m, self.t_s, axis=0)
        a_world = np.gradient(self.v_world_m_s, self.t_s, axis=0)
        self.acc_m_s2 = self.R_world_device.inv().apply(a_world + [0.0, 0.0, G])
        self.gyro_rad_s = frames.angular_rate_body(self.t_s, self.q_wxyz)

    def __len__(self) -> int:
        return len(self.t_s)


@pytest.fixture(scope="module")
def motion() -> Motion:
    return Motion()


def angle_deg(q_a_wxyz: np.ndarray, q_b_wxyz: np.ndarray) -> np.ndarray:
    return np.degrees(
        (frames.rotation_from_wxyz(q_a_wxyz).inv() * frames.rotation_from_wxyz(q_b_wxyz)).magnitude()
    )


def wxyz(rotation: Rotation) -> np.ndarray:
    return frames.wxyz_from_rotation(rotation)


def assert_world_is_gravity_aligned(seq) -> None:
    f_world = frames.rotate_to_world(seq.q_world_device_wxyz, seq.acc_m_s2).mean(axis=0)
    assert np.degrees(np.arccos(f_world[2] / np.linalg.norm(f_world))) < 2.0


# --- RoNIN ---------------------------------------------------------------------------------------

GYRO_BIAS = np.array([0.01, -0.02, 0.005])
ACC_BIAS = np.array([0.1, -0.05, 0.2])
ACC_SCALE = np.array([0.99, 1.01, 1.002])


def write_ronin(folder: Path, m: Motion, start_frame: int = 40, drop: tuple[str, ...] = ()) -> Path:
    """``data.hdf5`` + ``info.json``: raw sensors, game_rv in the device world, Tango pose in its own."""
    folder.mkdir(parents=True)
    n = len(m)
    # The chest-mounted Tango phone turns on its own; only at frame 0 is its pose tied to the IMU phone.
    R_tango_chest = R_GT_DEVICEWORLD * Rotation.from_euler("z", 0.3 * (m.t_s - m.t_s[0])[:, None])
    start_calibration = R_tango_chest[0].inv() * R_GT_DEVICEWORLD * m.R_world_device[0]
    datasets = {
        "synced/time": m.t_s,
        "synced/gyro_uncalib": m.gyro_rad_s + GYRO_BIAS,
        "synced/gyro": m.gyro_rad_s + 0.001,
        "synced/acce": m.acc_m_s2 / ACC_SCALE + ACC_BIAS,
        "synced/game_rv": m.q_wxyz,
        "synced/rv": wxyz(Rotation.from_euler("z", 1.0) * m.R_world_device),
        "pose/tango_pos": R_GT_DEVICEWORLD.apply(m.p_world_m),
        "pose/tango_ori": wxyz(R_tango_chest),
        "pose/ekf_ori": m.q_wxyz,
    }
    with h5py.File(folder / "data.hdf5", "w") as f:
        for key, value in datasets.items():
            if key not in drop:
                f[key] = value
        f["synced/magnet"] = np.zeros((n, 3))
    info = {
        "imu_init_gyro_bias": GYRO_BIAS.tolist(),
        "imu_acce_bias": ACC_BIAS.tolist(),
        "imu_acce_scale": ACC_SCALE.tolist(),
        "start_calibration": wxyz(start_calibration).tolist(),
        "start_frame": start_frame,
        "device": "asus4",
        "length": float(m.t_s[-1] - m.t_s[0]),
    }
    (folder / "info.json").write_text(json.dumps(info))
    return folder


def test_ronin_calibrates_aligns_and_trims(tmp_path, motion):
    folder = write_ronin(tmp_path / "a000_1", motion, start_frame=40)
    seq = ronin.read(folder)
    keep = slice(40, None)
    assert seq.name == "a000_1" and len(seq) == len(motion) - 40
    np.testing.assert_allclose(seq.t_s, motion.t_s[keep])
    np.testing.assert_allclose(seq.gyro_rad_s, motion.gyro_rad_s[keep], atol=1e-12)
    np.testing.assert_allclose(seq.acc_m_s2, motion.acc_m_s2[keep], atol=1e-12)
    assert angle_deg(seq.q_world_device_wxyz, motion.q_wxyz[keep]).max() < 1e-6
    np.testing.assert_allclose(seq.gt.p_world_m, motion.p_world_m[keep], atol=1e-9)  # in the device world
    assert seq.meta["gt_yaw_offset_deg"] == pytest.approx(PSI0_DEG, abs=1e-6)
    assert seq.meta["gt_tilt_offset_deg"] == pytest.approx(0.0, abs=1e-6)
    assert seq.meta["dataset"] == "ronin" and seq.meta["orientation_source"] == "device"
    assert seq.meta["rate_hz"] == pytest.approx(200.0) and seq.meta["device"] == "asus4"
    assert any("start_frame" in w for w in seq.meta["warnings"])
    assert_world_is_gravity_aligned(seq)


def test_ronin_options(tmp_path, motion):
    folder = write_ronin(tmp_path / "seq", motion, start_frame=10)
    raw = ronin.read(folder / "data.hdf5", calibrate=False, trim_to_start_frame=False)
    assert len(raw) == len(motion)
    np.testing.assert_allclose(raw.gyro_rad_s, motion.gyro_rad_s + 0.001)
    ekf = ronin.read(folder, orientation="ekf_ori")
    assert ekf.meta["orientation_source"] == "estimated"
    np.testing.assert_allclose(ekf.gt.p_world_m, motion.p_world_m[10:], atol=1e-9)
    with pytest.raises(ValueError):
        ronin.read(folder, orientation="magnetic")


def test_ronin_without_ground_truth_still_reads(tmp_path, motion):
    folder = write_ronin(tmp_path / "seq", motion, drop=("pose/tango_pos",))
    seq = ronin.read(folder)
    assert seq.gt is None and any("no ground truth" in w for w in seq.meta["warnings"])


def test_ronin_errors_name_the_file_and_dataset(tmp_path, motion):
    folder = write_ronin(tmp_path / "seq", motion, drop=("synced/acce",))
    with pytest.raises(DataFormatError, match=r"data\.hdf5: missing dataset 'synced/acce'"):
        ronin.read(folder)
    folder = write_ronin(tmp_path / "short", motion)
    with h5py.File(folder / "data.hdf5", "a") as f:
        del f["synced/game_rv"]
        f["synced/game_rv"] = motion.q_wxyz[:, :3]
    with pytest.raises(DataFormatError, match=r"'synced/game_rv' has shape \(1200, 3\); expected \(N, 4\)"):
        ronin.read(folder)
    (folder / "info.json").write_text("{not json")
    with pytest.raises(DataFormatError, match="info.json: not valid JSON"):
        ronin.read(folder)
    (folder / "info.json").unlink()
    with pytest.raises(DataFormatError, match=r"not a RoNIN sequence folder \(info.json is missing\)"):
        ronin.read(folder)


def test_ronin_bad_start_frame(tmp_path, motion):
    folder = write_ronin(tmp_path / "seq", motion, start_frame=99999)
    with pytest.raises(DataFormatError, match="start_frame must be an integer"):
        ronin.read(folder)


# --- RIDI and IMUNet (shared CSV layout) ---------------------------------------------------------


def write_processed_csv(folder: Path, m: Motion, ori: Rotation, pos: np.ndarray) -> Path:
    """RIDI's ``processed/data.csv``: pandas index column first, ns time, scalar-first quaternions."""
    (folder / "processed").mkdir(parents=True)
    n = len(m)
    columns = {"time": np.round(m.t_s * 1e9)}
    for name, values in (
        ("gyro", m.gyro_rad_s),
        ("acce", m.acc_m_s2),
        ("linacce", m.acc_m_s2 - 1.0),
        ("grav", np.ones((n, 3))),
        ("magnet", np.zeros((n, 3))),
        ("pos", pos),
    ):
        for i, axis in enumerate("xyz"):
            columns[f"{name}_{axis}"] = values[:, i]
    for name, q in (("ori", wxyz(ori)), ("rv", m.q_wxyz)):
        for i, comp in enumerate("wxyz"):
            columns[f"{name}_{comp}"] = q[:, i]
    pd.DataFrame(columns).to_csv(folder / "processed" / "data.csv")  # with the index, as RIDI
    return folder


def test_ridi_aligns_ground_truth_to_the_game_rotation_vector(tmp_path, motion):
    # RIDI: one Tango phone records both, so the Tango orientation is the device's in the Tango world.
    folder = write_processed_csv(
        tmp_path / "dan_body1",
        motion,
        R_GT_DEVICEWORLD * motion.R_world_device,
        R_GT_DEVICEWORLD.apply(motion.p_world_m),
    )
    seq = ridi.read(folder / "processed" / "data.csv")
    assert seq.name == "dan_body1" and seq.meta["carry"] == "body"
    np.testing.assert_allclose(seq.t_s, motion.t_s, atol=1e-9)
    np.testing.assert_array_equal(seq.gyro_rad_s, motion.gyro_rad_s)
    np.testing.assert_array_equal(seq.acc_m_s2, motion.acc_m_s2)
    np.testing.assert_allclose(seq.gt.p_world_m, motion.p_world_m, atol=1e-9)
    assert angle_deg(seq.gt.q_world_body_wxyz, motion.q_wxyz).max() < 1e-6
    assert angle_deg(seq.q_world_device_wxyz, motion.q_wxyz).max() < 1e-6
    assert seq.meta["gt_yaw_offset_deg"] == pytest.approx(-PSI0_DEG, abs=1e-6)
    assert seq.meta["dataset"] == "ridi" and seq.meta["orientation_source"] == "device"
    assert_world_is_gravity_aligned(seq)


@pytest.mark.parametrize(
    ("name", "carry"),
    [("hang_leg2", "pocket"), ("tang_handheld1", "handheld"), ("huayi_bag1", "bag"), ("x", "unknown")],
)
def test_ridi_carry_mode_from_the_sequence_name(name, carry):
    assert ridi.carry_mode(Path(name)) == carry


def test_ridi_missing_columns_are_listed(tmp_path, motion):
    folder = write_processed_csv(tmp_path / "seq", motion, motion.R_world_device, motion.p_world_m)
    table = pd.read_csv(folder / "processed" / "data.csv", index_col=0).drop(columns=["rv_w", "pos_z"])
    table.to_csv(folder / "processed" / "data.csv")
    with pytest.raises(
        DataFormatError, match=r"missing column\(s\) pos_z, rv_w; found columns: Unnamed: 0, time"
    ):
        ridi.read(folder)
    with pytest.raises(DataFormatError, match=r"no processed/data.csv"):
        ridi.read(tmp_path)


def test_ridi_non_numeric_cell_names_line_and_column(tmp_path, motion):
    folder = write_processed_csv(tmp_path / "seq", motion, motion.R_world_device, motion.p_world_m)
    table = pd.read_csv(folder / "processed" / "data.csv", index_col=0)
    table["acce_y"] = table["acce_y"].astype(object)
    table.loc[6, "acce_y"] = "n/a"
    table.to_csv(folder / "processed" / "data.csv")
    with pytest.raises(DataFormatError, match=r"line 8, column 'acce_y'"):
        ridi.read(folder)


R_DEVICE_CAMERA = Rotation.from_euler("zx", [90.0, 180.0], degrees=True)  # camera axes != sensor axes


def write_imunet(folder: Path, m: Motion) -> Path:
    """ARCore pose of the camera in ARCore's y-up world; positions converted to z-up as IMUNet does."""
    ori = imunet.R_ZUP_YUP.inv() * R_GT_DEVICEWORLD * m.R_world_device * R_DEVICE_CAMERA
    write_processed_csv(folder, m, ori, R_GT_DEVICEWORLD.apply(m.p_world_m))
    (folder / "android_sensor_pose.txt").write_text("# Created by the recorder\n")
    return folder


def test_imunet_solves_the_camera_to_device_rotation(tmp_path, motion):
    folder = write_imunet(tmp_path / "recording_7", motion)
    seq = imunet.read(folder)
    assert seq.meta["dataset"] == "imunet" and seq.name == "recording_7"
    solved = frames.rotation_from_wxyz(np.array(seq.meta["q_reference_device_wxyz"]))
    assert np.degrees((solved * R_DEVICE_CAMERA).magnitude()) < 0.5  # = R_camera_device
    assert seq.meta["gt_yaw_offset_deg"] == pytest.approx(-PSI0_DEG, abs=0.5)
    np.testing.assert_allclose(seq.gt.p_world_m, motion.p_world_m, atol=0.05)
    assert angle_deg(seq.gt.q_world_body_wxyz, motion.q_wxyz).max() < 0.5
    assert_world_is_gravity_aligned(seq)


def test_imunet_without_the_extrinsic_solve_warns_about_tilt(tmp_path, motion):
    folder = write_imunet(tmp_path / "recording_7", motion)
    seq = imunet.read(folder, solve_extrinsic=False)
    assert any("tilt" in w for w in seq.meta["warnings"])


def test_ridi_and_imunet_discovery_tell_the_layouts_apart(tmp_path, motion):
    ridi_folder = write_processed_csv(
        tmp_path / "ridi" / "dan_body1", motion, motion.R_world_device, motion.p_world_m
    )
    imunet_folder = write_imunet(tmp_path / "mine" / "rec1", motion)
    named = write_processed_csv(
        tmp_path / "IMUNet_dataset" / "rec2", motion, motion.R_world_device, motion.p_world_m
    )
    assert ridi.discover(tmp_path) == [ridi_folder]
    assert imunet.discover(tmp_path) == [named, imunet_folder]
    assert ridi.claims(ridi_folder / "processed" / "data.csv") and not imunet.claims(ridi_folder)
    assert imunet.claims(imunet_folder / "processed") and not ridi.claims(imunet_folder)


# --- TLIO ----------------------------------------------------------------------------------------

R_ACC = np.array([[1.02, 0.01, 0.0], [0.0, 0.98, 0.02], [0.0, 0.0, 1.01]])
B_ACC = np.array([0.05, -0.1, 0.02])
R_GYR = np.array([[0.99, 0.0, 0.01], [0.0, 1.01, 0.0], [0.02, 0.0, 1.0]])
B_GYR = np.array([0.002, 0.001, -0.003])
RAW_COLUMNS = ["ts_us(1)", "gyr(3)", "acc(3)", "qxyzw_World_Device(4)", "pos_World_Device(3)", "vel_World(3)"]


def write_tlio(folder: Path, m: Motion, description: list[str] | None, calibration: bool = True) -> Path:
    folder.mkdir(parents=True)
    gyro, acc = m.gyro_rad_s, m.acc_m_s2
    if description is not None and "in_World" in description[1]:
        gyro, acc = m.R_world_device.apply(gyro), m.R_world_device.apply(acc)
    elif calibration:  # raw device-frame IMU: undo TLIO's correction a = R^-1 a_raw - b
        gyro, acc = (gyro + B_GYR) @ R_GYR.T, (acc + B_ACC) @ R_ACC.T
    data = np.column_stack(
        [np.round(m.t_s * 1e6), gyro, acc, m.R_world_device.as_quat(), m.p_world_m, m.v_world_m_s]
    )
    np.save(folder / "imu0_resampled.npy", data)
    if description is not None:
        desc = {"columns_name(width)": description, "num_rows": len(m), "approximate_frequency_hz": 200.0}
        (folder / "imu0_resampled_description.json").write_text(json.dumps(desc))
    if calibration:
        calib = {
            "Accelerometer": {"Bias": {"Name": "Constant", "Offset": B_ACC.tolist()},
                              "Model": {"Name": "Linear", "RectificationMatrix": R_ACC.tolist()}},
            "Gyroscope": {"Bias": {"Name": "Constant", "Offset": B_GYR.tolist()},
                          "Model": {"Name": "Linear", "RectificationMatrix": R_GYR.tolist()}},
        }  # fmt: skip
        (folder / "calibration.json").write_text(json.dumps(calib))
    return folder


def test_tlio_published_layout_rotates_imu_back_and_keeps_compensation(tmp_path, motion):
    folder = write_tlio(tmp_path / "1008221029329889", motion, list(tlio.PUBLISHED_DESCRIPTION))
    seq = tlio.read(folder / "imu0_resampled.npy")
    assert seq.name == "1008221029329889" and seq.meta["orientation_source"] == "ground_truth"
    np.testing.assert_allclose(seq.t_s, motion.t_s, atol=1e-6)
    np.testing.assert_allclose(seq.gyro_rad_s, motion.gyro_rad_s, atol=1e-12)
    np.testing.assert_allclose(seq.acc_m_s2, motion.acc_m_s2, atol=1e-12)
    np.testing.assert_allclose(seq.gt.p_world_m, motion.p_world_m)
    assert angle_deg(seq.q_world_device_wxyz, motion.q_wxyz).max() < 1e-6
    assert any("not applied again" in w for w in seq.meta["warnings"])
    assert_world_is_gravity_aligned(seq)


def test_tlio_raw_layout_applies_the_calibration(tmp_path, motion):
    folder = write_tlio(tmp_path / "seq", motion, RAW_COLUMNS)
    seq = tlio.read(folder)
    np.testing.assert_allclose(seq.gyro_rad_s, motion.gyro_rad_s, atol=1e-12)
    np.testing.assert_allclose(seq.acc_m_s2, motion.acc_m_s2, atol=1e-12)
    assert any("applied calibration.json" in w for w in seq.meta["warnings"])
    skipped = tlio.read(folder, calibration="skip")
    assert np.abs(skipped.acc_m_s2 - motion.acc_m_s2).max() > 0.05


def test_tlio_without_description_assumes_the_published_columns(tmp_path, motion):
    write_tlio(tmp_path / "seq", motion, list(tlio.PUBLISHED_DESCRIPTION), calibration=False)
    (tmp_path / "seq" / "imu0_resampled_description.json").unlink()
    seq = tlio.read(tmp_path / "seq")
    np.testing.assert_allclose(seq.gyro_rad_s, motion.gyro_rad_s, atol=1e-12)
    assert any("assumed the published columns" in w for w in seq.meta["warnings"])
    with pytest.raises(DataFormatError, match="calibration='apply' but calibration.json is missing"):
        tlio.read(tmp_path / "seq", calibration="apply")


def test_tlio_errors(tmp_path, motion):
    folder = write_tlio(tmp_path / "seq", motion, RAW_COLUMNS)
    np.save(folder / "imu0_resampled.npy", np.zeros((10, 16)))
    with pytest.raises(
        DataFormatError, match=r"expected a numeric \(N, 17\) array .* got float64 \(10, 16\)"
    ):
        tlio.read(folder)
    write_tlio(tmp_path / "bad_desc", motion, ["ts_us(1)", "gyr(3)", "acc(2)", "q(4)", "p(3)", "v(3)"])
    with pytest.raises(DataFormatError, match="column widths"):
        tlio.read(tmp_path / "bad_desc")
    folder = write_tlio(tmp_path / "bad_calib", motion, RAW_COLUMNS)
    (folder / "calibration.json").write_text(json.dumps({"Accelerometer": {}}))
    with pytest.raises(DataFormatError, match=r"expected Accelerometer.Bias.Offset"):
        tlio.read(folder)
    with pytest.raises(DataFormatError, match="not a TLIO sequence folder"):
        tlio.read(tmp_path)


# --- RNIN-VIO ------------------------------------------------------------------------------------


def write_rnin(folder: Path, m: Motion, placeholder_gt: bool = False) -> Path:
    folder.mkdir(parents=True)
    n = len(m)
    bias = np.tile([0.01, 0.02, -0.01, 0.1, -0.2, 0.05], (n, 1))
    bias[:-1] += 0.5  # only the last row's (converged) estimate is used
    columns = {"time": m.t_s}
    gyro_raw, acc_raw = m.gyro_rad_s + bias[-1, :3], m.acc_m_s2 + bias[-1, 3:]
    q = m.q_wxyz
    gt_p, gt_q = (
        (np.zeros((n, 3)), np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))) if placeholder_gt else (m.p_world_m, q)
    )
    for prefix, values in (
        ("gyro", gyro_raw),
        ("acce", acc_raw),
        ("gt_p", gt_p),
        ("vio_p", m.p_world_m + 0.01),
    ):
        for i, axis in enumerate("xyz"):
            columns[f"{prefix}_{axis}"] = values[:, i]
    for prefix, values in (("gt_q", gt_q), ("vio_q", q)):
        for i, comp in enumerate("wxyz"):
            columns[f"{prefix}_{comp}"] = values[:, i]
    for i, name in enumerate(rnin.BIAS_COLUMNS):
        columns[name] = bias[:, i]
    pd.DataFrame(columns).to_csv(folder / "SenseINS.csv", index=False)
    return folder


def test_rnin_reads_reference_pose_and_subtracts_the_final_vio_bias(tmp_path, motion):
    folder = write_rnin(tmp_path / "data_train" / "3", motion)
    seq = rnin.read(folder / "SenseINS.csv")
    assert seq.name == "data_train/3" and seq.meta["orientation_source"] == "ground_truth"
    np.testing.assert_array_equal(seq.t_s, motion.t_s)
    np.testing.assert_allclose(seq.gyro_rad_s, motion.gyro_rad_s, atol=1e-12)
    np.testing.assert_allclose(seq.acc_m_s2, motion.acc_m_s2, atol=1e-12)
    np.testing.assert_array_equal(seq.gt.p_world_m, motion.p_world_m)
    assert angle_deg(seq.q_world_device_wxyz, motion.q_wxyz).max() < 1e-6
    assert_world_is_gravity_aligned(seq)
    unbiased = rnin.read(folder, subtract_vio_bias=False)
    np.testing.assert_allclose(
        unbiased.gyro_rad_s - seq.gyro_rad_s, np.tile([0.01, 0.02, -0.01], (len(seq), 1))
    )


def test_rnin_placeholder_ground_truth_falls_back_to_vio(tmp_path, motion):
    seq = rnin.read(write_rnin(tmp_path / "7", motion, placeholder_gt=True))
    np.testing.assert_allclose(seq.gt.p_world_m, motion.p_world_m + 0.01)
    assert any("used the VIO pose" in w for w in seq.meta["warnings"])


def test_rnin_missing_columns_are_listed(tmp_path, motion):
    folder = write_rnin(tmp_path / "7", motion)
    table = pd.read_csv(folder / "SenseINS.csv").drop(columns=["acce_z", "gt_q_w"])
    table.to_csv(folder / "SenseINS.csv", index=False)
    with pytest.raises(
        DataFormatError, match=r"SenseINS.csv: missing column\(s\) acce_z, gt_q_w; found columns: time"
    ):
        rnin.read(folder)


def test_rnin_decreasing_time_names_the_line(tmp_path, motion):
    folder = write_rnin(tmp_path / "7", motion)
    table = pd.read_csv(folder / "SenseINS.csv")
    table.loc[100, "time"] = table.loc[98, "time"]
    table.to_csv(folder / "SenseINS.csv", index=False)
    with pytest.raises(DataFormatError, match=r"line 102, column 'time'.*earlier than the previous one"):
        rnin.read(folder)
