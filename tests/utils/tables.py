"""What the ``ftin table`` tests evaluate: tiny untrained checkpoints of four of the table's models,
two small simulated datasets, two checkpoints of one model (which the table must refuse), and
the collected results of a small training campaign (``ftin table --campaign``)."""

from __future__ import annotations

import json
from pathlib import Path

from ftin.data.readers.generic_csv import write_csv
from ftin.sim import SimConfig, simulate
from tests.utils.checkpoints import RATE_HZ, WINDOW, tiny_model_kwargs, write_checkpoint

# Four of the table's nine models; ronin_lstm, rnin, imunet, tlio and resnet_tdl stay missing.
TINY_MODELS = ("ronin_resnet", "ronin_tcn", "ftin", "resnet_fdl")


def write_table_checkpoints(directory: Path) -> Path:
    """``<model>_sim`` checkpoints of ``TINY_MODELS``, plus run-folder files that are no checkpoint."""
    for i, name in enumerate(TINY_MODELS):
        write_checkpoint(
            directory / f"{name}_sim",
            name,
            seed=i,
            model_kwargs=tiny_model_kwargs(name, WINDOW),
            training_data={"datasets": ["sim"], "recordings": ["sim/train"]},
        )
    # Files of a training run folder that are no checkpoint pair must be skipped.
    (directory / "config.json").write_text("{}")
    (directory / "resume.safetensors").write_bytes(b"")
    return directory


def write_table_datasets(root: Path) -> Path:
    """Two datasets: "walk" (two sequences in one folder) and "pocket" (two files given separately)."""
    (root / "walk").mkdir()
    for seed in (1, 2):
        write_csv(
            simulate(SimConfig(duration_s=12.0, rate_hz=RATE_HZ, seed=seed)), root / "walk" / f"w{seed}.csv"
        )
    for seed in (3, 4):
        seq = simulate(SimConfig(duration_s=12.0, rate_hz=RATE_HZ, carry="pocket", seed=seed))
        write_csv(seq, root / f"pocket{seed}.csv")
    return root


def dataset_options(data_dir: Path) -> list[str]:
    """``--dataset`` values for ``write_table_datasets``' folder."""
    return [
        f"walk={data_dir / 'walk'}",
        f"pocket={data_dir / 'pocket3.csv'}",
        f"pocket={data_dir / 'pocket4.csv'}",
    ]


def write_two_of_one_model(directory: Path) -> Path:
    """``tcn-oxiod`` and ``tcn-sim``: two checkpoints for the RoNIN TCN column."""
    for i, name in enumerate(("tcn-oxiod", "tcn-sim")):
        write_checkpoint(directory / name, "ronin_tcn", seed=i, model_kwargs={"channels": (8,)})
    return directory


RECORDINGS = ("a", "b")


def campaign_record(model, dataset, seed, ates, variant=None):
    rows = [
        {
            "name": name,
            "duration_s": 60.0,
            "ate": ate,
            "rte": ate / 2,
            "pde": 0.01,
            "path_length_ratio": 0.9,
            "stand_still": {"ate": 2.0, "rte": 2.5, "pde": 0.5},
        }
        for name, ate in zip(RECORDINGS, ates, strict=True)
    ]
    parts = {f"{dataset}/{part}/{o}": rows for part in ("val", "test") for o in ("ground_truth", "device")}
    training = {
        "job": f"{dataset}/{model}-s{seed}",
        "model": model,
        "dataset": dataset,
        "seed": seed,
        "variant": variant,
        "best_val_mse": 0.01,
    }
    return {"training": training, "history": [], "evaluation": {"parts": parts}}


def write_campaign_results(folder: Path) -> Path:
    """What ``scripts/campaign.py collect`` writes, for a small campaign: FTIN in two variants (the
    manifest names the one validation chose), RoNIN ResNet over two seeds, RoNIN LSTM once (refused by
    the shipping gate)."""
    folder.mkdir(parents=True, exist_ok=True)
    records = [
        campaign_record("ftin", "oxiod", 0, (1.0, 1.2), "ordered"),
        campaign_record("ftin", "oxiod", 1, (1.1, 1.3), "ordered"),
        campaign_record("ftin", "oxiod", 0, (5.0, 5.0), "mixed"),  # the variant validation did not choose
        campaign_record("ronin_resnet", "oxiod", 0, (1.5, 1.6)),
        campaign_record("ronin_resnet", "oxiod", 1, (1.4, 1.9)),
        campaign_record("ronin_lstm", "oxiod", 0, (3.0, 3.0)),
    ]
    for i, record in enumerate(records):
        (folder / f"oxiod__{i}.json").write_text(json.dumps(record))
    refused = {
        "ronin_lstm-oxiod": {
            "job": "oxiod/ronin_lstm-s0",
            "refused": "validation ATE not below standing still",
        }
    }
    (folder / "manifest.json").write_text(json.dumps({"ftin_variant": "ordered", "not_shipped": refused}))
    return folder
