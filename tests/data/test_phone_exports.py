"""Phone app exports: Sensor Logger and phyphox, as folders, ZIPs and upload bytes.

Synthetic exports are written from one known motion (a phone turning and tilting), in the layouts
we have no real file for (2021 header, Android 500 Hz gyroscope, iOS g units and signs, phyphox with
a gyroscope, a ZIP with a top-level folder); the real shared exports check the same facts when
``../shared/data`` is present.
"""

from __future__ import annotations

import gzip
import io
import zipfile
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ftin.data import frames
from ftin.data.discovery import detect_format, list_sequences, read_sequence
from ftin.data.errors import DataFormatError
from ftin.data.from_bytes import read_bytes
from ftin.data.io import sensor_clock
from ftin.data.io.phone_exports import MAX_RATIO
from ftin.data.readers import phyphox, sensorlogger

G = 9.80665
T0_NS = 1_711_795_430_105_320_700


def rotation(t: np.ndarray) -> Rotation:
    """World-from-device: turning about z, rocking about x and y (so every axis is exercised)."""
    return (
        Rotation.from_euler("z", 0.6 * t[:, None])
        * Rotation.from_euler("x", 0.4 * np.sin(0.9 * t)[:, None])
        * Rotation.from_euler("y", 0.3 * np.sin(0.5 * t)[:, None])
    )


def truth(t: np.ndarray) -> dict[str, np.ndarray]:
    R = rotation(t)
    h = 1e-5
    gyro = (rotation(t).inv() * rotation(t + h)).as_rotvec() / h  # body rate, rad/s
    step = 2 * np.pi * 1.9 * t  # a walker's own acceleration: steps at ~2 Hz
    a_world = np.column_stack([0.8 * np.sin(step), 0.5 * np.cos(0.5 * step), 1.5 * np.sin(step + 1.0)])
    up = np.array([0.0, 0.0, G])
    return {
        "gyro": gyro,
        "f": R.inv().apply(a_world + up),  # specific force, +g up at rest (Android / ours)
        "gravity": R.inv().apply(np.tile(up, (len(t), 1))),
        "q": frames.wxyz_from_rotation(R),
    }


def axis_csv(t: np.ndarray, values: np.ndarray, layout: str = "2024", order: str = "zyx") -> str:
    ns = T0_NS + np.round(t * 1e9).astype(np.int64)
    cols = {"x": values[:, 0], "y": values[:, 1], "z": values[:, 2]}
    header = ["time", "seconds_elapsed", *order] if layout == "2024" else ["time", *order]
    lines = [",".join(header)]
    for i in range(len(t)):
        cells = [str(ns[i])] + ([repr(float(t[i]))] if layout == "2024" else [])
        cells += [repr(float(cols[a][i])) for a in order]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


def orientation_csv(t: np.ndarray, q_wxyz: np.ndarray) -> str:
    ns = T0_NS + np.round(t * 1e9).astype(np.int64)
    lines = ["time,seconds_elapsed,yaw,qx,qz,roll,qw,qy,pitch"]  # any column order, as iOS writes it
    for i in range(len(t)):
        w, x, y, z = (float(v) for v in q_wxyz[i])
        lines.append(f"{ns[i]},{float(t[i])!r},0.1,{x!r},{z!r},0.2,{w!r},{y!r},0.3")
    return "\n".join(lines) + "\n"


def metadata_csv(platform: str) -> str:
    return (
        "version,device name,recording time,platform,appVersion,device id,sensors,sampleRateMs\n"
        f"3,phone,2024-03-30_10-43-49,{platform},1.27.1,id,Accelerometer|Gravity|Gyroscope,10|10|10\n"
    )


def sensor_logger(
    *,
    platform: str = "android",
    layout: str = "2024",
    acc_rate: float = 100.0,
    gyro_rate: float = 100.0,
    duration_s: float = 20.0,
    units: str = "m/s^2",
    orientation: bool = True,
    gravity: bool = True,
    gyroscope: bool = True,
    gyro_deg: bool = False,
) -> dict[str, str]:
    t_acc = np.arange(int(duration_s * acc_rate)) / acc_rate
    t_gyro = np.arange(int(duration_s * gyro_rate)) / gyro_rate + 0.0013  # another clock
    ta, tg = truth(t_acc), truth(t_gyro)
    sign = -1.0 if platform == "ios" else 1.0  # iOS reports gravity downwards
    scale = 1.0 / G if units == "g" else 1.0
    files = {
        "Accelerometer.csv": axis_csv(t_acc, sign * (ta["f"] - ta["gravity"]) * scale, layout),
        "Metadata.csv": metadata_csv(platform),
    }
    if gravity:
        files["Gravity.csv"] = axis_csv(t_acc, sign * ta["gravity"] * scale, layout)
    if gyroscope:
        gyro = np.degrees(tg["gyro"]) if gyro_deg else tg["gyro"]
        files["Gyroscope.csv"] = axis_csv(t_gyro, gyro, layout, order="xzy")
    if orientation:
        files["Orientation.csv"] = orientation_csv(t_acc, ta["q"])
    return files


