"""``torchrun --nproc-per-node 2 -m ftin train``: DistributedDataParallel on gloo, rank 0 writes."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from ftin.data.readers.generic_csv import write_csv
from ftin.train import load_model

REPO = Path(__file__).resolve().parents[2]


def _entry(tmp_path: Path) -> list[str]:
    """``-m ftin`` once ``ftin.cli`` imports the train commands; a two-line launcher until then."""
    init = (REPO / "ftin" / "cli" / "__init__.py").read_text()
    if re.search(r"^from ftin\.cli import .*\btrain\b", init, re.MULTILINE):
        return ["-m", "ftin"]
    launcher = tmp_path / "launch_ftin.py"
    launcher.write_text("import ftin.cli.train  # noqa: F401\nfrom ftin.cli import main\n\nmain()\n")
    return [str(launcher)]


@pytest.mark.slow
def test_two_processes_train_and_only_rank_zero_writes(tmp_path, sim_sequences):
    data = tmp_path / "data"
    for seq in sim_sequences:
        write_csv(seq, data / f"{seq.name}.csv")
    run = tmp_path / "run"
    command = [
        sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc-per-node", "2",
        *_entry(tmp_path),
        "train", "--model", "ronin_tcn", "--model-kwargs", '{"channels": [8, 8]}',
        "--data", str(data), "--out", str(run), "--window", "25", "--stride", "5",
        "--batch-size", "64", "--lr", "1e-3", "--epochs", "2", "--no-progress",
    ]  # fmt: skip
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    done = subprocess.run(command, capture_output=True, text=True, timeout=120, env=env, cwd=tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.count("checkpoint:") == 1  # only rank 0 reports
    assert sorted(p.name for p in run.iterdir()) == [
        "config.json", "history.json", "resume.safetensors", "ronin_tcn.json", "ronin_tcn.safetensors"
    ]  # fmt: skip
    loaded = load_model(run / "ronin_tcn")
    assert loaded.meta["processes"] == 2 and loaded.meta["epochs"] >= 1
    history = json.loads((run / "history.json").read_text())
    assert [h["epoch"] for h in history] == [1, 2]
    # Each process took half of every global batch of 64: as many steps as one process with 64.
    n_train_windows = sum(
        len(range(0, len(s) - 25, 5)) for s in sim_sequences if s.name in loaded.meta["split"]["train"]
    )
    per_rank = -(-n_train_windows // 2)
    assert history[-1]["steps"] == 2 * -(-per_rank // 32)
