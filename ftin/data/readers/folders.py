"""Discovery shared by the readers whose sequence is a folder marked by fixed file names
(RoNIN ``data.hdf5`` + ``info.json``, RNIN ``SenseINS.csv``, TLIO ``imu0_resampled.npy``)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class MarkedFolderLayout:
    required: tuple[str, ...]  # files a sequence folder must hold
    members: tuple[str, ...]  # files whose path stands for their folder (a user may pass one)

    def sequence_dir(self, path: Path) -> Path:
        path = Path(path)
        return path.parent if path.name in self.members else path

    def claims(self, path: Path) -> bool:
        folder = self.sequence_dir(path)
        return all((folder / name).is_file() for name in self.required)

    def discover(self, root: Path) -> list[Path]:
        """Every folder under ``root`` (itself included) holding all the required files, sorted."""
        root = Path(root)
        if root.is_file():
            return [self.sequence_dir(root)] if self.claims(root) else []
        return sorted(
            Path(folder)
            for folder, _dirs, files in os.walk(root)  # os.walk skips unreadable folders
            if all(name in files for name in self.required)
        )
