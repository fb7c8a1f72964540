"""The evaluation protocol: fixed splits per dataset and the training jobs of the campaign.

One place for what docs/results/protocol.md states, read by the campaign (``ftin campaign``), the
report (``ftin table --campaign``) and the model cards: the splits, the walker-wise folds, the jobs
and the campaign's policy (which FTIN variant, which run may ship, the simulator's job).

Splits (fixed before any training, by whole recording, every carry mode in each part where the
data allows; paths relative to the dataset's folder, ``DATA_FOLDERS``):
- ``train``: the optimiser sees these;
- ``val``: early stopping, the learning-rate schedule, the best epoch, the seed that ships and the
  FTIN variant: every choice;
- ``test``: reported only. No number computed on it feeds back into any choice.

RIDI's test part holds two users who appear nowhere else (huayi, shali): the closest we get to the
"unseen user" a phone app meets. OxIOD has two handheld users only, so its test part mixes them.
Inria's test part is every iPhone 4S walk: a phone no training or validation walk comes from.

Walker-wise folds (``WALKER_FOLDS``, fixed before any training): the recordings outside the test
parts, grouped by walker (``walker``); in fold k the walkers of ``WALKER_FOLDS[dataset][k]`` are
validation and every other walker trains, so validation asks the question the test scores (walkers
the model has never seen). Inria has two walkers, hence two folds for every dataset.

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

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

OXIOD = "oxiod"
RIDI = "ridi"
INRIA = "inria"  # the Inria smartphone attitude benchmark (walks with Qualisys ground truth)
PEDESTRIAN = "pedestrian"  # OxIOD and RIDI together, at 100 Hz (the first campaign's app default)
WALKING = "walking"  # every walking dataset together (OxIOD, RIDI, Inria), at 100 Hz
SIM = "sim"
COMBINED = {PEDESTRIAN: (OXIOD, RIDI), WALKING: (OXIOD, RIDI, INRIA)}
# How reports name the datasets.
DATASET_LABELS = {OXIOD: "OxIOD", RIDI: "RIDI", INRIA: "Inria"}
# Where each dataset lives under the data root (the Inria reader reads ``<platform>/<walk>`` folders).
DATA_FOLDERS = {OXIOD: "oxiod", RIDI: "ridi", INRIA: "inria_attitude/datasets"}
# Orientation sources a dataset's test and validation parts are scored with: the reference (the network
# alone), the phone's own attitude, and ``PHONE_ONLY``: the recording as a phone alone gives it (its
# attitude removed; ``auto`` chooses from gyroscope, accelerometer and magnetometer), what a user has.
PHONE_ONLY = "phone_only"
EVAL_ORIENTATIONS = {d: ("ground_truth", "device", PHONE_ONLY) for d in DATA_FOLDERS}

_INRIA_MOTIONS = (
    *(f"{dist}_{m}" for dist in ("Dist", "NoDist") for m in ("AR", "BackPocket", "FrontPocket")),
    *(f"{dist}_{m}" for dist in ("Dist", "NoDist") for m in ("Phoning", "Swinging", "Texting")),
    "NoDist_RunningHand",
    "NoDist_RunningPocket",
)
_INRIA_PHONES = {"Nexus5": "android", "iPhone5": "ios", "iPhone4S": "ios"}
INRIA_WALKERS = ("Guillaume", "Thibaud")
INRIA_TEST_PHONE = "iPhone4S"


def _inria_walks(phones: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(
        f"{_INRIA_PHONES[phone]}/{walker}_{phone}_{motion}"
        for phone in phones
        for walker in INRIA_WALKERS
        for motion in _INRIA_MOTIONS
    )


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


def walker(dataset: str, recording: str) -> str:
    """Who walked a recording (a path relative to the dataset's folder). OxIOD: the handheld folders
    are users 1 and 2; each trolley folder is its own group. RIDI and Inria: the name's first word."""
    if dataset == OXIOD:
        top, folder = recording.split("/")[:2]
        return {"handheld": "user1", "multi users": "user2"}.get(top, f"{top}-{folder}")
    if dataset in (RIDI, INRIA):
        return Path(recording).name.split("_")[0]
    raise ValueError(f"no walkers known for dataset {dataset!r}")


# Validation walkers of fold 0 and fold 1 (everyone else outside the test part trains). Balanced by
# recordings and carry modes: OxIOD a handheld user and a trolley group each (4 / 6 recordings),
# RIDI dan (8: bag, body, handheld, leg) against hang, hao and ma (9: bag, body, handheld), Inria
# one walker each (28 walks on the Nexus 5 and the iPhone 5).
WALKER_FOLDS: dict[str, tuple[tuple[str, ...], ...]] = {
    OXIOD: (("user1", "trolley-data1"), ("user2", "trolley-data2")),
    RIDI: (("dan",), ("hang", "hao", "ma")),
    INRIA: (("Guillaume",), ("Thibaud",)),
}
FOLDS = (0, 1)


def fold_parts(dataset: str, fold: int) -> dict[str, tuple[str, ...]]:
    """Train, validation and (untouched) test recordings of walker fold ``fold``."""
    if dataset not in WALKER_FOLDS or fold not in FOLDS:
        raise ValueError(f"no walker fold {fold!r} for dataset {dataset!r}; folds: {FOLDS}")
    if dataset == INRIA:
        pool, test = _inria_walks(("Nexus5", "iPhone5")), _inria_walks((INRIA_TEST_PHONE,))
    else:
        pool, test = (*SPLITS[dataset]["train"], *SPLITS[dataset]["val"]), SPLITS[dataset]["test"]
    held = set(WALKER_FOLDS[dataset][fold])
    return {
        "train": tuple(sorted(r for r in pool if walker(dataset, r) not in held)),
        "val": tuple(sorted(r for r in pool if walker(dataset, r) in held)),
        "test": test,
    }


# Inria has no split by recording: its fixed split is walker fold 0, its test part the iPhone 4S.
SPLITS[INRIA] = fold_parts(INRIA, 0)

RATE_HZ = {OXIOD: 100.0, RIDI: 200.0, INRIA: 100.0, PEDESTRIAN: 100.0, WALKING: 100.0, SIM: 100.0}

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


# Training recipes beside ``COMMON``: ours (the budget this machine allows) and the paper's optimiser
# settings (Adam lr 1e-4, batch 512, at most 100 epochs). A recipe is options; so is any variant.
RECIPES: dict[str, dict[str, Any]] = {"ours": {}, "paper": {"lr": 1e-4, "batch_size": 512, "max_epochs": 100}}
SIM_TRAIN_WALKS = 48  # simulated two-minute walks for the simulator model (seeds disjoint from the samples)
SIM_VAL_WALKS = 4


@dataclass(frozen=True)
class Job:
    """One training run of a campaign: a model (variant), a dataset (walker fold) and a seed.

    ``options`` are ``TrainConfig`` options beyond ``COMMON``: the model's window and batch
    (``model_options``), then whatever a variant changes (a recipe, an augmentation set, the input
    orientation source), so a variant is data. ``parts`` names the recordings of a dataset outside
    the protocol (``{"train": [...], "val": [...], "test": [...]}``, paths under the data root)."""

    name: str  # run folder name, e.g. "oxiod/ftin-mixed-s0"
    model: str
    dataset: str
    seed: int
    variant: str | None = None  # FTIN's TDL variant, or a variant's label
    options: dict[str, Any] = field(default_factory=dict)
    fold: int | None = None  # walker fold (``WALKER_FOLDS``); None: the fixed split
    parts: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def paths(self, data_root: Path, part: str, dataset: str | None = None) -> list[Path]:
        """A part's recordings: the job's own ``parts``, else the protocol's (one member of a
        combined dataset with ``dataset``)."""
        if self.parts:
            return [Path(data_root) / rel for rel in self.parts.get(part, ())]
        return split_paths(data_root, dataset or self.dataset, part, self.fold)

    def config(self, data_root: Path) -> dict[str, Any]:
        """``TrainConfig`` options (without ``out_dir``) with the split's paths under ``data_root``."""
        return {
            **COMMON,
            **self.options,
            "model": self.model,
            "seed": self.seed,
            "name": self.checkpoint_stem,
            "data": [str(p) for p in self.paths(data_root, "train")],
            "val": [str(p) for p in self.paths(data_root, "val")],
        }

    def evaluation_sets(self) -> list[tuple[str, str, tuple[str | None, ...]]]:
        """``(dataset, part, orientation sources)`` the finished job is scored on: validation and test
        of its dataset (each member of a combined one); reader default for data outside the protocol."""
        members = COMBINED.get(self.dataset, (self.dataset,))
        return [
            (d, part, EVAL_ORIENTATIONS.get(d, (None,)) if not self.parts else (None,))
            for d in members
            for part in ("val", "test")
        ]

    @property
    def checkpoint_stem(self) -> str:
        return f"{self.model}-{self.dataset}"

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "model": self.model,
            "dataset": self.dataset,
            "seed": self.seed,
            "variant": self.variant,
            "options": self.options,
            "fold": self.fold,
            "parts": {k: list(v) for k, v in self.parts.items()},
        }

    @classmethod
    def from_json(cls, spec: Mapping[str, Any]) -> Job:
        """A job from its JSON form; ``options`` go over the model's ``model_options`` when the
        dataset has a rate in the protocol."""
        unknown = sorted(
            set(spec) - {"name", "model", "dataset", "seed", "variant", "options", "fold", "parts"}
        )
        missing = [key for key in ("name", "model", "dataset") if key not in spec]
        if unknown or missing:
            raise ValueError(f"job {spec.get('name')!r}: unknown key(s) {unknown}, missing {missing}")
        base = model_options(spec["model"], spec["dataset"]) if spec["dataset"] in RATE_HZ else {}
        return cls(
            name=str(spec["name"]),
            model=str(spec["model"]),
            dataset=str(spec["dataset"]),
            seed=int(spec.get("seed", 0)),
            variant=spec.get("variant"),
            options={**base, **dict(spec.get("options") or {})},
            fold=spec.get("fold"),
            parts={k: tuple(v) for k, v in (spec.get("parts") or {}).items()},
        )


