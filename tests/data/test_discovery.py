"""Sequence discovery over folders of mixed formats, names, and auto-detected reading."""

from __future__ import annotations

import json
import logging
import os
import pkgutil
import sys
import types
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest

from ftin.data import readers
from ftin.data.discovery import SequenceRef, detect_format, list_sequences, read_sequence
from ftin.data.errors import DataFormatError
from ftin.data.readers import generic_csv
from ftin.data.types import ImuSequence, Trajectory

G = 9.81
N = 600
RATE_HZ = 200.0


def flat_turning_phone() -> dict[str, np.ndarray]:
    """A phone lying flat, turning slowly about the vertical while sliding along x: simple but exact."""
    t = 10.0 + np.arange(N) / RATE_HZ
    yaw = 0.5 * (t - t[0])
    q_wxyz = np.column_stack([np.cos(yaw / 2), np.zeros(N), np.zeros(N), np.sin(yaw / 2)])
    return {
        "t": t,
        "gyro": np.tile([0.0, 0.0, 0.5], (N, 1)),
        "acc": np.tile([0.0, 0.0, G], (N, 1)),
        "q": q_wxyz,
        "p": np.column_stack([0.8 * (t - t[0]), np.zeros(N), np.zeros(N)]),
    }


def write_generic(path: Path, m: dict) -> Path:
    seq = ImuSequence("x", m["t"], m["gyro"], m["acc"], m["q"], Trajectory(m["t"], m["p"]))
    return generic_csv.write_csv(seq, path)


def write_ronin(folder: Path, m: dict) -> Path:
    folder.mkdir(parents=True)
    with h5py.File(folder / "data.hdf5", "w") as f:
        f["synced/time"] = m["t"]
        f["synced/gyro_uncalib"] = m["gyro"]
        f["synced/acce"] = m["acc"]
        f["synced/game_rv"] = m["q"]
        f["pose/tango_pos"] = m["p"]
        f["pose/tango_ori"] = m["q"]
    info = {"imu_init_gyro_bias": [0, 0, 0], "imu_acce_bias": [0, 0, 0], "imu_acce_scale": [1, 1, 1]}
    (folder / "info.json").write_text(
        json.dumps({**info, "start_calibration": [1, 0, 0, 0], "start_frame": 0})
    )
    return folder


def write_processed(folder: Path, m: dict, arcore: bool = False) -> Path:
    (folder / "processed").mkdir(parents=True)
    columns = {"time": m["t"] * 1e9}
    for name, values in (("gyro", m["gyro"]), ("acce", m["acc"]), ("pos", m["p"])):
        columns.update({f"{name}_{a}": values[:, i] for i, a in enumerate("xyz")})
    for name in ("ori", "rv"):
        columns.update({f"{name}_{c}": m["q"][:, i] for i, c in enumerate("wxyz")})
    pd.DataFrame(columns).to_csv(folder / "processed" / "data.csv")
    if arcore:
        (folder / "android_sensor_pose.txt").write_text("")
    return folder


def write_tlio(folder: Path, m: dict) -> Path:
    folder.mkdir(parents=True)
    q_xyzw = m["q"][:, [1, 2, 3, 0]]
    np.save(
        folder / "imu0_resampled.npy",
        np.column_stack([m["t"] * 1e6, m["gyro"], m["acc"], q_xyzw, m["p"], m["p"]]),
    )
    return folder


def write_rnin(folder: Path, m: dict) -> Path:
    folder.mkdir(parents=True)
    columns = {"time": m["t"]}
    for name, values in (("gyro", m["gyro"]), ("acce", m["acc"]), ("gt_p", m["p"])):
        columns.update({f"{name}_{a}": values[:, i] for i, a in enumerate("xyz")})
    columns.update({f"gt_q_{c}": m["q"][:, i] for i, c in enumerate("wxyz")})
    columns.update({name: np.zeros(N) for name in readers.rnin.BIAS_COLUMNS})
    pd.DataFrame(columns).to_csv(folder / "SenseINS.csv", index=False)
    return folder


