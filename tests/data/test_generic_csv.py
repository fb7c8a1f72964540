"""The generic CSV format: every violation's message, aliases, units, time detection, round trip."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ftin.data.errors import DataFormatError
from ftin.data.readers import generic_csv
from ftin.data.readers.generic_csv import COLUMNS, discover, read_csv, schema_markdown, write_csv
from ftin.data.types import ImuSequence, Trajectory

G = 9.80665
CANONICAL = ["t", "gyro_x", "gyro_y", "gyro_z", "acc_x", "acc_y", "acc_z"]


def walking_imu(n: int = 300, rate_hz: float = 100.0, seed: int = 0) -> dict[str, np.ndarray]:
    """Plausible phone IMU: small tilt, turning, gravity on the device's z axis."""
    rng = np.random.default_rng(seed)
    t = 1000.0 + np.arange(n) / rate_hz
    euler = np.column_stack([0.4 * np.sin(0.3 * t), 0.1 * np.sin(1.7 * t), 0.05 * np.cos(1.1 * t)])
    R_world_device = Rotation.from_euler("ZYX", euler)
    f_world = np.column_stack([rng.normal(0, 0.8, n), rng.normal(0, 0.8, n), G + rng.normal(0, 1.0, n)])
    return {
        "t": t,
        "gyro": rng.normal(0, 0.6, (n, 3)),
        "acc": R_world_device.inv().apply(f_world),
        "q": R_world_device.as_quat()[:, [3, 0, 1, 2]],
        "gt": np.column_stack([np.cos(0.1 * t), np.sin(0.1 * t), np.zeros(n)]) * 5.0,
    }


def csv_text(header: list[str], rows: np.ndarray, newline: str = "\n") -> str:
    lines = [",".join(header)] + [",".join(repr(float(v)) for v in row) for row in rows]
    return newline.join(lines) + newline


def imu_rows(data: dict[str, np.ndarray]) -> np.ndarray:
    return np.column_stack([data["t"], data["gyro"], data["acc"]])


def read_text(text: str, **options) -> ImuSequence:
    return read_csv(io.BytesIO(text.encode("utf-8")), name="test", **options)


def error_of(text: str, **options) -> str:
    with pytest.raises(DataFormatError) as info:
        read_text(text, **options)
    return str(info.value)


@pytest.fixture()
def data() -> dict[str, np.ndarray]:
    return walking_imu()


def with_cell(text: str, line: int, column: int, value: str) -> str:
    """Replace one cell (1-based file line, 0-based column)."""
    lines = text.split("\n")
    cells = lines[line - 1].split(",")
    cells[column] = value
    lines[line - 1] = ",".join(cells)
    return "\n".join(lines)


# --- reading good files --------------------------------------------------------------------------


def test_canonical_file_reads_exact_values(data):
    seq = read_text(csv_text(CANONICAL, imu_rows(data)))
    np.testing.assert_array_equal(seq.t_s, data["t"])
    np.testing.assert_array_equal(seq.gyro_rad_s, data["gyro"])
    np.testing.assert_array_equal(seq.acc_m_s2, data["acc"])
    assert seq.q_world_device_wxyz is None and seq.gt is None
    assert seq.meta["dataset"] == "csv"
    assert seq.meta["rate_hz"] == pytest.approx(100.0)
    assert "orientation_source" not in seq.meta
    assert any("seconds" in w for w in seq.meta["notes"])


def test_orientation_and_ground_truth_columns(data):
    header = CANONICAL + ["q_w", "q_x", "q_y", "q_z", "gt_x", "gt_y", "gt_z"]
    seq = read_text(csv_text(header, np.column_stack([imu_rows(data), data["q"], data["gt"]])))
    np.testing.assert_allclose(seq.q_world_device_wxyz, data["q"], atol=1e-12)
    np.testing.assert_array_equal(seq.gt.p_world_m, data["gt"])
    assert seq.meta["orientation_source"] == "device"
    # gt_x may be motion capture in its own world frame: comparisons align it at the start.
    assert seq.meta["gt_frame"] == "unknown"


def test_column_order_is_free_and_extra_columns_are_reported(data):
    header = ["acc_z", "pressure_hpa", "gyro_y", "t", "acc_x", "gyro_z", "gyro_x", "acc_y"]
    rows = np.column_stack(
        [data["acc"][:, 2], np.ones(len(data["t"])), data["gyro"][:, 1], data["t"], data["acc"][:, 0]]
        + [data["gyro"][:, 2], data["gyro"][:, 0], data["acc"][:, 1]]
    )
    seq = read_text(csv_text(header, rows))
    np.testing.assert_array_equal(seq.gyro_rad_s, data["gyro"])
    np.testing.assert_array_equal(seq.acc_m_s2, data["acc"])
    assert any("ignored columns: pressure_hpa" in w for w in seq.meta["notes"])


