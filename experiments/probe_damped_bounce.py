"""What makes speed survive a damped bounce (a handbag, a phone held steadily in front, running)?

Question (issue 34, before stage three's retrain): the shipped default reads running at 0.41-0.44 of
its distance, the handbag walk at 0.73, the iPhone 6 at 0.52-0.91 (docs/results/probes/
new_oxiod_walks.md), and it reads speed mostly from the vertical bounce (speed_cues*.md). Is more
data (the new OxIOD walks) enough, or does a wider bounce augmentation (``vertical`` scaling the
bounce in [0.3, 1.7] instead of [0.7, 1.3]) or the pace augmentation add to it?

Method: a short fine-tune, not a campaign. Every arm starts from ``checkpoints/ronin_resnet-walking``
(``TrainConfig.init_from``) with its recipe as its JSON records it (rate, window, stride, batch,
normalisation, ``ground_truth`` orientation, its ``mirror`` augmentation), Adam at ``--lr`` (a tenth
of the recipe's: a fine-tune), seed 0, one torch thread, ``--minutes`` of training and no validation
(no choice is made on any walk: the weights scored are those at the end of the budget). Training set:
the walking dataset's walker-fold-0 training recordings (``ftin.protocol``) plus the new OxIOD walks
of the groups not held out (iPhone 6 imu5-9, Nexus 5, running imu6, pocket, floor1 imu4-10). Arms
(``ARMS``): ``more-data`` (the recipe's augmentation only), ``vertical-0.7`` and
``vertical-0.7+pace``; the untouched checkpoint is the ``reference`` row. Held out in every arm
(``HELD_OUT``): user3 (pockets, handbag), user4, running imu7, iPhone 6 imu1-4, floor1 imu1-3, read
phone only and scored as ``experiments.probe_new_oxiod_walks`` scores them (ATE, RoNIN convention;
standing still; distance ratio, in bounds at 0.8-1.2).

    nice -n 10 .venv/bin/python -m experiments.probe_damped_bounce --minutes 6 \
        --out docs/results/probes/damped_bounce.md

Each arm lands in ``runs/probes/damped_bounce/<arm>/`` with ``result.json``; finished arms are
skipped when the probe is run again (an unfinished folder is trained again from the start).
"""

from __future__ import annotations

import json
import shutil
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
import torch

from experiments.common import argument_parser, parse, write_report
from experiments.probe_new_oxiod_walks import NEW_WALKS, walk_row
from ftin import protocol
from ftin.checkpoint import LoadedModel, load_model
from ftin.data.loading import load_phone_only, load_sequences
from ftin.files import DEFAULT_DATA_ROOT
from ftin.train.config import LossKind, TrainConfig
from ftin.train.loop import train
from ftin.train.state import RESUME_FILE, load_training_state

RUNS = Path("runs/probes/damped_bounce")
START = Path("checkpoints/ronin_resnet-walking")
REFERENCE = "reference"
# New walks no arm trains on (relative to oxiod/, as NEW_WALKS names them).
HELD_OUT = (
    *(f"multi users/user3/syn/imu{i}.csv.xz" for i in (4, 5, 7)),
    *(f"multi users/user4/syn/imu{i}.csv.xz" for i in (4, 6, 7)),
    "running/data1/syn/imu7.csv.xz",
    *(f"multi devices/iPhone 6/syn/imu{i}.csv.xz" for i in range(1, 5)),
    *(f"large scale/floor1/syn/imu{i}.csv.xz" for i in range(1, 4)),
)
NEW_TRAINING = tuple(rel for rel in NEW_WALKS if rel not in HELD_OUT)
# Augmentations each arm adds to the recipe's own (the checkpoint's ``mirror``).
ARMS: dict[str, dict[str, float | None]] = {
    "more-data": {},
    "vertical-0.7": {"vertical": 0.7},
    "vertical-0.7+pace": {"vertical": 0.7, "pace": None},
    "more-data-no-floor": {},
}
# Training walks an arm leaves out, by name prefix: ``more-data-no-floor`` asks whether the floor walks
# (Tango, trained through their fitted orientation) are what pulled the held-out walks down.
ARM_LEAVES_OUT: dict[str, str] = {"more-data-no-floor": "large scale/"}


