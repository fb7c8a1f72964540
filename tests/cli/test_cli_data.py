"""``ftin data info`` and ``ftin data convert`` through typer's CliRunner."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from ftin.cli import app
from ftin.data.discovery import read_sequence
from ftin.data.readers.generic_csv import read_csv, write_csv
from ftin.data.types import ImuSequence, Trajectory

runner = CliRunner()


def generic_sequence(n: int = 400, rate_hz: float = 100.0, yaw_rate: float = 0.3) -> ImuSequence:
    t = np.arange(n) / rate_hz
    yaw = yaw_rate * t
    q = np.column_stack([np.cos(yaw / 2), np.zeros(n), np.zeros(n), np.sin(yaw / 2)])
    p = np.column_stack([t, np.zeros(n), np.zeros(n)])
    gyro = np.tile([0.0, 0.0, yaw_rate], (n, 1))
    return ImuSequence("s", t, gyro, np.tile([0.0, 0.0, 9.81], (n, 1)), q, Trajectory(t, p))


def one_error(result, exit_code: int = 2) -> str:
    """The single ``error:`` message of a run (rich may wrap it on a narrow console)."""
    assert result.exit_code == exit_code
    assert result.exception is None or isinstance(result.exception, SystemExit)  # no traceback
    assert "Traceback" not in result.output
    assert result.stderr.startswith("error: ") and result.stderr.count("error: ") == 1, result.stderr
    return " ".join(line.strip() for line in result.stderr.splitlines())


@pytest.fixture()
def csv_folder(tmp_path) -> Path:
    write_csv(generic_sequence(), tmp_path / "in" / "a.csv")
    write_csv(generic_sequence(n=600, rate_hz=200.0), tmp_path / "in" / "day2" / "b.csv")
    return tmp_path / "in"


def test_info_json_on_a_folder(csv_folder):
    result = runner.invoke(app, ["data", "info", str(csv_folder), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["format"] == "csv" and report["formats"] == ["csv"]
    assert [s["name"] for s in report["sequences"]] == ["a", "day2/b"]
    a, b = report["sequences"]
    assert a["duration_s"] == pytest.approx(3.99) and a["rate_hz"] == pytest.approx(100.0)
    assert b["rate_hz"] == pytest.approx(200.0) and b["samples"] == 600
    assert a["has_gt"] and a["has_orientation"] and a["orientation_source"] == "device"
    assert report["totals"] == {
        "count": 2,
        "duration_s": pytest.approx(6.985),
        "duration_min": 0.12,
        "recorded_duration_s": pytest.approx(6.985),  # generic CSV: nothing trimmed
        "recorded_duration_min": 0.12,
    }
    assert report["errors"] == []


def test_info_table_for_humans(csv_folder):
    result = runner.invoke(app, ["data", "info", str(csv_folder)])
    assert result.exit_code == 0, result.output
    assert "day2/b" in result.stdout and "200 Hz" in result.stdout and "total: 2" in result.stdout


def test_info_reports_good_sequences_and_one_line_per_bad_file(csv_folder):
    bad = csv_folder / "broken.csv"
    bad.write_text("t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z\n0,0,0,0,0,0,9.8\n")
    result = runner.invoke(app, ["data", "info", str(csv_folder), "--json"])
    line = one_error(result, exit_code=0)  # the folder lists what it can: the rest read
    assert "broken: " in line and "only 1 samples" in line
    report = json.loads(result.stdout)
    assert report["totals"]["count"] == 2 and len(report["errors"]) == 1


@pytest.mark.parametrize("command", [["info"], ["convert", "--out", "out"]])
def test_bad_path_is_one_line_and_a_non_zero_exit(tmp_path, command):
    missing = tmp_path / "nowhere"
    result = runner.invoke(app, ["data", command[0], str(missing), *command[1:]])
    assert f"{missing}: no such file or directory" in one_error(result)


def test_path_error_is_one_physical_line(tmp_path):
    missing = tmp_path / ("a-long-folder-name-" * 4) / "nowhere"
    result = runner.invoke(app, ["data", "info", str(missing)])
    assert len(result.stderr.strip().splitlines()) == 1


def test_bad_file_errors_are_one_physical_line_each(csv_folder):
    for name in ("broken1.csv", "broken2.csv"):
        (csv_folder / ("a-long-file-name-" * 4 + name)).write_text(
            "t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z\n1,0,0,0,0,0,9\n"
        )
    result = runner.invoke(app, ["data", "info", str(csv_folder)])
    lines = result.stderr.strip().splitlines()
    assert result.exit_code == 0 and len(lines) == 2 and all(line.startswith("error: ") for line in lines)


def test_folder_without_sequences(tmp_path):
    (tmp_path / "readme.txt").write_text("nothing here")
    result = runner.invoke(app, ["data", "info", str(tmp_path)])
    assert "no sequence of any supported format found" in one_error(result)


def test_convert_folder_keeps_the_structure(csv_folder, tmp_path):
    out = tmp_path / "out"
    result = runner.invoke(app, ["data", "convert", str(csv_folder), "--to", "csv", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "wrote 2 CSV file(s)" in result.stdout
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*.csv")) == ["a.csv", "day2/b.csv"]
    np.testing.assert_array_equal(
        read_csv(out / "day2" / "b.csv").t_s, read_csv(csv_folder / "day2" / "b.csv").t_s
    )


def test_convert_refuses_a_file_as_output_folder(csv_folder, tmp_path):
    target = tmp_path / "taken"
    target.write_text("")
    result = runner.invoke(app, ["data", "convert", str(csv_folder), "--out", str(target)])
    assert "--out must be a folder" in one_error(result)


def test_convert_rejects_an_unknown_target(csv_folder, tmp_path):
    result = runner.invoke(
        app, ["data", "convert", str(csv_folder), "--to", "parquet", "--out", str(tmp_path)]
    )
    assert result.exit_code != 0 and "parquet" in result.output


def test_info_on_shared_oxiod(shared_data):
    result = runner.invoke(app, ["data", "info", str(shared_data / "oxiod"), "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["format"] == "oxiod" and report["totals"]["count"] == 42
    # ~141 min recorded; the OxIOD reader trims 12 s + 3 s of standing still per sequence by default.
    assert 140.0 <= report["totals"]["recorded_duration_min"] <= 142.0
    trimmed_min = 42 * (1200 + 300) / 100.0 / 60.0
    assert report["totals"]["duration_min"] == pytest.approx(
        report["totals"]["recorded_duration_min"] - trimmed_min, abs=0.1
    )
    assert all(s["has_gt"] and s["rate_hz"] == pytest.approx(100.0) for s in report["sequences"])
    assert {s["carry"] for s in report["sequences"]} == {"handheld", "trolley", "pocket", "bag", "unknown"}


def test_convert_oxiod_sequence_round_trips(shared_data, tmp_path):
    source = shared_data / "oxiod" / "trolley" / "data2" / "syn" / "imu3.csv"
    result = runner.invoke(app, ["data", "convert", str(source), "--to", "csv", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    original = read_sequence(source)
    back = read_csv(tmp_path / "imu3.csv")
    assert len(back) == len(original)
    for field in ("t_s", "gyro_rad_s", "acc_m_s2", "q_world_device_wxyz"):
        np.testing.assert_allclose(getattr(back, field), getattr(original, field), atol=1e-6, rtol=0)
    np.testing.assert_allclose(back.gt.p_world_m, original.gt.p_world_m, atol=1e-6, rtol=0)


def test_a_piped_table_keeps_long_recording_names_whole(tmp_path, monkeypatch):
    """Written to a pipe (no terminal, no COLUMNS) tables are 120 columns wide, not rich's 80."""
    monkeypatch.delenv("COLUMNS", raising=False)
    name = "multi_users_user2_handheld_imu6"
    write_csv(generic_sequence(), tmp_path / "in" / f"{name}.csv")
    result = runner.invoke(app, ["data", "info", str(tmp_path / "in")])
    assert result.exit_code == 0, result.output
    assert name in result.stdout and max(map(len, result.stdout.splitlines())) <= 120
    monkeypatch.setenv("COLUMNS", "60")  # the user's width is kept
    narrow = runner.invoke(app, ["data", "info", str(tmp_path / "in")])
    assert max(map(len, narrow.stdout.splitlines())) <= 60


def test_info_exits_non_zero_when_nothing_in_the_folder_reads(tmp_path):
    (tmp_path / "broken.csv").write_text("t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z\n0,0,0,0,0,0,9.8\n")
    result = runner.invoke(app, ["data", "info", str(tmp_path)])
    assert "broken: " in one_error(result) and "only 1 samples" in one_error(result)