def test_bom_windows_line_endings_and_whitespace_in_headers(data):
    header = ["  T ", " Gyro_X", "gyro_y ", "GYRO_Z", "acc_x", " acc_y ", "acc_z"]
    text = "\ufeff" + csv_text(header, imu_rows(data), newline="\r\n")
    seq = read_csv(io.BytesIO(text.encode("utf-8")))
    np.testing.assert_array_equal(seq.acc_m_s2, data["acc"])
    assert seq.name == "upload"


def test_blank_lines_are_skipped_and_line_numbers_stay_the_files(data):
    text = csv_text(CANONICAL, imu_rows(data))
    lines = text.split("\n")
    lines.insert(5, "")  # a blank line 6: data moves down one line
    text = "\n".join(lines)
    assert len(read_text(text)) == len(data["t"])
    message = error_of(with_cell(text, 20, 2, "oops"))
    assert "line 20" in message and "'gyro_y'" in message


@pytest.mark.parametrize(
    "header",
    [
        # Sensor Logger / Android style, with unit suffixes
        ["seconds_elapsed", "gyroscope_x", "gyroscope_y", "gyroscope_z"]
        + ["accelerometer_x", "accelerometer_y", "accelerometer_z"],
        ["time_s", "gyro_x_rad_s", "gyro_y_rad_s", "gyro_z_rad_s", "acc_x_m_s2", "acc_y_m_s2", "acc_z_m_s2"],
        # phyphox style: words, spaces and units in parentheses
        ["Time (s)", "Gyroscope x (rad/s)", "Gyroscope y (rad/s)", "Gyroscope z (rad/s)"]
        + ["Acceleration x (m/s^2)", "Acceleration y (m/s^2)", "Acceleration z (m/s^2)"],
        # short forms and RoNIN-style names, mixed case
        ["Timestamp", "GX", "gy", "gz", "AX", "ay", "az"],
        ["time", "gyro_x", "gyro_y", "gyro_z", "acce_x", "acce_y", "acce_z"],
    ],
)
def test_logger_aliases(data, header):
    seq = read_text(csv_text(header, imu_rows(data)))
    np.testing.assert_array_equal(seq.gyro_rad_s, data["gyro"])
    np.testing.assert_array_equal(seq.acc_m_s2, data["acc"])


@pytest.mark.parametrize(
    "names",
    [
        ["rotation_vector_w", "rotation_vector_x", "rotation_vector_y", "rotation_vector_z"],
        ["game_rv_w", "game_rv_x", "game_rv_y", "game_rv_z"],
        ["qw", "qx", "qy", "qz"],
    ],
)
def test_quaternion_aliases(data, names):
    rows = np.column_stack([imu_rows(data), data["q"]])
    seq = read_text(csv_text(CANONICAL + names, rows))
    np.testing.assert_allclose(seq.q_world_device_wxyz, data["q"], atol=1e-12)


def test_preferred_alias_wins_and_the_other_is_reported(data):
    rows = np.column_stack([data["t"], (data["t"] - data["t"][0]) * 1e9, data["gyro"], data["acc"]])
    header = ["seconds_elapsed", "time"] + CANONICAL[1:]
    seq = read_text(csv_text(header, rows))
    np.testing.assert_array_equal(seq.t_s, data["t"])
    assert any("used column 'seconds_elapsed' for t; ignored 'time'" in w for w in seq.meta["notes"])


def test_two_columns_with_the_same_meaning_are_refused(data):
    rows = np.column_stack([imu_rows(data), data["gyro"][:, 0]])
    message = error_of(csv_text(CANONICAL + ["Gyro X"], rows))
    assert "'gyro_x' (column 2)" in message and "'Gyro X' (column 8)" in message


def test_semicolon_separated_file(data):
    text = csv_text(CANONICAL, imu_rows(data)).replace(",", ";")
    np.testing.assert_array_equal(read_text(text).acc_m_s2, data["acc"])


# --- time units ----------------------------------------------------------------------------------