def split_paths(data_root: Path, dataset: str, part: str, fold: int | None = None) -> list[Path]:
    """Absolute paths of a part of the fixed split (``fold`` None) or of a walker fold; a combined
    dataset (``COMBINED``) joins its members'."""
    if dataset in COMBINED:
        return [p for d in COMBINED[dataset] for p in split_paths(data_root, d, part, fold)]
    if dataset not in SPLITS:
        known = ", ".join([*SPLITS, *COMBINED])
        raise ValueError(f"no split for dataset {dataset!r}; known: {known}")
    rels = SPLITS[dataset][part] if fold is None else fold_parts(dataset, fold)[part]
    return [Path(data_root) / DATA_FOLDERS[dataset] / rel for rel in rels]


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
    if ftin_variant is not None:  # the app's default model and the samples' one, once the variant is known
        add("ftin", PEDESTRIAN, 0, ftin_variant)
        jobs.append(sim_job(ftin_variant))
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


# The generalisation campaign's first stage: the choices it has to make, each decided on walkers the
# run never trained on (``WALKER_FOLDS`` of the walking dataset). Arms: FTIN with either TDL sequence
# and RoNIN ResNet under our recipe and yaw augmentation only; both with ``GENERALISATION_AUGMENT``
# (the walker-held-out probe's two candidates, docs/results/probes/augmentations.md: white noise,
# which had the lowest ATE on one seed, and the bounce scaling, which halves how much the model reads
# speed from the bounce); both under the paper's optimiser settings. Seed 0 of every arm on both
# folds comes first, so that a session's worth of jobs already answers each question once.
GENERALISATION_AUGMENT: dict[str, float | None] = {"acc_noise": None, "gyro_noise": None, "vertical": None}