def write_oxiod_like(folder: Path) -> Path:
    """Headerless imuN.csv / viN.csv pair (discovery only needs the layout)."""
    folder.mkdir(parents=True)
    np.savetxt(folder / "imu1.csv", np.ones((5, 16)), delimiter=",")
    np.savetxt(folder / "vi1.csv", np.ones((5, 9)), delimiter=",")
    return folder / "imu1.csv"


def write_euroc_like(folder: Path) -> Path:
    imu = folder / "mav0" / "imu0" / "data.csv"
    imu.parent.mkdir(parents=True)
    imu.write_text(
        "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
        "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n1403636579758555392,0,0,0,9.8,0,0\n"
    )
    return folder


@pytest.fixture()
def mixed(tmp_path) -> Path:
    m = flat_turning_phone()
    write_ronin(tmp_path / "ronin" / "a000_1", m)
    write_processed(tmp_path / "ridi" / "dan_body1", m)
    write_processed(tmp_path / "imunet" / "rec1", m, arcore=True)
    write_tlio(tmp_path / "tlio" / "145820422949970", m)
    write_rnin(tmp_path / "rnin" / "data_test" / "0", m)
    write_generic(tmp_path / "mine" / "walk.csv", m)
    write_generic(tmp_path / "mine" / "deeper" / "run.csv", m)
    write_oxiod_like(tmp_path / "oxiod" / "handheld" / "data1" / "syn")
    write_euroc_like(tmp_path / "euroc" / "MH_01_easy")
    (tmp_path / "mine" / "notes.csv").write_text("when,what\n1,walked\n")
    return tmp_path


EXPECTED = {
    ("ronin", "ronin/a000_1"),
    ("ridi", "ridi/dan_body1"),
    ("imunet", "imunet/rec1"),
    ("tlio", "tlio/145820422949970"),
    ("rnin", "rnin/data_test/0"),
    ("csv", "mine/walk"),
    ("csv", "mine/deeper/run"),
    ("oxiod", "oxiod/handheld/data1/syn/imu1"),
    ("euroc", "euroc/MH_01_easy"),
}


def test_mixed_folder_lists_every_sequence_once(mixed):
    refs = list_sequences(mixed)
    assert {(ref.format, ref.name) for ref in refs} == EXPECTED
    assert len(refs) == len(EXPECTED)
    assert [ref.name for ref in refs] == sorted(ref.name for ref in refs)
    assert all(isinstance(ref, SequenceRef) and ref.path.exists() for ref in refs)


def test_every_module_of_the_readers_package_registers_in_priority_order():
    modules = {m.name for m in pkgutil.iter_modules(readers.__path__) if not m.name.startswith("_")}
    assert {module.__name__.rsplit(".", 1)[1] for module in readers.READERS.values()} == modules
    assert all(module.FORMAT == fmt for fmt, module in readers.READERS.items())
    priorities = [readers.PRIORITY[fmt] for fmt in readers.READERS]
    assert priorities == sorted(priorities, reverse=True)
    assert list(readers.READERS)[-1] == generic_csv.FORMAT  # accepts the most: asked last


def test_a_format_registers_once(monkeypatch):
    monkeypatch.setattr(readers._registry, "READERS", dict(readers.READERS))
    monkeypatch.setattr(readers._registry, "PRIORITY", dict(readers.PRIORITY))
    module = types.ModuleType("another_csv_reader")
    module.FORMAT, module.LABEL = "csv", "another CSV"
    monkeypatch.setitem(sys.modules, module.__name__, module)

    def read(path: Path) -> ImuSequence:
        raise NotImplementedError

    read.__module__ = module.__name__
    with pytest.raises(
        ValueError, match="format 'csv' is already registered by ftin.data.readers.generic_csv"
    ):
        readers.register_reader(priority=5)(read)
    module.FORMAT = ""
    with pytest.raises(TypeError, match="another_csv_reader: a reader module defines FORMAT"):
        readers.register_reader(priority=5)(read)
    module.FORMAT, module.LABEL = "another", None
    with pytest.raises(TypeError, match="another_csv_reader: a reader module defines LABEL"):
        readers.register_reader(priority=5)(read)


