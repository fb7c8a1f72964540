"""The evaluation protocol: fixed splits per dataset and the training jobs of the campaign.

One place for what docs/results/protocol.md states, read by the campaign runner
(``scripts/campaign.py``), the report (``ftin table --campaign``) and the model cards.

Splits (fixed before any training, by whole recording, every carry mode in each part where the
data allows; paths relative to the dataset's root folder):
- ``train``: the optimiser sees these;
- ``val``: early stopping, the learning-rate schedule, the best epoch, the seed that ships and the
  FTIN variant: every choice;
- ``test``: reported only. No number computed on it feeds back into any choice.

RIDI's test part holds two users who appear nowhere else (huayi, shali): the closest we get to the
"unseen user" a phone app meets. OxIOD has two handheld users only, so its test part mixes them.

Training settings, the same for every model (``COMMON``): Adam lr 1e-3, plateau decay (factor 0.3,
patience 3 epochs on the validation 1 s-velocity MSE), early stopping after 8 epochs without a new
best, at most 60 epochs, stop below lr 1e-6; yaw augmentation; orientation from the ground truth
(the network alone); 1 thread per run. Every model sees each sample about five times per epoch:
window models take 1 s windows every 0.2 s, RNIN its ten 1 s sub-windows every 2 s, RoNIN's LSTM
and TCN their 400-frame chunks every 80 frames. Batches follow the references: 128 windows; RNIN
32 sequences (its reference); RoNIN LSTM/TCN 72 chunks (their reference). TLIO switches from MSE to
its Gaussian NLL after 5 epochs (its reference trains MSE first; 5 < the earliest early stop).
RNIN trains with its reference loss (MSE on sub-window displacements plus 8x their cumulative sum;
the reference never switches to the NLL within its epochs).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

OXIOD = "oxiod"
RIDI = "ridi"
PEDESTRIAN = "pedestrian"  # OxIOD and RIDI together, at 100 Hz
SIM = "sim"

SPLITS: dict[str, dict[str, tuple[str, ...]]] = {
    OXIOD: {
        "train": (
            "handheld/data1/syn/imu2.csv",
            "handheld/data1/syn/imu4.csv",
            "multi users/user2/syn/imu4.csv",
            "multi users/user2/syn/imu5.csv",
            "trolley/data1/syn/imu7.csv",
            "trolley/data2/syn/imu1.csv",
            "trolley/data2/syn/imu2.csv",
            "trolley/data2/syn/imu4.csv",
        ),
        "val": ("handheld/data1/syn/imu3.csv", "trolley/data2/syn/imu3.csv"),
        "test": ("multi users/user2/syn/imu6.csv", "trolley/data2/syn/imu5.csv"),
    },
    RIDI: {
        "train": (
            "dan_bag1",
            "dan_bag2",
            "dan_body1",
            "dan_body2",
            "dan_handheld1",
            "dan_handheld2",
            "dan_leg1",
            "hang_body_fast1",
            "hang_handheld_side_test2",
            "hao_body1",
            "hao_body2",
            "ma_body1",
            "ma_body2",
        ),
        "val": ("hang_bag_side1", "hang_body_test1", "ma_handheld3", "dan_body3"),
        "test": ("huayi_bag2", "huayi_body_test1", "shali_handheld1", "hao_leg2"),
    },
}

RATE_HZ = {OXIOD: 100.0, RIDI: 200.0, PEDESTRIAN: 100.0, SIM: 100.0}

# Models of the paper's comparison, in Table 1's column order, then the ablations.
COMPARED = ("ronin_resnet", "ronin_lstm", "ronin_tcn", "rnin", "imunet", "tlio", "ftin")
ABLATIONS = ("resnet_fdl", "resnet_tdl", "ftin")
MULTI_SEED = ("ftin", "resnet_fdl", "resnet_tdl", "ronin_resnet")
SEEDS = (0, 1, 2)
# FTIN's two TDL sequences (design decision left open by the paper; validation picks one).
FTIN_VARIANTS = {"mixed": {"fdl_output": "mixed"}, "ordered": {"fdl_output": "ordered"}}

COMMON: dict[str, Any] = {
    "lr": 1e-3,
    "batch_size": 128,
    "plateau_factor": 0.3,
    "plateau_patience": 3,
    "early_stop_patience": 8,
    "max_epochs": 60,
    "min_lr": 1e-6,
    "augment_yaw": True,
    "orientation": "ground_truth",
    "weights_dtype": "float16",
    "save_every_min": 3.0,
}
PASSES_PER_EPOCH = 5  # each sample appears in about this many training windows per epoch


@dataclass(frozen=True)
class Job:
    """One training run of the campaign: a model (variant), a dataset and a seed."""

    name: str  # run folder name, e.g. "oxiod/ftin-mixed-s0"
    model: str
    dataset: str
    seed: int
    variant: str | None = None  # FTIN's TDL variant
    options: dict[str, Any] = field(default_factory=dict)  # TrainConfig options beyond COMMON

    def config(self, data_root: Path) -> dict[str, Any]:
        """``TrainConfig`` options (without ``out_dir``) with the split's paths under ``data_root``."""
        return {
            **COMMON,
            **self.options,
            "model": self.model,
            "seed": self.seed,
            "name": self.checkpoint_stem,
            "data": [str(p) for p in split_paths(data_root, self.dataset, "train")],
            "val": [str(p) for p in split_paths(data_root, self.dataset, "val")],
        }

    @property
    def checkpoint_stem(self) -> str:
        return f"{self.model}-{self.dataset}"