def generalisation_jobs(_variant: str | None = None) -> list[Job]:
    """Stage one of the generalisation campaign: walker-wise cross-validation (module comment above).

    Order: each question's pair of arms on both folds before the next question, seed 0 before seed 1,
    the paper's recipe (100 epochs: the longest jobs) last, so that every session's few jobs complete
    comparisons over every walker rather than half of many."""
    yaw = [("ftin", "ordered", "yaw", {}), ("ronin_resnet", None, "yaw", {})]
    aug = [(m, v, "aug", {"augment": dict(GENERALISATION_AUGMENT)}) for m, v, _, _ in yaw]
    mirror = [(m, v, "mirror", {"augment": {"mirror": None}}) for m, v, _, _ in yaw]
    pace = [(m, v, "pace", {"augment": {"pace": None}}) for m, v, _, _ in yaw]
    mixed = [("ftin", "mixed", "yaw", {})]
    paper = [(m, v, "paper", dict(RECIPES["paper"])) for m, v, _, _ in yaw]
    order = [(seed, question) for seed in (0, 1) for question in (yaw, aug, mirror, pace, mixed)]
    order.append((0, paper))  # the recipe question gets one seed per fold
    jobs: list[Job] = []
    for seed, question in order:
        for fold in FOLDS:
            for model, variant, arm, extra in question:
                options = {**model_options(model, WALKING), **extra}
                if variant:
                    kwargs = {**options.get("model_kwargs", {}), **FTIN_VARIANTS[variant]}
                    options["model_kwargs"] = kwargs
                label = f"{model}{f'-{variant}' if variant else ''}-{arm}"
                name = f"walking-f{fold}/{label}-s{seed}"
                jobs.append(Job(name, model, WALKING, seed, variant, options, fold))
    return jobs