def write_folder(folder: Path, files: dict[str, str]) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (folder / name).write_text(text)
    return folder


def zip_bytes(files: dict[str, str], folder: str = "") -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, text in files.items():
            archive.writestr(f"{folder}{name}", text)
    return buffer.getvalue()


def check_against_truth(seq, gyro_tol: float = 0.02, acc_tol: float = 0.05) -> None:
    # Files start at t = 0 (acc) and 0.0013 s (gyro): the merged clock starts where both exist.
    expected = truth(seq.t_s + 0.0013)
    np.testing.assert_allclose(seq.gyro_rad_s, expected["gyro"], atol=gyro_tol)
    np.testing.assert_allclose(seq.acc_m_s2, expected["f"], atol=acc_tol)


def test_android_2024_folder(tmp_path):
    folder = write_folder(tmp_path / "walk", sensor_logger())
    assert sensorlogger.claims(folder) and detect_format(folder) == "sensorlogger"
    seq = read_sequence(folder)
    assert seq.meta["dataset"] == "sensorlogger" and seq.rate_hz == pytest.approx(100.0)
    assert seq.meta["orientation_source"] == "device"
    check_against_truth(seq)
    np.testing.assert_allclose(
        frames.rotate_to_world(seq.q_world_device_wxyz, seq.acc_m_s2).mean(axis=0)[2], G, atol=0.1
    )


def test_2021_layout_ios_in_g_without_orientation_zip_with_top_folder():
    files = sensor_logger(platform="ios", layout="2021", units="g", orientation=False)
    seq = read_bytes(zip_bytes(files, folder="2021-05-01_10-00-00/"), "2021-05-01_10-00-00.zip")
    assert seq.name == "2021-05-01_10-00-00" and seq.q_world_device_wxyz is None
    check_against_truth(seq)  # units (g) and sign (iOS) derived: specific force +g up
    assert any("read in g" in w for w in seq.meta["notes"])
    assert any("iOS" in w for w in seq.meta["notes"])


def test_ios_sign_from_the_orientation_alone():
    ios = sensor_logger(platform="ios", orientation=True)
    ios.pop("Metadata.csv")  # no platform: the orientation alone must tell the sign
    seq = read_bytes(zip_bytes(ios), "ios.zip")
    check_against_truth(seq)
    assert any("gravity points down" in w for w in seq.meta["notes"])


def test_android_gyroscope_at_500_hz_beside_a_100_hz_accelerometer():
    seq = read_bytes(zip_bytes(sensor_logger(gyro_rate=500.0)), "fast-gyro.zip")
    assert seq.rate_hz == pytest.approx(100.0, rel=1e-6)  # the slower sensor's rate
    # Averaged over each 10 ms interval (no aliasing): close to the instantaneous truth for this motion.
    check_against_truth(seq, gyro_tol=0.01)
    assert seq.meta["sensor_rates_hz"]["Gyroscope.csv"] == pytest.approx(500.0, rel=1e-3)


def test_a_stated_gyroscope_unit_wins_over_the_gravity_turn_fit():
    # Sensor Logger documents rad/s: rates that turn gravity 57x too fast are not silently rescaled;
    # the fit only warns with both numbers, and the rates (above any phone's full scale) are refused.
    with pytest.raises(DataFormatError, match="looks like deg/s"):
        read_bytes(zip_bytes(sensor_logger(gyro_deg=True)), "deg.zip")
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 20.0, 0.01)
    angle = 0.6 * np.sin(2 * np.pi * 0.2 * t)  # the phone tilts slowly about x
    up = np.column_stack([np.zeros_like(t), np.sin(angle), np.cos(angle)])
    gyro = np.column_stack([np.gradient(angle, t), np.zeros_like(t), np.zeros_like(t)])
    gyro = gyro + 0.05 * rng.standard_normal(gyro.shape)
    warnings: list[str] = []
    assert sensor_clock.gyro_scale_from_gravity(t, gyro, up, "walk", warnings) == pytest.approx(1.0)
    deg = np.degrees(gyro)
    assert sensor_clock.gyro_scale_from_gravity(t, deg, up, "walk", warnings) == pytest.approx(np.pi / 180)
    assert "deg/s, converted" in warnings[-1]
    kept = sensor_clock.gyro_scale_from_gravity(t, deg, up, "walk", warnings, stated_unit="rad/s (header)")
    assert kept == 1.0 and "rad/s (header) kept as stated" in warnings[-1] and "fits 0.017" in warnings[-1]


