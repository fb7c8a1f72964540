"""The Inria attitude benchmark reader on the shared real walks: every walk, units, frames, mocap gaps."""

from __future__ import annotations

import gzip
import json
import shutil

import numpy as np
import pytest
from scipy.io import loadmat
from scipy.ndimage import uniform_filter1d
from typer.testing import CliRunner

from ftin.cli import app
from ftin.data import frames
from ftin.data.discovery import detect_format, list_sequences, read_sequence
from ftin.data.errors import DataFormatError
from ftin.data.io import qualisys
from ftin.data.readers import inria_attitude
from ftin.data.windows import WindowDataset, window_starts

GLITCHY = "android/Thibaud_Nexus5_Dist_FrontPocket"  # 6.9 % NaN frames, 170 frame pairs above 15 rad/s
SHORT_WALK = "Guillaume_Nexus5_NoDist_AR"  # its gyroscope stops for 24 s mid-walk


@pytest.fixture(scope="module")
def datasets(shared_dataset):
    return shared_dataset("inria_attitude") / "datasets"


def walk_summary(seq) -> dict:
    """What the tests check of one walk, so that 84 walks need not stay in memory."""
    tracked = seq.gt.tracked
    f_world = frames.rotation_from_wxyz(seq.gt.q_world_body_wxyz).apply(seq.acc_m_s2)[tracked].mean(axis=0)
    f_device_world = frames.rotation_from_wxyz(seq.q_world_device_wxyz).apply(seq.acc_m_s2).mean(axis=0)
    # The path over a 1 s mean: the carry motion (a swinging hand) would lengthen it by up to ~35 %.
    smooth = uniform_filter1d(seq.gt.p_world_m, int(round(seq.rate_hz)), axis=0)
    return {
        "meta": seq.meta,
        "duration_s": seq.duration_s,
        "rate_hz": seq.rate_hz,
        "f_world": f_world,
        "f_device_world": f_device_world,
        "path_m": float(np.linalg.norm(np.diff(smooth[:, :2], axis=0), axis=1).sum()),
        "extent_m": np.ptp(seq.gt.p_world_m[:, :2], axis=0),
        "mag_norm_uT": float(np.median(np.linalg.norm(seq.mag_uT, axis=1))),
        "finite": all(np.isfinite(a).all() for a in (seq.gt.p_world_m, seq.gt.q_world_body_wxyz, seq.mag_uT)),
    }


@pytest.fixture(scope="module")
def walks(datasets):
    return {path.name: walk_summary(inria_attitude.read(path)) for path in inria_attitude.discover(datasets)}


def test_every_walk_is_found_and_read(walks):
    assert len(walks) == 84
    platforms = {w["meta"]["platform"] for w in walks.values()}
    assert platforms == {"android", "ios"}
    assert sum(w["meta"]["magnetic_disturbance"] for w in walks.values()) == 36  # no Dist running walks
    assert {w["meta"]["carry"] for w in walks.values()} == {"handheld", "swinging", "pocket"}
    for name, w in walks.items():
        meta = w["meta"]
        assert meta["dataset"] == "inria_attitude" and meta["orientation_source"] == "device"
        walker, phone, dist, motion = name.split("_")
        assert (meta["walker"], meta["phone"], meta["motion"]) == (walker, phone, motion)
        assert meta["magnetic_disturbance"] == (dist == "Dist")
        assert w["finite"], name
        # Cropped to the 120 s capture; a walk with a sensor hole is cut to its longest stretch, and says so.
        assert 60.0 < w["duration_s"] <= 121.5, name
        if w["duration_s"] < 115.0:
            assert any(m.startswith("sensor gaps") for m in meta["warnings"]), name
        assert 0.8 < meta["tracked_fraction"] <= 1.0, name
        # Column-major rotations make the rigid body the phone within a few degrees (row-major: tens).
        assert meta["body_device_deg"] < 4.0, name
        assert abs(meta["time_shift_s"]) < 0.1, name
    assert walks[SHORT_WALK]["duration_s"] < 70.0