# A question asked after stage two was planned (docs/results/probes/phone_cost.md): on OxIOD a phone
# alone costs stage two's ResNet recipe 1.43x its motion-capture ATE on walkers it never saw, most of
# it the tilt VQF leaves, which a model trained on motion capture never sees. Does training with tilt
# errors (``tilt``: TLIO's gravity perturbation, up to 5 deg) on top of that recipe (mirror) pay for
# it? Stage one's folds, seeds and budget; compared with its ``ronin_resnet-mirror`` runs, phone only.
TILT_QUESTION_SEEDS = (0, 1)


def tilt_question_jobs(_variant: str | None = None) -> list[Job]:
    """RoNIN ResNet + mirror + tilt on both walker folds, seeds 0 and 1 (``plan --jobs tilt --extend``
    on the generalisation campaign's folder: its frozen code scores as stage one's did)."""
    options = {**model_options("ronin_resnet", WALKING), "augment": {"mirror": None, "tilt": None}}
    return [
        Job(
            f"walking-f{fold}/ronin_resnet-mirror-tilt-s{seed}",
            "ronin_resnet",
            WALKING,
            seed,
            None,
            options,
            fold,
        )
        for seed in TILT_QUESTION_SEEDS
        for fold in FOLDS
    ]


CAMPAIGNS = {  # by name (``plan --jobs``)
    "table1": campaign_jobs,
    "generalisation": generalisation_jobs,
    "tilt": tilt_question_jobs,
}


# --- the campaign's policy -------------------------------------------------------------------------


def sim_job(variant: str) -> Job:
    """FTIN on simulated walks (``SIM_TRAIN_WALKS`` / ``SIM_VAL_WALKS`` under the campaign folder's
    ``sim-data``), tested on the app's bundled samples (never trained or chosen on)."""
    options = {
        **model_options("ftin", SIM),
        "model_kwargs": dict(FTIN_VARIANTS[variant]),
        "orientation": None,
    }
    samples = Path(__file__).resolve().parent / "sim" / "samples"
    parts = {"train": ("sim-data/train",), "val": ("sim-data/val",), "test": (str(samples),)}
    return Job(f"sim/ftin-{variant}-s0", "ftin", SIM, 0, variant, options, parts=parts)