def test_the_gravity_turn_fit_is_not_biased_by_the_step_wobble_of_a_walk():
    # A walk: slow tilt plus a 2 Hz wobble the low-passed gravity direction cannot follow.
    t = np.arange(0.0, 60.0, 0.01)
    slow = 0.5 * np.sin(2 * np.pi * 0.1 * t)
    wobble = 0.15 * np.sin(2 * np.pi * 2.0 * t)
    tilt = slow + wobble
    acc = 9.81 * np.column_stack([np.zeros_like(t), np.sin(tilt), np.cos(tilt)])
    gyro = np.column_stack([np.gradient(tilt, t), np.zeros_like(t), np.zeros_like(t)])
    up = sensor_clock.low_pass(acc, t)
    warnings: list[str] = []
    assert sensor_clock.gyro_scale_from_gravity(t, gyro, up, "walk", warnings) == 1.0
    assert not warnings


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"gyroscope": False}, r"no gyroscope \(Gyroscope.csv\).*Sensor Logger"),
        ({"gravity": False}, r"without gravity.*record Gravity"),
    ],
)
def test_what_cannot_give_a_trajectory_names_the_missing_sensor(change, message):
    with pytest.raises(DataFormatError, match=message):
        read_bytes(zip_bytes(sensor_logger(**change)), "bad.zip")


def phyphox_csv(t: np.ndarray, values: np.ndarray, name: str, unit: str) -> str:
    header = ",".join(f'"{c}"' for c in ["Time (s)", *(f"{name} {a} ({unit})" for a in "xyz")])
    rows = [header] + [",".join(f"{v:.9E}" for v in (t[i], *values[i])) for i in range(len(t))]
    return "\n".join(rows) + "\n"


def phyphox_export(gyro: bool = True, mag: bool = False) -> dict[str, str]:
    t = np.arange(2000) / 100.0 + 0.0123
    tr = truth(t)
    files = {"Accelerometer.csv": phyphox_csv(t, tr["f"], "Acceleration", "m/s^2")}
    if gyro:
        files["Gyroscope.csv"] = phyphox_csv(t + 0.002, truth(t + 0.002)["gyro"], "Gyroscope", "rad/s")
    if mag:
        field = rotation(t).inv().apply(np.tile([20.0, 0.0, -40.0], (len(t), 1)))
        files["Magnetometer.csv"] = phyphox_csv(t, field, "Magnetic field", "µT")
    files["meta/device.csv"] = '"property","value"\n"deviceModel","phone"\n'
    return files


def test_phyphox_zip_with_gyroscope_and_magnetometer():
    seq = read_bytes(zip_bytes(phyphox_export(mag=True)), "phyphox.zip")
    assert seq.meta["dataset"] == "phyphox" and seq.q_world_device_wxyz is None
    expected = truth(seq.t_s + 0.0143)
    np.testing.assert_allclose(seq.gyro_rad_s, expected["gyro"], atol=0.02)
    np.testing.assert_allclose(seq.acc_m_s2, expected["f"], atol=0.05)
    assert seq.mag_uT.shape == (len(seq), 3)
    from ftin.data.preprocess import estimate_orientation

    out = estimate_orientation(seq)
    assert out.meta["orientation_filter"] == "vqf-9d"
    assert any("9-D" in w for w in out.meta["notes"])


def test_phyphox_folder_without_gyroscope_is_refused_by_name(tmp_path):
    files = {k: v for k, v in phyphox_export(gyro=False).items() if "/" not in k}
    folder = write_folder(tmp_path / "p", files)
    assert phyphox.claims(folder)
    with pytest.raises(DataFormatError, match=r"no gyroscope.*Add simple experiment"):
        read_sequence(folder)