def test_units_and_frames(walks):
    for name, w in walks.items():
        running = "Running" in name
        f_world, f_device = w["f_world"], w["f_device_world"]
        # Specific force in the mocap world: gravity up; running walks clip at +-2 g (Nexus 5, 4S).
        assert (6.0 if running else 9.4) < f_world[2] < 10.1, (name, f_world)
        assert np.hypot(*f_world[:2]) < 0.2, (name, f_world)
        # The phone's own attitude is looser: 9-15 deg of tilt on swinging iPhone walks (README), and
        # CoreMotion loses gravity altogether on one running walk.
        if not running:
            assert 8.5 < f_device[2] < 10.2, (name, f_device)
        assert 15.0 < w["mag_norm_uT"] < 90.0, name  # the Earth's field is 25-65 µT, disturbed nearby
        assert (80.0 if running else 60.0) < w["rate_hz"] < 210.0, name
        # A loop in a ~5 x 6 m room: 10-260 m of 1 s-smoothed path in two minutes.
        assert 8.0 < w["path_m"] < 260.0, (name, w["path_m"])
        assert (w["extent_m"] < 7.0).all() and (w["extent_m"] > 1.0).all(), name


def test_rotation_glitches_and_nan_frames_are_marked_and_repaired(datasets):
    mat = datasets / "qualisys" / f"{GLITCHY.split('/')[1]}.mat"
    raw = next(v for k, v in loadmat(mat, squeeze_me=True, struct_as_record=False).items() if k[0] != "_")
    nan_frames = int(np.isnan(raw.RigidBodies.Positions).any(axis=0).sum())
    mocap = qualisys.read_mocap(mat)
    assert mocap.untracked_frames == nan_frames > 100
    assert mocap.glitch_frames > 50
    assert np.isfinite(mocap.p_m).all() and np.isfinite(mocap.q_world_body_wxyz).all()
    # No tracked frame pair turns faster than the glitch limit, and nothing untracked is called tracked.
    R = frames.rotation_from_wxyz(mocap.q_world_body_wxyz)
    rate = (R[:-1].inv() * R[1:]).magnitude() * 60.0
    both = mocap.tracked[1:] & mocap.tracked[:-1]
    assert rate[both].max() < 15.0
    assert rate[~both].max() > 15.0  # the glitches are really there, inside the untracked frames
    assert not mocap.tracked[np.isnan(raw.RigidBodies.Positions).any(axis=0)].any()

    seq = read_sequence(datasets / GLITCHY)
    assert 0.8 < seq.meta["tracked_fraction"] < 0.95
    assert any("untracked" in w and "glitching" in w for w in seq.meta["warnings"])