def choose_variant(val_mse: Mapping[str, Mapping[str, float]]) -> tuple[str | None, dict[str, float]]:
    """FTIN's TDL variant: the one with the lower geometric-mean best validation MSE over OxIOD and
    RIDI (``val_mse[variant][dataset]`` of the seed-0 runs). ``(None, {})`` until all four are known."""
    scores: dict[str, float] = {}
    for variant in FTIN_VARIANTS:
        values = [val_mse.get(variant, {}).get(d) for d in (OXIOD, RIDI)]
        if any(v is None for v in values):
            return None, {}
        scores[variant] = math.exp(sum(math.log(v) for v in values) / len(values))
    return min(scores, key=scores.__getitem__), scores


def validation_gate(record: Mapping[str, Any]) -> dict[str, Any]:
    """Whether a run may be hosted, from its validation recordings (ground-truth orientation): it must
    walk about the right distance (mean path ratio 0.8-1.25) and beat a predictor that never moves
    (mean ATE below the stand-still ATE). ``refused`` names the rule it broke, else None.

    Each validation dataset weighs the same (its mean first, then the mean over datasets), as in the
    default's choice: a walking checkpoint validates on 28 Inria walks beside 2 OxIOD and 4 RIDI ones,
    and pooled rows would make the gate an Inria gate. One dataset: the plain mean (amended
    2026-11-27, when the pooled rule refused the first walking checkpoint; ``..._pooled`` keeps it)."""
    per_dataset: dict[str, list[Mapping[str, Any]]] = {}
    for key, part in record["evaluation"]["parts"].items():
        dataset, split, orientation = key.split("/")
        if split == "val" and orientation == "ground_truth" and part:
            per_dataset.setdefault(dataset, []).extend(part)

    def mean(values: list[float]) -> float | None:
        return sum(values) / len(values) if values else None

    def path_ratio(rows: list[Mapping[str, Any]]) -> float | None:
        return mean([row["path_length_ratio"] for row in rows if row["path_length_ratio"] is not None])

    ratios = {d: path_ratio(rows) for d, rows in per_dataset.items()}
    ratio = None if not ratios or None in ratios.values() else mean(list(ratios.values()))
    ates = [mean([row["ate"] for row in rows]) for rows in per_dataset.values()]
    stills = [mean([row["stand_still"]["ate"] for row in rows]) for rows in per_dataset.values()]
    ate, still = mean(ates), mean(stills)
    ate_over_still = mean([a / s for a, s in zip(ates, stills, strict=True)])
    refused = None
    if ratio is None or not 0.8 <= ratio <= 1.25:
        refused = "validation path ratio outside 0.8-1.25"
    elif ate_over_still is None or ate_over_still >= 1.0:
        refused = "validation ATE not below standing still"
    return {
        "val_path_length_ratio": ratio,
        "val_path_length_ratio_pooled": path_ratio([r for rows in per_dataset.values() for r in rows]),
        "val_path_length_ratio_per_dataset": ratios,
        "val_ate_m": ate,
        "val_stand_still_ate_m": still,
        "refused": refused,
    }


def path_ratio_bounds(carry: str) -> tuple[float, float]:
    """The path ratio a walk of this carry mode must reach (the generalisation issue's acceptance:
    0.8-1.2 of the walked distance, 0.7-1.3 running)."""
    return (0.7, 1.3) if "running" in carry.lower() else (0.8, 1.2)


# The app's default model (for requests that name none): the pedestrian checkpoint, of whatever
# architecture, whose validation recordings it walks best, as a user would get them. Scored per
# dataset as validation ATE over standing still's (scale-free: RIDI's long walks are not worth ten
# of Inria's room), averaged over the datasets it was validated on, from the most realistic
# orientation source every candidate was scored with (phone only, else the phone's attitude).
DEFAULT_CANDIDATE_DATASETS = (PEDESTRIAN, WALKING)
DEFAULT_SOURCES = (PHONE_ONLY, "device", "ground_truth")


def default_scores(record: Mapping[str, Any], source: str) -> dict[str, float] | None:
    """``{dataset: mean val ATE / mean stand-still ATE, ..., "mean": their mean}`` of a job record
    scored with ``source``; None when it was not."""
    scores: dict[str, float] = {}
    for key, rows in sorted(record["evaluation"]["parts"].items()):
        dataset, part, scored_with = key.split("/")
        if part == "val" and scored_with == source and rows:
            still = sum(row["stand_still"]["ate"] for row in rows)
            scores[dataset] = sum(row["ate"] for row in rows) / still
    if not scores:
        return None
    return {**scores, "mean": sum(scores.values()) / len(scores)}


