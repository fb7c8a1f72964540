"""Where the OxIOD release says what a walk is: its file names and folders (``imuN`` beside ``viN`` or
``tangoN``; the carry mode, the walker and the phone that the folders and user3's ``Readme.txt`` name).

The reader (``ftin.data.readers.oxiod``) puts them in ``meta``; the reports group walks by them.
"""

from __future__ import annotations

import re
from pathlib import Path

IMU_NAME = re.compile(r"imu(\d+)(\.csv(?:\.xz)?)")

# Folder names of the OxIOD release -> carry mode. "multi users", "running" and "slow walking"
# were recorded with the phone in the hand (the OxIOD paper's motion-mode sets).
CARRY_BY_FOLDER = {
    "handheld": "handheld",
    "multi users": "handheld",
    "running": "handheld",
    "slow walking": "handheld",
    "pocket": "pocket",
    "handbag": "bag",
    "trolley": "trolley",
    "multi devices": "handheld",  # the shared README: the other phones were hand-held
}
# Walks whose carry mode the release documents per sequence: user3's Readme.txt ("1-2: handheld,
# 3-5: pocket, 6-7: handbag"). user4's walks and the large-scale floor walks are not documented.
CARRY_BY_WALK = {
    "user3": {1: "handheld", 2: "handheld", 3: "pocket", 4: "pocket", 5: "pocket", 6: "bag", 7: "bag"}
}
UNDOCUMENTED_CARRY = ("user4", "large scale")


def ground_truth_path(imu_path: Path) -> Path | None:
    """The ``viN`` (Vicon) or else ``tangoN`` (Tango) file beside ``imuN``, plain or xz; None if none."""
    match = IMU_NAME.fullmatch(imu_path.name)
    if match is None:
        return None
    for stem in ("vi", "tango"):
        for suffix in dict.fromkeys((match.group(2), ".csv", ".csv.xz")):
            path = imu_path.with_name(f"{stem}{match.group(1)}{suffix}")
            if path.is_file():
                return path
    return None


def carry_and_source(path: Path) -> tuple[str, str]:
    """Carry mode as the release documents it (module docstring), else ``"unknown"``, and where it
    was found: ``"user3 Readme.txt"``, ``"folder name"``, ``"not documented in the release"``, ``"none"``."""
    match = IMU_NAME.fullmatch(Path(path).name)
    number = None if match is None else int(match.group(1))
    for part in reversed([part.lower() for part in Path(path).parent.parts]):
        if number in CARRY_BY_WALK.get(part, {}):
            return CARRY_BY_WALK[part][number], f"{part} Readme.txt"
        if part in UNDOCUMENTED_CARRY:
            return "unknown", "not documented in the release"
        if part in CARRY_BY_FOLDER:
            return CARRY_BY_FOLDER[part], "folder name"
    return "unknown", "none"


def carry_mode(path: Path) -> str:
    """Carry mode as the release documents it (:func:`carry_and_source`), else ``"unknown"``."""
    return carry_and_source(path)[0]


def walker_and_phone(path: Path) -> tuple[str, str]:
    """``("user3", "iPhone")``-style: the walker named by a ``multi users`` folder, the phone by a
    ``multi devices`` folder; "unknown" and "iPhone" where the release names neither."""
    parents = [part for part in Path(path).parent.parts if part.lower() != "syn"]
    walker, phone = "unknown", "iPhone"
    for above, folder in zip(parents, parents[1:], strict=False):
        if above.lower() == "multi users":
            walker = folder
        elif above.lower() == "multi devices":
            phone = {"nexus 5": "Nexus 5"}.get(folder.lower(), folder)
    return walker, phone


def sequence_name(imu_path: Path) -> str:
    """``handheld/data1/imu2``-style name: the folders that tell sequences apart, without ``syn``."""
    parents = [p for p in imu_path.parent.parts[-3:] if p.lower() != "syn"]
    match = IMU_NAME.fullmatch(imu_path.name)
    stem = imu_path.stem if match is None else f"imu{match.group(1)}"  # without .csv / .csv.xz
    return "/".join([*parents[-2:], stem])