def split_paths(data_root: Path, dataset: str, part: str) -> list[Path]:
    """Absolute paths of a split part; ``pedestrian`` joins OxIOD's and RIDI's."""
    if dataset == PEDESTRIAN:
        return [*split_paths(data_root, OXIOD, part), *split_paths(data_root, RIDI, part)]
    if dataset not in SPLITS:
        raise ValueError(f"no split for dataset {dataset!r}; known: {', '.join(SPLITS)}, {PEDESTRIAN}")
    return [Path(data_root) / dataset / rel for rel in SPLITS[dataset][part]]


def model_options(model: str, dataset: str) -> dict[str, Any]:
    """Window, stride, batch and loss choices of ``model`` at ``dataset``'s rate (module docstring)."""
    rate = int(RATE_HZ[dataset])
    window = rate  # 1 s
    options: dict[str, Any] = {
        "imu_rate_hz": float(rate),
        "window": window,
        "stride": window // PASSES_PER_EPOCH,
    }
    if model == "rnin":
        window = 10 * rate  # ten 1 s sub-windows through the LSTM
        options.update(
            window=window,
            stride=window // PASSES_PER_EPOCH,
            batch_size=32,
            loss="mse",
            model_kwargs={"sub_window": rate},
        )
    elif model in ("ronin_lstm", "ronin_tcn"):
        options.update(window=400, stride=400 // PASSES_PER_EPOCH, batch_size=72)
    elif model == "tlio":
        options.update(nll_warmup_epochs=5)
    return options


def campaign_jobs(ftin_variant: str | None = None) -> list[Job]:
    """Every job, most informative first; the pedestrian model (the app's default) as soon as the
    FTIN variant is chosen. FTIN's seeds 1-2 use ``ftin_variant`` (None: not yet chosen)."""
    jobs: list[Job] = []

    def add(model: str, dataset: str, seed: int, variant: str | None = None) -> None:
        options = model_options(model, dataset)
        suffix = f"-{variant}" if variant else ""
        if variant:
            options["model_kwargs"] = {**options.get("model_kwargs", {}), **FTIN_VARIANTS[variant]}
        jobs.append(Job(f"{dataset}/{model}{suffix}-s{seed}", model, dataset, seed, variant, options))

    for dataset in (OXIOD, RIDI):
        for variant in FTIN_VARIANTS:
            add("ftin", dataset, 0, variant)
        add("ronin_resnet", dataset, 0)
    if ftin_variant is not None:  # the app's default model, as soon as the variant is known
        add("ftin", PEDESTRIAN, 0, ftin_variant)
    for dataset in (OXIOD, RIDI):
        for model in ("resnet_fdl", "resnet_tdl", "ronin_lstm", "ronin_tcn", "rnin", "imunet", "tlio"):
            add(model, dataset, 0)
    for dataset in (OXIOD, RIDI):
        for seed in SEEDS[1:]:
            for model in ("ronin_resnet", "resnet_fdl", "resnet_tdl"):
                add(model, dataset, seed)
            if ftin_variant is not None:
                add("ftin", dataset, seed, ftin_variant)
    return jobs