def choose_default(candidates: Mapping[str, Mapping[str, Any]]) -> dict[str, Any] | None:
    """The default among shipped pedestrian checkpoints (``{checkpoint name: job record}``):
    ``{"model", "source", "scores": {name: default_scores}, "why"}``; None without candidates."""
    if not candidates:
        return None
    for source in DEFAULT_SOURCES:
        scores = {name: default_scores(record, source) for name, record in candidates.items()}
        if all(s is not None for s in scores.values()):
            break
    else:
        raise ValueError("the default's candidates share no orientation source on validation")
    ranked = sorted(scores, key=lambda name: scores[name]["mean"])
    best = ranked[0]

    def figure(name: str) -> str:
        return f"{name} {scores[name]['mean']:.2f}x"

    label = {PHONE_ONLY: "phone only", "device": "the phone's attitude"}.get(
        source, "ground-truth orientation"
    )
    datasets = ", ".join(DATASET_LABELS.get(d, d) for d in scores[best] if d != "mean")
    why = (
        f"the pedestrian checkpoint that walks its validation walks best ({label}): ATE "
        f"{scores[best]['mean']:.2f}x standing still's, mean over {datasets}"
    )
    if len(ranked) > 1:
        why += "; against " + ", ".join(figure(name) for name in ranked[1:])
    return {"model": best, "source": source, "scores": scores, "why": why}


# --- the generalisation campaign, stage two -------------------------------------------------------
# Stage one's choices (docs/results/protocol.md: each takes the arm with the lower mean paired
# validation ATE over every walker of both folds, phone only), read from the paired comparisons of
# ``ftin campaign crossval``, then every shipped checkpoint retrained with them.
STAGE_TWO_SEEDS = (0, 1, 2, 3, 4)  # FTIN, +TDL and RoNIN ResNet (the five)
STAGE_TWO_MULTI_SEED = ("ftin", "resnet_tdl", "ronin_resnet")
FTIN_FAMILY = ("ftin", "resnet_fdl", "resnet_tdl")  # take FTIN's augmentations; every other model ResNet's
STAGE_TWO_AUGMENT_ARMS = ("aug", "mirror", "pace")  # each chosen against yaw only; the chosen combined


@dataclass(frozen=True)
class StageTwoChoices:
    ftin_variant: str  # FTIN's TDL sequence
    recipe: str  # a key of RECIPES, for every model (the same budget for all)
    augment: dict[str, dict[str, float | None]]  # "ftin" / "ronin_resnet" -> augmentations beyond yaw
    why: dict[str, str]  # each choice in words, with its figure


