"""The datasets of the evaluation protocol: names, labels, folders, rates, fixed splits and walker folds.

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
"""

from __future__ import annotations

from pathlib import Path

from ftin.data.readers import dataset_folder, dataset_label

OXIOD = "oxiod"
RIDI = "ridi"
INRIA = "inria"  # the Inria smartphone attitude benchmark (walks with Qualisys ground truth)
PEDESTRIAN = "pedestrian"  # OxIOD and RIDI together, at 100 Hz (the first campaign's app default)
WALKING = "walking"  # every walking dataset together (OxIOD, RIDI, Inria), at 100 Hz
SIM = "sim"
COMBINED = {PEDESTRIAN: (OXIOD, RIDI), WALKING: (OXIOD, RIDI, INRIA)}
_PROTOCOL_DATASETS = (OXIOD, RIDI, INRIA)
# How reports name the datasets, and where each lives under the data root: their readers say
# (``@register_reader(dataset=..., folder=...)``; the Inria reader reads ``<platform>/<walk>`` folders).
DATASET_LABELS = {d: dataset_label(d) for d in _PROTOCOL_DATASETS}
DATA_FOLDERS = {d: dataset_folder(d) for d in _PROTOCOL_DATASETS}
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
    """Who walked a recording (a path relative to the dataset's folder). OxIOD: ``handheld`` is user 1,
    ``multi users/userN`` user N; any other folder (trolley, running, pocket, another phone, the large
    floor: the release names no walker) is its own group. RIDI and Inria: the name's first word."""
    if dataset == OXIOD:
        top, folder = recording.split("/")[:2]
        if top == "multi users":
            return folder
        return "user1" if top == "handheld" else f"{top}-{folder}"
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
