"""The training jobs of the campaigns: the ``Job`` every campaign runs and each campaign's list of them.

Training settings, the same for every model (``COMMON``): Adam lr 1e-3, plateau decay (factor 0.3,
patience 3 epochs on the validation 1 s-velocity MSE), early stopping after 8 epochs without a new
best, at most 60 epochs, stop below lr 1e-6; yaw augmentation; orientation from the ground truth
(the network alone); 1 thread per run. Every model sees each sample about five times per epoch:
window models take 1 s windows every 0.2 s, RNIN its ten 1 s sub-windows every 2 s, RoNIN's LSTM
and TCN their 400-frame chunks every 80 frames. Batches follow the references: 128 windows; RNIN
32 sequences (its reference); RoNIN LSTM/TCN 72 chunks (their reference). TLIO switches from MSE to
its Gaussian NLL after 5 epochs (its reference trains MSE first; 5 < the earliest early stop).
RNIN trains with its reference loss (MSE on sub-window displacements plus 8x their cumulative sum;
the reference never switches to the NLL within its epochs). What differs per model is the model's
own: its registry entry's ``train_options`` (``ftin.models.model_train_options``).

Campaigns: Table 1 (``campaign_jobs``), the generalisation campaign's first stage
(``generalisation_jobs``), the tilt question (``tilt_question_jobs``); the simulator's job is
``sim_job``. Stage two's jobs are in ``ftin.protocol.stages``, stage three's in
``ftin.protocol.stage_three``; ``ftin.protocol.campaigns`` names them all for ``plan --jobs``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from ftin.models import list_models, model_train_options
from ftin.protocol.datasets import (
    COMBINED,
    DATA_FOLDERS,
    EVAL_ORIENTATIONS,
    FOLDS,
    OXIOD,
    PEDESTRIAN,
    RATE_HZ,
    RIDI,
    SIM,
    WALKING,
    split_paths,
)

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
        combined dataset with ``dataset``: of its own parts, those under that member's folder)."""
        if self.parts:
            rels = self.parts.get(part, ())
            if dataset is not None and dataset != self.dataset and dataset in DATA_FOLDERS:
                rels = tuple(r for r in rels if r.startswith(DATA_FOLDERS[dataset] + "/"))
            return [Path(data_root) / rel for rel in rels]
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
        of its dataset (each member of a combined one); a job with its own parts on a protocol dataset
        the reference alone (the gate's), data outside the protocol the reader's default."""
        members = COMBINED.get(self.dataset, (self.dataset,))
        return [(d, part, self._orientations(d)) for d in members for part in ("val", "test")]

    def _orientations(self, dataset: str) -> tuple[str | None, ...]:
        if dataset not in EVAL_ORIENTATIONS:
            return (None,)
        return ("ground_truth",) if self.parts else EVAL_ORIENTATIONS[dataset]

    @property
    def checkpoint_stem(self) -> str:
        return f"{self.model}-{self.dataset}"

    def to_json(self) -> dict[str, Any]:
        """Every field by its name (``parts``' tuples as lists): what ``from_json`` reads."""
        return {**asdict(self), "parts": {k: list(v) for k, v in self.parts.items()}}

    @classmethod
    def from_json(cls, spec: Mapping[str, Any]) -> Job:
        """A job from its JSON form; ``options`` go over the model's ``model_options`` when the
        dataset has a rate in the protocol."""
        unknown = sorted(set(spec) - {f.name for f in fields(cls)})
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


def model_options(model: str, dataset: str) -> dict[str, Any]:
    """Window, stride, batch and loss choices of ``model`` at ``dataset``'s rate (module docstring): a
    1 s window unless the model's ``train_options`` say otherwise, the stride that gives each sample
    ``PASSES_PER_EPOCH`` windows per epoch."""
    rate = int(RATE_HZ[dataset])
    options: dict[str, Any] = {"imu_rate_hz": float(rate), "window": rate, "stride": rate // PASSES_PER_EPOCH}
    if model in list_models():  # a job file may name a model this code lacks: it fails when it trains
        options.update(model_train_options(model, rate))
    options["stride"] = options["window"] // PASSES_PER_EPOCH
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


def sim_job(variant: str) -> Job:
    """FTIN on simulated walks (``SIM_TRAIN_WALKS`` / ``SIM_VAL_WALKS`` under the campaign folder's
    ``sim-data``), tested on the app's bundled samples (never trained or chosen on)."""
    options = {
        **model_options("ftin", SIM),
        "model_kwargs": dict(FTIN_VARIANTS[variant]),
        "orientation": None,
    }
    samples = Path(__file__).resolve().parents[1] / "sim" / "samples"
    parts = {"train": ("sim-data/train",), "val": ("sim-data/val",), "test": (str(samples),)}
    return Job(f"sim/ftin-{variant}-s0", "ftin", SIM, 0, variant, options, parts=parts)