def test_every_reader_names_its_format_in_words_and_exports_are_offered_by_priority():
    assert readers.reader_label("oxiod") == "OxIOD"
    assert readers.reader_label("sensorlogger") == "Sensor Logger export"
    assert all(readers.reader_label(fmt) for fmt in readers.READERS)
    with pytest.raises(ValueError, match="no reader is registered for format 'nope'; formats: oxiod, "):
        readers.reader_label("nope")
    assert [module.FORMAT for module in readers.export_readers()] == ["ilc", "phyphox", "sensorlogger"]


def test_generic_csv_never_claims_a_file_of_another_layout(mixed):
    # RIDI's and RNIN's CSVs have headers the generic format accepts; only their own readers list them.
    claimed = {p.relative_to(mixed).as_posix() for p in generic_csv.discover(mixed)}
    assert "ridi/dan_body1/processed/data.csv" in claimed and "rnin/data_test/0/SenseINS.csv" in claimed
    csv_refs = [ref.name for ref in list_sequences(mixed) if ref.format == "csv"]
    assert sorted(csv_refs) == ["mine/deeper/run", "mine/walk"]


@pytest.mark.parametrize(
    ("relative", "expected"),
    [
        ("ronin/a000_1", "ronin"),
        ("ronin/a000_1/data.hdf5", "ronin"),
        ("ridi/dan_body1", "ridi"),
        ("ridi/dan_body1/processed/data.csv", "ridi"),
        ("imunet/rec1/processed", "imunet"),
        ("tlio/145820422949970/imu0_resampled.npy", "tlio"),
        ("rnin/data_test/0/SenseINS.csv", "rnin"),
        ("mine/walk.csv", "csv"),
        ("oxiod/handheld/data1/syn/imu1.csv", "oxiod"),
        ("euroc/MH_01_easy", "euroc"),
        ("euroc/MH_01_easy/mav0/imu0/data.csv", "euroc"),
        ("mine/notes.csv", None),
        ("mine", None),
    ],
)
def test_detect_format(mixed, relative, expected):
    assert detect_format(mixed / relative) == expected


@pytest.mark.parametrize("fmt", ["ronin", "ridi", "imunet", "tlio", "rnin", "csv"])
def test_read_sequence_auto_detects_and_names(mixed, fmt):
    ref = next(ref for ref in list_sequences(mixed) if ref.format == fmt)
    seq = read_sequence(ref)
    assert seq.name == ref.name and seq.meta["dataset"] == fmt
    assert len(seq) == N and seq.gt is not None
    np.testing.assert_allclose(seq.t_s, flat_turning_phone()["t"], atol=1e-6)
    np.testing.assert_allclose(seq.gt.p_world_m, flat_turning_phone()["p"], atol=1e-6)
    by_path = read_sequence(ref.path)  # the same sequence, format detected from the path
    np.testing.assert_array_equal(by_path.acc_m_s2, seq.acc_m_s2)


def test_read_sequence_with_explicit_format(mixed):
    seq = read_sequence(mixed / "ridi" / "dan_body1", format="ridi")
    assert seq.meta["dataset"] == "ridi"
    with pytest.raises(DataFormatError, match="unknown format 'kitti'; supported: oxiod, euroc"):
        read_sequence(mixed / "ridi" / "dan_body1", format="kitti")


def test_read_sequence_on_folders(mixed):
    assert read_sequence(mixed / "ridi").name == "dan_body1"  # holds exactly one sequence
    with pytest.raises(DataFormatError, match=r"holds 2 sequences \(deeper/run, walk\); pass one of them"):
        read_sequence(mixed / "mine")
    empty = mixed / "empty"
    empty.mkdir()
    with pytest.raises(DataFormatError, match=rf"{empty}: not a sequence of any supported format"):
        read_sequence(empty)
    # A file no format claims is read as an upload would be: the error names what is missing.
    with pytest.raises(DataFormatError, match=r"notes.csv: missing column\(s\) t, gyro_x"):
        read_sequence(mixed / "mine" / "notes.csv")
    with pytest.raises(DataFormatError, match="absent: no such file or directory"):
        read_sequence(mixed / "absent")
    with pytest.raises(DataFormatError, match="absent: no such file or directory"):
        list_sequences(mixed / "absent")


