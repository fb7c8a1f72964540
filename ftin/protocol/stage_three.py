"""Stage three: the walkers the shared data gained, and what the campaign trains on them.

The 30 OxIOD walks added to ``../shared/data`` (its README, "More OxIOD walks") join the protocol as a
fold of their own, leaving the frozen ``WALKER_FOLDS`` of stages one and two as they were (their
records stay comparable):

- ``NEW_TRAIN``: walker 3 (pocket, handbag), iPhone 6 walks 1-6, Nexus 5 walk 7, running walk 6.
- ``NEW_VAL``: walker 4, iPhone 6 walks 7-9, Nexus 5 walk 8, running walk 7, the pocket walk: every
  choice of stage three is judged on them with the old validation walkers, never on ``NEW_TRAIN``.
- ``FLOOR_DRIFT``: the ten long floor walks (Tango ground truth) measure drift over minutes (ATE and
  end-point error per 100 m); no stage-three job trains on them. Their steps agree with Tango's
  distance (0.61-0.63 m a step on all ten), but a short fine-tune of the default on more walkers
  shortened the held-out floor walks 1-3 from 0.87 to about half their distance, with or without their
  sister walks in training (``docs/results/probes/damped_bounce.md``): until that is understood they
  judge, they do not teach.

Jobs (``stage_three_jobs``): the variance head of the probes' choice (``docs/results/probes/
uncertainty.md``: no per-window sigma without one follows the error) trained on the frozen shipped
walking checkpoints (``TrainConfig.train_only``), so their velocities, Table 1 and the default stay
bit for bit; TLIO's gravity perturbation (``tilt``) beside the checkpoints' own augmentation, so the
head sees the tilt a phone's orientation leaves (issue 36).

Retrain jobs (``stage_three_retrain_jobs``, campaign ``stage-three-retrain``): the default's network
(RoNIN ResNet, its recipe: mirror) trained from scratch at full budget on the same pooled walkers,
beside the same with the bounce scaled by 0.4-1.6 (``vertical`` 0.6) so that the bounce's amplitude
alone cannot be read as speed (the damped carries). The full-budget form of the 8-minute fine-tunes
of ``docs/results/probes/damped_bounce.md``; judged on the validation walkers old and new and the
floor walks, against the shipped default. A third arm, ``pooled-agreeing``, leaves out of training and
validation the walks whose reference orientation disagrees with their own IMU
(``REFERENCE_DISAGREES``: ``docs/results/probes/reference_frames.md``), since every job trains on the
IMU rotated by that reference: markers off the phone's axes feed the network gravity against its
labels. (Campaign ``runs/stage-three-retrain`` froze the code before the reader paired OxIOD's Vicon
rows by their rates and left out seven walks; ``runs/stage-three-synced`` trains on today's reader.)
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ftin.protocol.datasets import INRIA, OXIOD, RIDI, WALKING, split_paths
from ftin.protocol.jobs import Job, model_options

_OXIOD = "oxiod/"
NEW_TRAIN = tuple(
    _OXIOD + rel
    for rel in (
        *(f"multi users/user3/syn/imu{i}.csv.xz" for i in (4, 5, 7)),
        *(f"multi devices/iPhone 6/syn/imu{i}.csv.xz" for i in range(1, 7)),
        "multi devices/nexus 5/syn/imu7.csv.xz",
        "running/data1/syn/imu6.csv.xz",
    )
)
NEW_VAL = tuple(
    _OXIOD + rel
    for rel in (
        *(f"multi users/user4/syn/imu{i}.csv.xz" for i in (4, 6, 7)),
        *(f"multi devices/iPhone 6/syn/imu{i}.csv.xz" for i in range(7, 10)),
        "multi devices/nexus 5/syn/imu8.csv.xz",
        "running/data1/syn/imu7.csv.xz",
        "pocket/data1/syn/imu5.csv.xz",
    )
)
FLOOR_DRIFT = tuple(f"{_OXIOD}large scale/floor1/syn/imu{i}.csv.xz" for i in range(1, 11))

# The shipped walking checkpoints that gain a head, with the augmentation each was trained with.
HEADED = {
    "ronin_resnet": ("ronin_resnet-walking", {}, {"mirror": None}),
    "ftin": ("ftin-walking", {"fdl_output": "mixed"}, {"mirror": None, "pace": None}),
}
HEAD_OPTIONS: dict[str, Any] = {
    "train_only": ["log_std_head"],
    "loss": "nll",
    "nll_warmup_epochs": 0,  # the velocity is frozen: nothing to warm up
    "max_epochs": 30,
    "early_stop_patience": 4,
    "plateau_patience": 2,
}


# Walks whose reference orientation disagrees with their IMU (``ftin.data.reference_check``: the
# horizontal acceleration it gives misses the reference position's by over 0.5 m/s² and over twice what
# the IMU levelled by itself misses by), relative to the data root. With the OxIOD reader's Vicon
# pairing (``ftin.data.io.vicon_sync``) three are left of the seven found before it: user3's pocket
# walks and the Nexus 5's were Vicon rows 0.1-0.3 s off their IMU rows.
REFERENCE_DISAGREES = (
    "inria_attitude/datasets/android/Thibaud_Nexus5_Dist_FrontPocket",
    "inria_attitude/datasets/android/Thibaud_Nexus5_Dist_Phoning",
    f"{_OXIOD}multi devices/iPhone 6/syn/imu5.csv.xz",
)

RETRAIN_MODEL = "ronin_resnet"
# arm -> (augmentations beyond yaw, whether the REFERENCE_DISAGREES walks are left out)
RETRAIN_ARMS: dict[str, tuple[dict[str, float | None], bool]] = {
    "pooled": ({"mirror": None}, False),
    "pooled-vertical": ({"mirror": None, "vertical": 0.6}, False),
    "pooled-agreeing": ({"mirror": None}, True),
}


def relative_paths(data_root: Path, part: str) -> tuple[str, ...]:
    """The walking dataset's ``part`` (the stage-two split the checkpoints trained on), relative."""
    root = Path(data_root)
    return tuple(str(p.relative_to(root)) for d in (OXIOD, RIDI, INRIA) for p in split_paths(root, d, part))


