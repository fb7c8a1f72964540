"""Probe: does a network trained with tilt noise read better on the filter's orientation (issue 36,
"train for it where it pays")?

The filter levels a walking phone to 0.4-1.2 deg of motion capture (``docs/results/probes/
ekf_settled.md``); the default network trained on motion-capture orientation never saw such a tilt. An
earlier probe (``tilt_phone_only.md``: 5 deg of tilt, 10 epochs, VQF's orientation) did not lower the
phone-only cost; here the question is the filter's, at the filter's scale.

Method: two short fine-tunes of the default (``experiments.probe_damped_bounce.fine_tune_config``: its
recipe, Adam at ``--lr``, one thread, ``--minutes``, seed 0, no validation), on the fixed split's
training walks of the walking datasets (``ftin.protocol``; the validation and test parts never
trained on): ``finetune`` (the recipe's augmentation) and ``finetune-tilt`` (plus TLIO's gravity tilt,
``tilt`` up to ``--tilt-deg``). Each, and the shipped default (``reference``), reads the walker-held-out
validation walks (OxIOD, RIDI, Inria), phone only, alone (``auto``) and as ``filter=ekf`` answers
(``ftin.filter.levelled``: two filter passes, the re-read): start-aligned ATE (RoNIN convention), mean
over walks. The tilt arm pays if its ``filter=ekf`` gain over ``finetune``'s is beyond the seed-sized
moves the ``auto`` column shows.

    nice -n 10 .venv/bin/python -m experiments.probe_filter_tilt --minutes 8 \
        --out docs/results/probes/filter_tilt.md
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from experiments.common import argument_parser, parse, write_report
from experiments.probe_damped_bounce import START, final_weights, fine_tune_config, start_recipe
from experiments.probe_ekf import SETS, set_paths
from ftin import protocol
from ftin.checkpoint import LoadedModel, load_model
from ftin.data.loading import load_phone_only, load_sequences
from ftin.evaluate import score
from ftin.files import DEFAULT_DATA_ROOT
from ftin.filter.levelled import levelled_prediction
from ftin.infer import predict_trajectory
from ftin.train.loop import train

RUNS = Path("runs/probes/filter_tilt")
VALIDATION = ("oxiod-val", "ridi-val", "inria-val")
REFERENCE = "reference"


def arms(tilt_deg: float) -> dict[str, dict[str, float | None]]:
    return {"finetune": {}, "finetune-tilt": {"tilt": tilt_deg}}


def read_walks(loaded: LoadedModel, walks: dict[str, list]) -> dict[str, list[dict]]:
    """Per set, per walk: the start-aligned ATE alone and as ``filter=ekf`` answers."""
    out: dict[str, list[dict]] = {}
    for set_name, seqs in walks.items():
        rows = []
        for seq in tqdm(seqs, desc=f"{loaded.name} {set_name}", unit="walk"):
            alone = score(predict_trajectory(loaded, seq), "start").metrics.ate
            read = levelled_prediction(loaded, seq)
            rows.append({"name": seq.name, "auto": alone, "ekf": score(read.prediction, "start").metrics.ate})
        out[set_name] = rows
    return out


def run_arm(arm: str, augment, args, walks: dict[str, list], train_seqs) -> dict:
    folder = RUNS / arm
    result_path = folder / "result.json"
    if result_path.exists():
        return json.loads(result_path.read_text())
    if arm == REFERENCE:
        result = {"arm": arm, "steps": 0, "sets": read_walks(load_model(START), walks)}
    else:
        config = fine_tune_config(
            folder, len(train_seqs()), augment, args.lr, args.minutes, None, "experiments.probe_filter_tilt"
        )
        trained = train(config, train_seqs(), progress=False)
        result = {
            "arm": arm,
            "augment": config.augment,
            "steps": trained.steps,
            "epochs": trained.epochs_done,
            "sets": read_walks(final_weights(folder), walks),
        }
    folder.mkdir(parents=True, exist_ok=True)
    result_path.write_text(json.dumps(result, indent=2) + "\n")
    return result


def report(results: list[dict], args) -> list[str]:
    lines = [
        "# Tilt noise in training, read on the filter's orientation (a probe)",
        "",
        f"Made by `python -m experiments.probe_filter_tilt --minutes {args.minutes:g} --tilt-deg"
        f" {args.tilt_deg:g}` (its docstring: method). Start-aligned ATE (m), mean over the"
        " walker-held-out validation walks, phone only: the model alone (`auto`) and as `filter=ekf`"
        " answers (two filter passes, the re-read); in brackets `filter=ekf` against `auto`.",
        "",
        "| arm | augment | steps | " + " | ".join(f"{s} auto / ekf" for s in VALIDATION) + " |",
        "|---|---|--:|" + "---|" * len(VALIDATION),
    ]
    for r in results:
        cells = []
        for set_name in VALIDATION:
            rows = r["sets"][set_name]
            auto = float(np.mean([w["auto"] for w in rows]))
            ekf = float(np.mean([w["ekf"] for w in rows]))
            cells.append(f"{auto:.3f} / {ekf:.3f} ({ekf / auto - 1:+.1%})")
        lines.append(f"| {r['arm']} | {r.get('augment') or '-'} | {r['steps']} | {' | '.join(cells)} |")
    return lines


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--minutes", type=float, default=8.0, help="training budget per arm")
    parser.add_argument("--lr", type=float, default=1e-4, help="Adam learning rate of the fine-tune")
    parser.add_argument("--tilt-deg", type=float, default=2.0, help="the tilt augmentation's magnitude")
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    torch.set_num_threads(1)  # one thread, as the fine-tunes of probe_damped_bounce ran
    walks = {s: load_phone_only(set_paths(DEFAULT_DATA_ROOT, *SETS[s])) for s in VALIDATION}
    loaded_train: list = []

    def train_seqs() -> list:  # read once, only when an arm trains
        if not loaded_train:
            paths = protocol.split_paths(DEFAULT_DATA_ROOT, protocol.WALKING, "train")
            loaded_train.extend(load_sequences(paths, "walking train", start_recipe().orientation))
        return loaded_train

    results = [run_arm(REFERENCE, None, args, walks, train_seqs)]
    results += [
        run_arm(arm, augment, args, walks, train_seqs) for arm, augment in arms(args.tilt_deg).items()
    ]
    write_report(args.out, report(results, args))


if __name__ == "__main__":
    main()