def test_names_of_a_sequence_root_and_a_file_root(mixed):
    assert list_sequences(mixed / "ronin" / "a000_1") == [
        SequenceRef("ronin", mixed / "ronin" / "a000_1", "a000_1")
    ]
    assert list_sequences(mixed / "mine" / "walk.csv") == [
        SequenceRef("csv", mixed / "mine" / "walk.csv", "walk")
    ]
    assert list_sequences(mixed / "mine" / "notes.csv") == []
    names = [ref.name for ref in list_sequences(mixed / "rnin")]
    assert names == ["data_test/0"]


def test_colliding_names_get_the_format_appended(tmp_path):
    m = flat_turning_phone()
    write_generic(tmp_path / "a.csv", m)
    write_ronin(tmp_path / "a", m)
    assert {(ref.format, ref.name) for ref in list_sequences(tmp_path)} == {
        ("csv", "a_csv"),
        ("ronin", "a_ronin"),
    }


def test_failing_discovery_and_unreadable_folders_do_not_crash(mixed, monkeypatch, caplog):
    locked = mixed / "locked"
    write_generic(locked / "secret.csv", flat_turning_phone())
    os.chmod(locked, 0)
    try:
        names = {ref.name for ref in list_sequences(mixed)}  # root ignores the mode bits; others skip it
    finally:
        os.chmod(locked, 0o755)
    assert EXPECTED_NAMES <= names

    def refuse(root: Path) -> list[Path]:
        raise PermissionError(13, "Permission denied", str(root))

    monkeypatch.setattr(readers.tlio, "discover", refuse)
    with caplog.at_level(logging.WARNING, logger="ftin.data.discovery"):
        refs = list_sequences(mixed)
    assert {ref.format for ref in refs} == {fmt for fmt, _name in EXPECTED} - {"tlio"}
    assert "tlio discovery" in caplog.text and "Permission denied" in caplog.text


EXPECTED_NAMES = {name for _fmt, name in EXPECTED}


def test_shared_data_lists_every_dataset(shared_data):
    refs = list_sequences(shared_data)
    by_format: dict[str, list[str]] = {}
    for ref in refs:
        by_format.setdefault(ref.format, []).append(ref.name)
    assert sorted(by_format) == ["euroc", "ilc", "inria_attitude", "oxiod", "phyphox", "ridi", "sensorlogger"]
    assert len(by_format["ilc"]) == 571 and "ilc/site1/F1/5dd9e7aac5b77e0006b1732b.txt" in by_format["ilc"]
    assert len(by_format["oxiod"]) == 42 and len(by_format["euroc"]) == 5 and len(by_format["ridi"]) == 21
    assert len(by_format["inria_attitude"]) == 84
    assert "inria_attitude/datasets/android/Thibaud_Nexus5_Dist_AR" in by_format["inria_attitude"]
    assert sorted(by_format["sensorlogger"]) == [
        "phone/sensorlogger/2022-09-16_11-15-46",
        "phone/sensorlogger/inhand-20-steps-Zyf",
    ]
    assert "oxiod/handheld/data1/syn/imu2" in by_format["oxiod"]
    assert "euroc/MH_04_difficult" in by_format["euroc"]
    assert detect_format(shared_data / "oxiod" / "trolley" / "data2" / "syn" / "imu1.csv") == "oxiod"
    assert detect_format(shared_data / "euroc" / "V1_02_medium") == "euroc"
    assert detect_format(shared_data / "oxiod" / "trolley" / "data2" / "syn" / "vi1.csv") is None