def stage_two_choices(comparisons: Sequence[Mapping[str, Any]]) -> StageTwoChoices:
    """The choices from crossval's paired comparisons (``crossval.json["comparisons"]``): the phone-only
    rows over every dataset. ``ValueError`` naming a question stage one has not answered yet."""
    rows = {
        (row["a"], row["b"]): row
        for row in comparisons
        if row["orientation"] == PHONE_ONLY and row["dataset"] == "all"
    }

    def row(a: str, b: str) -> Mapping[str, Any]:
        if (a, b) not in rows:
            raise ValueError(f"stage one has not compared {a} with {b} yet (no phone-only row in crossval)")
        return rows[a, b]

    def said(a: str, b: str) -> str:
        return comparison_words(row(a, b))

    why: dict[str, str] = {}
    tdl = row("ftin-mixed-yaw", "ftin-ordered-yaw")
    variant = "mixed" if tdl["lower_mean"] == "a" else "ordered"
    why["ftin_variant"] = f"{variant} ({said('ftin-mixed-yaw', 'ftin-ordered-yaw')})"
    arms = {arm_of(job.name): job for job in generalisation_jobs()}
    augment: dict[str, dict[str, float | None]] = {}
    for family, prefix in (("ftin", "ftin-ordered"), ("ronin_resnet", "ronin_resnet")):
        chosen: dict[str, float | None] = {}
        for arm in STAGE_TWO_AUGMENT_ARMS:
            if row(f"{prefix}-{arm}", f"{prefix}-yaw")["lower_mean"] == "a":
                chosen.update(arms[f"{prefix}-{arm}"].options["augment"])
        augment[family] = chosen
        words = "; ".join(said(f"{prefix}-{arm}", f"{prefix}-yaw") for arm in STAGE_TWO_AUGMENT_ARMS)
        why[f"augment_{family}"] = f"{', '.join(chosen) or 'yaw only'} ({words})"
    paper = [row(f"{p}-paper", f"{p}-yaw") for p in ("ftin-ordered", "ronin_resnet")]
    pooled = sum(r["mean_m"] * r["pairs"] for r in paper) / sum(r["pairs"] for r in paper)
    recipe = "paper" if pooled < 0 else "ours"
    why["recipe"] = f"{recipe} (the paper's recipe against ours, both architectures: mean d {pooled:+.3f} m)"
    return StageTwoChoices(variant, recipe, augment, why)


def comparison_words(row: Mapping[str, Any]) -> str:
    """One paired comparison of crossval in words, with its figure."""
    return (
        f"{row['a']} vs {row['b']}: mean d {row['mean_m']:+.3f} m over {row['pairs']} pairs, "
        f"{row['walkers']} walkers"
    )


_ARM_JOB_NAME = re.compile(r"[^/]+/(?P<arm>.+)-s(?P<seed>\d+)")


def arm_of(job_name: str) -> str:
    """A walker-fold job's arm: ``walking-f0/ftin-ordered-yaw-s1`` -> ``ftin-ordered-yaw``."""
    match = _ARM_JOB_NAME.fullmatch(job_name)
    if match is None:
        raise ValueError(f"job {job_name!r}: not a walker-fold job name (<dataset>-f<fold>/<arm>-s<seed>)")
    return match["arm"]


def stage_two_jobs(choices: StageTwoChoices) -> list[Job]:
    """Every shipped checkpoint retrained with stage one's choices, the default's candidates first: the
    walking checkpoints of FTIN and RoNIN ResNet (every walking dataset), then FTIN, +TDL and RoNIN
    ResNet with ``STAGE_TWO_SEEDS`` on OxIOD and RIDI, +FDL with ``SEEDS``, the other baselines with
    one seed, and the simulator model."""
    jobs: list[Job] = []

    def add(model: str, dataset: str, seed: int) -> None:
        options = {**model_options(model, dataset), **RECIPES[choices.recipe]}
        augment = choices.augment["ftin" if model in FTIN_FAMILY else "ronin_resnet"]
        if augment:
            options["augment"] = dict(augment)
        variant = choices.ftin_variant if model == "ftin" else None
        if variant:
            options["model_kwargs"] = {**options.get("model_kwargs", {}), **FTIN_VARIANTS[variant]}
        jobs.append(
            Job(
                f"{dataset}/{model}{f'-{variant}' if variant else ''}-s{seed}",
                model,
                dataset,
                seed,
                variant,
                options,
            )
        )

    for model in ("ftin", "ronin_resnet"):
        add(model, WALKING, 0)
    for seed in STAGE_TWO_SEEDS:
        for dataset in (OXIOD, RIDI):
            for model in STAGE_TWO_MULTI_SEED:
                add(model, dataset, seed)
            if seed in SEEDS:
                add("resnet_fdl", dataset, seed)
            if seed == 0:
                for model in ("ronin_lstm", "ronin_tcn", "rnin", "imunet", "tlio"):
                    add(model, dataset, seed)
    sim = sim_job(choices.ftin_variant)
    sim_options = {**sim.options, **RECIPES[choices.recipe]}
    if choices.augment["ftin"]:
        sim_options["augment"] = dict(choices.augment["ftin"])
    jobs.append(replace(sim, options=sim_options))
    return jobs