def start_recipe() -> TrainConfig:
    """The training config the starting checkpoint was made with (its JSON's ``train_config``)."""
    return TrainConfig.from_json(json.loads(START.with_suffix(".json").read_text())["train_config"])


def fine_tune_config(
    folder: Path,
    sequences: int,
    augment: dict[str, float | None],
    lr: float,
    minutes: float,
    steps: int | None,
    probe: str,
) -> TrainConfig:
    """The starting checkpoint's recipe as a fine-tune into ``folder``: from its weights (its model as
    shipped, the variance head stage three added included, the head left as it is: the velocity's MSE),
    Adam at ``lr``, its augmentation plus ``augment``, ``minutes`` (or ``steps``) of training, seed 0, no
    validation (the weights at the end of the budget are the ones scored)."""
    recipe = start_recipe()
    shipped = json.loads(START.with_suffix(".json").read_text())
    return recipe.with_(
        model_kwargs=shipped["model_kwargs"],
        loss=LossKind.MSE,
        data=(f"{sequences} sequences, see {probe.replace('.', '/')}.py",),
        val=(),
        val_fraction=0.0,
        out_dir=str(folder),
        name="model",
        init_from=str(START),
        lr=lr,
        augment={**recipe.augment, **augment},
        max_minutes=None if steps else minutes,
        max_steps=steps,
        max_epochs=1000,  # the minutes (or steps) end every arm
        early_stop_patience=None,
        seed=0,
        weights_dtype="float32",
    )


def oxiod_paths(data_root: Path, relatives: tuple[str, ...]) -> list[Path]:
    return [data_root / protocol.DATA_FOLDERS[protocol.OXIOD] / rel for rel in relatives]


def final_weights(run: Path) -> LoadedModel:
    """The run's model as it stood when the budget ended (its resume state), not its best epoch's."""
    loaded = load_model(run / "model")
    optimizer = torch.optim.Adam(loaded.model.parameters())
    scheduler = torch.optim.lr_scheduler.ReduceLROnPlateau(optimizer)
    load_training_state(run / RESUME_FILE, model=loaded.model, optimizer=optimizer, scheduler=scheduler)
    loaded.model.eval()
    return loaded


def score_walks(loaded: LoadedModel, held_out: list) -> list[dict[str, Any]]:
    return [walk_row(loaded, rel, seq) for rel, seq in zip(HELD_OUT, held_out, strict=True)]


def run_arm(
    arm: str, minutes: float, lr: float, train_seqs: list, held_out: list, steps: int | None = None
) -> dict[str, Any]:
    folder = RUNS / arm
    result_path = folder / "result.json"
    if result_path.exists():
        return json.loads(result_path.read_text())
    if folder.exists():  # an interrupted run: start it again
        shutil.rmtree(folder)
    if arm == REFERENCE:
        result = {"arm": arm, "augment": None, "steps": 0, "rows": score_walks(load_model(START), held_out)}
    else:
        if arm in ARM_LEAVES_OUT:
            train_seqs = [seq for seq in train_seqs if not seq.name.startswith(ARM_LEAVES_OUT[arm])]
        probe = "experiments.probe_damped_bounce"
        config = fine_tune_config(folder, len(train_seqs), ARMS[arm], lr, minutes, steps, probe)
        trained = train(config, train_seqs, progress=False)
        losses = [h["train_loss"] for h in trained.history]
        result = {
            "arm": arm,
            "augment": config.augment,
            "lr": lr,
            "minutes": None if steps else minutes,
            "training_sequences": len(train_seqs),
            "steps": trained.steps,
            "epochs": trained.epochs_done,
            "epoch_train_loss": losses,
            "rows": score_walks(final_weights(folder), held_out),
        }
    folder.mkdir(parents=True, exist_ok=True)
    result_path.write_text(json.dumps(result, indent=2) + "\n")
    print(f"{arm}: {result['steps']} steps, mean ATE {np.mean([r['ate'] for r in result['rows']]):.2f} m")
    return result