def test_nanosecond_timestamps_are_detected_and_reported(data):
    t_ns = np.round(1.7e18 + (data["t"] - data["t"][0]) * 1e9)
    rows = np.column_stack([t_ns, data["gyro"], data["acc"]])
    seq = read_text(csv_text(CANONICAL, rows))
    np.testing.assert_allclose(np.diff(seq.t_s), 0.01, atol=1e-6)
    assert seq.rate_hz == pytest.approx(100.0, rel=1e-4)
    assert any("t detected as nanoseconds" in w for w in seq.meta["notes"])


def test_millisecond_timestamps_are_detected(data):
    rows = np.column_stack([data["t"] * 1e3, data["gyro"], data["acc"]])
    seq = read_text(csv_text(CANONICAL, rows))
    np.testing.assert_allclose(seq.t_s, data["t"], rtol=1e-12)
    assert any("milliseconds" in w for w in seq.meta["notes"])


def test_time_unit_from_header(data):
    rows = np.column_stack([data["t"] * 1e6, data["gyro"], data["acc"]])
    seq = read_text(csv_text(["timestamp [us]"] + CANONICAL[1:], rows))
    np.testing.assert_allclose(seq.t_s, data["t"], rtol=1e-12)
    assert any("microseconds (unit in header" in w for w in seq.meta["notes"])


def test_units_in_header_are_converted(data):
    rows = np.column_stack([data["t"], np.degrees(data["gyro"]), data["acc"] / G])
    header = ["t", "gyro_x_deg_s", "gyro_y_deg_s", "gyro_z_deg_s", "acc_x [g]", "acc_y [g]", "acc_z [g]"]
    seq = read_text(csv_text(header, rows))
    np.testing.assert_allclose(seq.gyro_rad_s, data["gyro"], rtol=1e-12)
    np.testing.assert_allclose(seq.acc_m_s2, data["acc"], rtol=1e-12)
    assert any("gyro converted from deg/s" in w for w in seq.meta["notes"])


# --- one test per violation ----------------------------------------------------------------------


def test_empty_file():
    assert "file is empty" in error_of("")
    assert "file is empty" in error_of("\n\n  \n")


def test_no_header_row(data):
    text = csv_text(CANONICAL, imu_rows(data)).split("\n", 1)[1]
    message = error_of(text)
    assert "no header row" in message and "t,gyro_x" in message


def test_missing_column_lists_the_columns_found(data):
    rows = np.column_stack([data["t"], data["gyro"], data["acc"][:, :2]])
    message = error_of(csv_text(CANONICAL[:-1], rows))
    assert "missing column(s) acc_z" in message
    assert "found columns: t, gyro_x, gyro_y, gyro_z, acc_x, acc_y" in message


def test_linear_acceleration_is_not_specific_force(data):
    header = CANONICAL[:4] + [
        "Linear Acceleration x (m/s^2)",
        "Linear Acceleration y",
        "Linear Acceleration z",
    ]
    message = error_of(csv_text(header, imu_rows(data)))
    assert "missing column(s) acc_x, acc_y, acc_z" in message and "linear acceleration" in message


def test_non_numeric_value_names_line_and_column(data):
    text = with_cell(csv_text(CANONICAL, imu_rows(data)), 42, 5, "1.2.3")
    message = error_of(text)
    assert "line 42" in message and "'acc_y'" in message and "'1.2.3' is not a number" in message


@pytest.mark.parametrize("cell", ["nan", "NaN", ""])
def test_nan_or_empty_value_names_line_and_column(data, cell):
    text = with_cell(csv_text(CANONICAL, imu_rows(data)), 17, 3, cell)
    message = error_of(text)
    assert "line 17" in message and "'gyro_z'" in message and "NaN" in message


def test_infinite_value_names_line_and_column(data):
    text = with_cell(csv_text(CANONICAL, imu_rows(data)), 9, 6, "-inf")
    message = error_of(text)
    assert "line 9" in message and "'acc_z'" in message and "infinite" in message


def test_duplicate_timestamp_names_the_line(data):
    t = data["t"].copy()
    t[30] = t[29]
    message = error_of(csv_text(CANONICAL, np.column_stack([t, data["gyro"], data["acc"]])))
    assert "line 32" in message and "duplicates the previous one" in message


def test_decreasing_timestamp_names_the_line(data):
    t = data["t"].copy()
    t[[50, 51]] = t[[51, 50]]
    message = error_of(csv_text(CANONICAL, np.column_stack([t, data["gyro"], data["acc"]])))
    assert "line 53" in message and "is earlier than the previous one" in message