def stage_three_jobs(data_root: Path, checkpoint_dir: Path) -> list[Job]:
    """One job per headed checkpoint: its training and validation walkers plus the new fold's."""
    jobs = []
    for model, (stem, kwargs, augment) in HEADED.items():
        options = {
            **model_options(model, WALKING),
            **HEAD_OPTIONS,
            "model_kwargs": {**kwargs, "uncertainty_head": True},
            "augment": {**augment, "tilt": None},
            "init_from": str(Path(checkpoint_dir).resolve() / f"{stem}.safetensors"),
        }
        name = f"stage-three/{model}-head-s0"
        jobs.append(Job(name, model, WALKING, 0, "head", options, None, _parts(data_root)))
    return jobs


def _parts(data_root: Path, leave_out: tuple[str, ...] = ()) -> dict[str, tuple[str, ...]]:
    """Stage two's walkers plus the new fold's, without ``leave_out``; the floor walks as the test part
    (drift only)."""
    train = (*relative_paths(data_root, "train"), *NEW_TRAIN)
    val = (*relative_paths(data_root, "val"), *NEW_VAL)
    return {
        "train": tuple(r for r in train if r not in leave_out),
        "val": tuple(r for r in val if r not in leave_out),
        "test": FLOOR_DRIFT,
    }


def stage_three_retrain_jobs(data_root: Path) -> list[Job]:
    """One job per ``RETRAIN_ARMS`` arm: the default's network from scratch on the pooled walkers."""
    return [
        Job(
            f"stage-three-retrain/{RETRAIN_MODEL}-{arm}-s0",
            RETRAIN_MODEL,
            WALKING,
            0,
            arm,
            {**model_options(RETRAIN_MODEL, WALKING), "augment": dict(augment)},
            None,
            _parts(data_root, REFERENCE_DISAGREES if agreeing_only else ()),
        )
        for arm, (augment, agreeing_only) in RETRAIN_ARMS.items()
    ]