def group_line(arm: str, group: str, part: list[dict[str, Any]]) -> str:
    ate, still = np.mean([r["ate"] for r in part]), np.mean([r["still"] for r in part])
    ratios = [r["ratio"] for r in part if r["ratio"] is not None]
    inside = sum(0.8 <= r <= 1.2 for r in ratios)
    return (
        f"| {arm} | {group} | {len(part)} | {ate:.2f} | {still:.2f} | {ate / still:.2f} "
        f"| {min(ratios):.2f}-{max(ratios):.2f} | {np.mean(ratios):.2f} | {inside} of {len(ratios)} |"
    )


def report(results: list[dict[str, Any]]) -> list[str]:
    lines = [
        "# Damped bounce: fine-tuning the default on the new OxIOD walks, phone only",
        "",
        "Made by `python -m experiments.probe_damped_bounce` (its docstring: question, method). Held-out",
        "walks only (no arm trains on them), read phone only. ATE in m, RoNIN convention; ratio: distance",
        "ratio (predicted path over the walked distance, in bounds at 0.8-1.2).",
        "",
        "| arm | augment beyond yaw | lr | minutes | steps | epochs | train loss per epoch |",
        "|---|---|--:|--:|--:|--:|---|",
    ]
    for r in results:
        if r["arm"] == REFERENCE:
            lines.append("| reference | (the shipped checkpoint, untouched) | — | — | 0 | — | — |")
            continue
        augment = ", ".join(k if v is None else f"{k} {v:g}" for k, v in r["augment"].items())
        losses = ", ".join(f"{v:.4f}" for v in r["epoch_train_loss"]) or "— (no epoch ended)"
        minutes = "—" if r["minutes"] is None else f"{r['minutes']:g}"
        lines.append(
            f"| {r['arm']} | {augment} | {r['lr']:g} | {minutes} | {r['steps']} | {r['epochs']} | {losses} |"
        )
    lines += [
        "",
        "| arm | group | walks | mean ATE | stand still | ATE / still | ratio (min-max) | ratio mean "
        "| in 0.8-1.2 |",
        "|---|---|--:|--:|--:|--:|---|--:|--:|",
    ]
    for r in results:
        groups: dict[str, list[dict[str, Any]]] = defaultdict(list)
        for row in r["rows"]:
            groups[row["group"]].append(row)
        lines += [group_line(r["arm"], g, part) for g, part in [*groups.items(), ("all", r["rows"])]]
    lines += ["", "Per walk (ATE / distance ratio):", ""]
    arms = [r["arm"] for r in results]
    lines += ["| walk | carry | still | " + " | ".join(arms) + " |", "|---|---|--:|" + "---|" * len(arms)]
    for i, row in enumerate(results[0]["rows"]):
        cells = [f"{r['rows'][i]['ate']:.2f} / {r['rows'][i]['ratio']:.2f}" for r in results]
        lines.append(f"| {row['walk']} | {row['carry']} | {row['still']:.2f} | " + " | ".join(cells) + " |")
    return lines


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--minutes", type=float, default=6.0, help="training budget per arm")
    parser.add_argument("--lr", type=float, default=1e-4, help="Adam learning rate of the fine-tune")
    parser.add_argument(
        "--steps", type=int, default=None, help="a budget in steps, not minutes (a busy machine)"
    )
    parser.add_argument("--arms", nargs="*", default=list(ARMS), choices=list(ARMS), help="arms to train")
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None, help="markdown report (default: print only)")
    args = parse(parser)
    held_out = load_phone_only(oxiod_paths(args.data_root, HELD_OUT), "held-out walks")
    results = [run_arm(REFERENCE, 0.0, 0.0, [], held_out)]
    if any(not (RUNS / arm / "result.json").exists() for arm in args.arms):
        orientation = start_recipe().orientation  # as the walking campaign trained: ground_truth
        fold = protocol.split_paths(args.data_root, protocol.WALKING, "train", 0)
        train_seqs = [
            *load_sequences(fold, "fold 0", orientation),
            *load_sequences(oxiod_paths(args.data_root, NEW_TRAINING), "new walks", orientation),
        ]
    else:
        train_seqs = []
    results += [run_arm(arm, args.minutes, args.lr, train_seqs, held_out, args.steps) for arm in args.arms]
    write_report(args.out, report(results))


if __name__ == "__main__":
    main()