def test_upload_bytes_gzip_csv_and_zip_safety(tmp_path):
    t = np.arange(300) / 100.0
    tr = truth(t)
    rows = ["t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z"]
    rows += [",".join(repr(float(v)) for v in (t[i], *tr["gyro"][i], *tr["f"][i])) for i in range(len(t))]
    csv = ("\n".join(rows) + "\n").encode()
    seq = read_bytes(gzip.compress(csv), "walk.csv.gz")
    assert seq.name == "walk" and len(seq) == 300
    with pytest.raises(DataFormatError, match="more than 1 MiB"):
        read_bytes(gzip.compress(b"x" * (2 * 2**20)), "bomb.gz", max_uncompressed_bytes=2**20)
    bomb = zip_bytes({"Gyroscope.csv": "time,z,y,x\n" + "0" * int(2e6)})
    with pytest.raises(DataFormatError, match=f"compresses|{MAX_RATIO}"):
        read_bytes(bomb, "bomb.zip")
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, text in sensor_logger().items():
            archive.writestr(f"a/{name}", text)
            archive.writestr(f"b/{name}", text)
    with pytest.raises(DataFormatError, match="one recording per ZIP"):
        read_bytes(buffer.getvalue(), "two.zip")
    with pytest.raises(DataFormatError, match="one file of a Sensor Logger export"):
        read_bytes(sensor_logger()["Gyroscope.csv"].encode(), "Gyroscope.csv")


def test_near_miss_csv_names_the_column_in_read_sequence(tmp_path):
    path = tmp_path / "walk.csv"
    path.write_text("t,gyro_x,gyro_y,gyro_z,acc_x,acc_y\n0,0,0,0,0,9.8\n")
    with pytest.raises(DataFormatError, match=r"walk.csv: missing column\(s\) acc_z"):
        read_sequence(path)


def test_zip_files_are_listed_in_folders(tmp_path):
    (tmp_path / "rec.zip").write_bytes(zip_bytes(sensor_logger()))
    write_folder(tmp_path / "unzipped", sensor_logger(platform="ios"))
    refs = list_sequences(tmp_path)
    assert {(r.format, r.name) for r in refs} == {("sensorlogger", "rec"), ("sensorlogger", "unzipped")}
    assert read_sequence(refs[0]).name == refs[0].name


# --- the real exports in ../shared/data/phone ----------------------------------------------------


def test_shared_sensor_logger_exports(shared_data):
    phone = shared_data / "phone"
    ios = read_sequence(phone / "sensorlogger" / "2022-09-16_11-15-46.zip")
    android = read_sequence(phone / "sensorlogger" / "inhand-20-steps-Zyf")
    for seq, rate in ((ios, 100.4), (android, 103.6)):
        assert seq.rate_hz == pytest.approx(rate, abs=0.2) and seq.duration_s == pytest.approx(20.5, abs=0.1)
        assert seq.meta["orientation_source"] == "device"
        f_world = frames.rotate_to_world(seq.q_world_device_wxyz, seq.acc_m_s2).mean(axis=0)
        assert f_world[2] == pytest.approx(9.85, abs=0.1) and np.hypot(*f_world[:2]) < 0.1
    assert any("iOS" in w for w in ios.meta["notes"])  # iOS: gravity reported downwards, negated
    assert android.mag_uT.shape == (len(android), 3)
    for seq in (ios, android):  # rad/s as the app documents it: kept, never read as deg/s
        assert not any("deg/s" in w for w in seq.meta["warnings"])
        assert np.percentile(np.linalg.norm(seq.gyro_rad_s, axis=1), 99) < 10.0
    with pytest.raises(DataFormatError, match=r"no gyroscope and no acceleration with g.*linear"):
        read_sequence(phone / "phyphox" / "walk-no-gyroscope")


@pytest.mark.parametrize("flavour", ["semicolon, decimal comma", "tabulator, decimal point"])
def test_phyphox_csv_flavours(flavour):
    files = phyphox_export()
    if flavour.startswith("semicolon"):
        changed = {k: v.replace(",", ";").replace(".", ",") for k, v in files.items() if "/" not in k}
    else:
        changed = {k: v.replace(",", "\t") for k, v in files.items() if "/" not in k}
    plain = read_bytes(zip_bytes(files), "plain.zip")
    other = read_bytes(zip_bytes(changed), "other.zip")
    np.testing.assert_array_equal(other.acc_m_s2, plain.acc_m_s2)
    np.testing.assert_array_equal(other.gyro_rad_s, plain.gyro_rad_s)