def test_a_short_gap_is_bridged_with_a_note_that_says_where(data):
    t = data["t"].copy()
    t[200:] += 0.5
    seq = read_text(csv_text(CANONICAL, np.column_stack([t, data["gyro"], data["acc"]])))
    (note,) = [n for n in seq.meta["notes"] if "bridged" in n]
    assert "1 gap(s)" in note and "510 ms" in note and "between line 201 and line 202" in note
    assert "holes_s" not in seq.meta


def test_a_gap_of_two_recordings_names_the_lines_and_the_fix(data):
    t = data["t"].copy()
    t[200:] += 90.0
    message = error_of(csv_text(CANONICAL, np.column_stack([t, data["gyro"], data["acc"]])))
    assert "no data for 90.01 s between line 201" in message and "and line 202" in message
    assert "split the file there" in message


def test_fewer_samples_than_one_window(data):
    rows = imu_rows(data)[:80]
    message = error_of(csv_text(CANONICAL, rows))
    assert "only 80 samples" in message and "at least 100 are needed" in message
    assert "min_samples" not in message  # the user's words, not the reader's option name
    assert len(read_text(csv_text(CANONICAL, rows), min_samples=50)) == 80
    assert "at least 500 are needed" in error_of(csv_text(CANONICAL, imu_rows(data)), min_samples=500)


@pytest.mark.parametrize("rate_hz", [5.0, 2000.0])
def test_rate_outside_20_to_1000_hz(rate_hz):
    data = walking_imu(rate_hz=rate_hz)
    rows = np.column_stack([data["t"] - data["t"][0], data["gyro"], data["acc"]])
    header = ["time_s"] + CANONICAL[1:]  # a stated unit: the rate is checked in it
    message = error_of(csv_text(header, rows))
    assert f"sample rate {rate_hz:g} Hz is outside 20–1000 Hz" in message


def test_rate_outside_range_for_every_time_unit():
    data = walking_imu(rate_hz=5.0)
    message = error_of(csv_text(CANONICAL, imu_rows(data)))
    assert "outside 20–1000 Hz whether read as seconds (5 Hz)" in message


def test_acceleration_in_g_is_refused_with_the_factor(data):
    rows = np.column_stack([data["t"], data["gyro"], data["acc"] / G])
    message = error_of(csv_text(CANONICAL, rows))
    assert "looks like g; multiply by 9.80665" in message


def test_gyro_in_deg_per_s_is_refused_with_the_factor(data):
    rows = np.column_stack([data["t"], np.degrees(data["gyro"]), data["acc"]])
    message = error_of(csv_text(CANONICAL, rows))
    assert "looks like deg/s; multiply by pi/180" in message


def test_acceleration_without_gravity_is_refused(data):
    rows = np.column_stack([data["t"], data["gyro"], data["acc"] - data["acc"].mean(axis=0)])
    assert "gravity removed" in error_of(csv_text(CANONICAL, rows))


def test_incomplete_quaternion_columns(data):
    rows = np.column_stack([imu_rows(data), data["q"][:, :2]])
    message = error_of(csv_text(CANONICAL + ["q_w", "q_x"], rows))
    assert "incomplete q columns: found q_w, q_x but not q_y, q_z" in message


def test_non_unit_quaternion_names_the_line(data):
    q = data["q"].copy()
    q[10] *= 2.0
    message = error_of(
        csv_text(CANONICAL + ["q_w", "q_x", "q_y", "q_z"], np.column_stack([imu_rows(data), q]))
    )
    assert "line 12" in message and "norm 2" in message


def test_device_from_world_quaternion_is_refused(data):
    inverse = data["q"] * np.array([1.0, -1.0, -1.0, -1.0])
    tilted = walking_imu()  # make the tilt large enough that the inverse is clearly wrong
    R = Rotation.from_euler("X", 60, degrees=True) * Rotation.from_quat(tilted["q"][:, [1, 2, 3, 0]])
    q_true = R.as_quat()[:, [3, 0, 1, 2]]
    acc = R.inv().apply(np.tile([0.0, 0.0, G], (len(data["t"]), 1)))
    rows = np.column_stack([data["t"], data["gyro"], acc, q_true * np.array([1.0, -1.0, -1.0, -1.0])])
    message = error_of(csv_text(CANONICAL + ["q_w", "q_x", "q_y", "q_z"], rows))
    assert "look like device-from-world" in message
    assert inverse.shape == data["q"].shape


def test_malformed_table_is_a_format_error(data):
    text = csv_text(CANONICAL, imu_rows(data))
    text = with_cell(text, 5, 6, "1.0,2.0,3.0")  # too many fields on line 5
    assert "not a well-formed CSV table" in error_of(text)