def test_untracked_samples_never_become_targets(datasets):
    seq = read_sequence(datasets / GLITCHY)
    window = int(round(seq.rate_hz))
    dataset = WindowDataset([seq], window, window // 5, parts=1, augment_yaw=False)
    every = window_starts(len(seq), window, window // 5)
    assert 0 < len(dataset.starts) < len(every)
    tracked = seq.gt.tracked
    assert tracked[dataset.starts].all() and tracked[dataset.starts + window].all()


def test_txt_and_txt_gz_read_the_same(datasets, tmp_path):
    platform, name = GLITCHY.split("/")
    copy = tmp_path / "datasets" / platform / name
    copy.mkdir(parents=True)
    for item in (datasets / GLITCHY).iterdir():
        if item.name.endswith(".txt.gz"):
            with gzip.open(item, "rb") as source, open(copy / item.name[:-3], "wb") as target:
                shutil.copyfileobj(source, target)
        else:
            shutil.copy(item, copy / item.name)
    (tmp_path / "datasets" / "qualisys").mkdir()
    shutil.copy(datasets / "qualisys" / f"{name}.mat", tmp_path / "datasets" / "qualisys" / f"{name}.MAT")
    assert not list(copy.glob("*.gz"))
    assert detect_format(copy) == "inria_attitude"
    plain, packed = read_sequence(copy), read_sequence(datasets / GLITCHY)
    for a, b in (
        (plain.acc_m_s2, packed.acc_m_s2),
        (plain.gyro_rad_s, packed.gyro_rad_s),
        (plain.mag_uT, packed.mag_uT),
        (plain.q_world_device_wxyz, packed.q_world_device_wxyz),
        (plain.gt.p_world_m, packed.gt.p_world_m),
    ):
        np.testing.assert_array_equal(a, b)

    result = CliRunner().invoke(app, ["data", "info", str(tmp_path), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["formats"] == ["inria_attitude"]
    (listed,) = report["sequences"]
    assert listed["name"] == f"datasets/{GLITCHY}" and listed["has_gt"] and listed["has_magnetometer"]
    assert listed["carry"] == "pocket" and listed["orientation_source"] == "device"
    assert [ref.name for ref in list_sequences(tmp_path)] == [f"datasets/{GLITCHY}"]


def test_ground_truth_orientation_and_device_world(datasets):
    device = read_sequence(datasets / "ios/Thibaud_iPhone5_NoDist_Texting")
    truth = read_sequence(datasets / "ios/Thibaud_iPhone5_NoDist_Texting", orientation="ground_truth")
    assert np.allclose(truth.q_world_device_wxyz, truth.gt.q_world_body_wxyz)
    assert truth.meta["gt_yaw_offset_deg"] == 0.0
    yaw = np.radians(device.meta["gt_yaw_offset_deg"])
    R = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
    moved = truth.gt.p_world_m[:, :2] @ R.T
    assert np.allclose(moved, device.gt.p_world_m[:, :2], atol=1e-4)  # the yaw is rounded in meta
    # The phone's attitude agrees with the mocap's tilt (README: median 1.5-3.2 deg on iOS).
    up = np.array([0.0, 0.0, 1.0])
    u_dev = frames.rotation_from_wxyz(device.q_world_device_wxyz).inv().apply(up)
    u_true = frames.rotation_from_wxyz(device.gt.q_world_body_wxyz).inv().apply(up)
    assert np.median(np.degrees(np.arccos(np.clip((u_dev * u_true).sum(axis=1), -1, 1)))) < 4.0


def test_a_walk_without_its_capture_is_refused(datasets, tmp_path):
    copy = tmp_path / "datasets" / "android" / "Thibaud_Nexus5_NoDist_AR"
    shutil.copytree(datasets / "android" / "Thibaud_Nexus5_NoDist_AR", copy)
    assert not inria_attitude.claims(copy)
    with pytest.raises(
        DataFormatError, match=r"Qualisys capture qualisys/Thibaud_Nexus5_NoDist_AR\.mat is missing"
    ):
        inria_attitude.read(copy)


@pytest.mark.parametrize("dataset", ["oxiod/handheld/data1/syn/imu3.csv", "ridi/dan_bag1"])
def test_oxiod_and_ridi_expose_their_magnetometer(shared_data, dataset):
    path = shared_data / dataset
    if not path.exists():
        pytest.skip(f"no {path}")
    seq = read_sequence(path)
    assert seq.mag_uT is not None and seq.mag_uT.shape == (len(seq), 3)
    assert 15.0 < float(np.median(np.linalg.norm(seq.mag_uT, axis=1))) < 90.0


def test_a_broken_sensor_file_is_named(datasets, tmp_path):
    platform, name = GLITCHY.split("/")
    copy = tmp_path / "datasets" / platform / name
    shutil.copytree(datasets / GLITCHY, copy)
    (tmp_path / "datasets" / "qualisys").mkdir()
    shutil.copy(datasets / "qualisys" / f"{name}.mat", tmp_path / "datasets" / "qualisys")
    with gzip.open(copy / "gyroscope-calibrated.txt.gz", "rt") as handle:
        lines = handle.read().splitlines()
    (copy / "gyroscope-calibrated.txt.gz").unlink()
    lines[41] = "0.5 0.1"  # a cut line
    (copy / "gyroscope-calibrated.txt").write_text("\n".join(lines) + "\n")
    with pytest.raises(DataFormatError, match=r"gyroscope-calibrated\.txt: line 42 has 2 columns"):
        read_sequence(copy)
    (copy / "timeAlignment.txt").write_text("soon\n")
    with pytest.raises(DataFormatError, match=r"timeAlignment\.txt: expected one number"):
        read_sequence(copy)