def test_missing_file_and_binary_file(tmp_path):
    with pytest.raises(DataFormatError, match="cannot read file"):
        read_csv(tmp_path / "absent.csv")
    binary = tmp_path / "photo.csv"
    binary.write_bytes(b"\xff\xd8\xff\xe0" + bytes(range(256)))
    with pytest.raises(DataFormatError, match="not UTF-8 text"):
        read_csv(binary)


# --- writing, schema and discovery ---------------------------------------------------------------


def test_round_trip_is_exact(tmp_path, data):
    seq = ImuSequence(
        "walk",
        data["t"],
        data["gyro"],
        data["acc"],
        data["q"],
        Trajectory(data["t"], data["gt"]),
        {"dataset": "x"},
    )
    path = write_csv(seq, tmp_path / "nested" / "walk.csv")
    back = read_csv(path)
    assert back.name == "walk"
    for field in ("t_s", "gyro_rad_s", "acc_m_s2", "q_world_device_wxyz"):
        np.testing.assert_allclose(getattr(back, field), getattr(seq, field), rtol=1e-9, atol=0)
    np.testing.assert_allclose(back.gt.p_world_m, seq.gt.p_world_m, rtol=1e-9, atol=0)
    header = path.read_text().splitlines()[0]
    gt_columns = ["gt_device_world_x", "gt_device_world_y", "gt_device_world_z"]  # our readers' frame
    assert header == ",".join(CANONICAL + ["q_w", "q_x", "q_y", "q_z", *gt_columns])
    assert back.meta["gt_frame"] == "device_world"


def test_write_to_a_buffer(data):
    seq = ImuSequence("walk", data["t"], data["gyro"], data["acc"])
    buffer = io.StringIO()
    assert write_csv(seq, buffer) is None
    assert buffer.getvalue().splitlines()[0] == ",".join(CANONICAL)


def test_schema_markdown_lists_every_column_and_its_aliases():
    table = schema_markdown()
    for spec in COLUMNS:
        assert f"| `{spec.name}` |" in table
    assert "`seconds_elapsed`" in table and "`gyroscope_x`" in table and "`rotation_vector_w`" in table


def test_discover_claims_only_files_with_the_canonical_header(tmp_path, data):
    good = tmp_path / "a" / "walk.CSV"
    good.parent.mkdir()
    good.write_text(csv_text(["Time (s)"] + CANONICAL[1:], imu_rows(data)))
    (tmp_path / "headerless.csv").write_text(csv_text(CANONICAL, imu_rows(data)).split("\n", 1)[1])
    (tmp_path / "euroc.csv").write_text(
        "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
        "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n1,0,0,0,0,0,9.8\n"
    )
    (tmp_path / "notes.txt").write_text(",".join(CANONICAL))
    (tmp_path / "empty.csv").write_text("")
    assert discover(tmp_path) == [good]
    assert discover(good) == [good]
    assert generic_csv.claims(good) and not generic_csv.claims(tmp_path / "euroc.csv")


def test_discover_does_not_claim_the_shared_oxiod_and_euroc_files(shared_data: Path):
    assert discover(shared_data / "oxiod") == []
    assert discover(shared_data / "euroc") == []


def test_a_magnetometer_column_reaches_the_orientation_filter_in_microtesla(data):
    field_ut = np.tile([20.0, 0.0, -40.0], (len(data["t"]), 1))
    header = [*CANONICAL, "magnet_x [nT]", "magnet_y [nT]", "magnet_z [nT]"]
    seq = read_text(csv_text(header, np.column_stack([imu_rows(data), field_ut * 1000.0])))
    np.testing.assert_allclose(seq.mag_uT, field_ut)
    assert "mag converted from nT (unit in header)" in seq.meta["notes"]
    for aliases in (["mx", "my", "mz"], ["magnetometer_x", "magnetometer_y", "magnetometer_z"]):
        again = read_text(csv_text([*CANONICAL, *aliases], np.column_stack([imu_rows(data), field_ut])))
        np.testing.assert_allclose(again.mag_uT, field_ut)
    message = error_of(
        csv_text([*CANONICAL, "mag_x", "mag_y"], np.column_stack([imu_rows(data), field_ut[:, :2]]))
    )
    assert "incomplete mag columns" in message and "mag_z" in message
    out = io.StringIO()
    write_csv(seq, out)
    np.testing.assert_allclose(read_text(out.getvalue()).mag_uT, field_ut)
