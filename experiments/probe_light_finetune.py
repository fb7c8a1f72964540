"""From the default, not from scratch: does a fine-tune with the light segment term keep the dense walks?

Question: the light arm of the stride retrain (``stride-retrain-light``: from scratch, the ILC segment
term at 0.1) reads the held-out ILC floors near their length but every dense validation set worse than the
shipped default (``stride_retrain_judge.md``). Starting from the default's weights instead, does the same
mixed loss lengthen the held-out floors while the dense walks stay where the default reads them?

Method (a fine-tune of minutes): ``experiments.probe_sparse_truth``'s fine-tune (from
``checkpoints/ronin_resnet-walking``, Adam at ``--lr``, batch norm as shipped, bf16 autocast, seed 0,
``--steps`` steps of ``--dense`` windows of the default's training walks with its recipe, ``mirror``),
in two arms: ``dense`` (those windows alone: what fine-tuning itself does) and ``sparse0.1+dense`` (plus
``--chunks`` ILC chunks of floors F1-F3 a step, the segment loss at ``SPARSE_WEIGHT``, the light arm's).
Each network is saved under ``runs/probes/light_finetune/`` and read by the stride judge's rows
(``experiments.judge_stride_retrain``: every group, phone only, as the app runs).

The rule, written before any arm was read: a fine-tune from the default with the light segment term
becomes the retrain's next campaign arm when ``sparse0.1+dense`` reads **both** held-out ILC floors' median
path ratio closer to 1 than ``dense`` does, and no dense validation set (OxIOD, RIDI, Inria) has a mean ATE
worse than the **untouched default's** by more than 5 % (the bar that arm would face).

    nice -n 10 python -m experiments.probe_light_finetune --out docs/results/probes/light_finetune.md
"""

from __future__ import annotations

import functools
import time
from pathlib import Path

import numpy as np

from experiments.common import argument_parser, parse, write_report
from experiments.judge_stride_retrain import (
    DEFAULT,
    DENSE_SETS,
    WORSE_AT_MOST,
    cached_rows,
    floor_ratio,
    rows_table,
    set_ates,
)
from experiments.probe_sparse_truth import (
    TRAIN_FLOORS,
    SparseChunks,
    default_training_windows,
    fine_tune,
    fine_tune_arguments,
    fine_tuned_once,
    ilc_paths,
)
from ftin.data.discovery import read_sequence
from ftin.files import DEFAULT_DATA_ROOT
from ftin.protocol.stride_retrain import ILC_HELD_OUT, LIGHT_SPARSE_WEIGHT

RUNS = Path("runs/probes/light_finetune")
SPARSE_WEIGHT = LIGHT_SPARSE_WEIGHT
ARMS = ("dense", "sparse0.1+dense")


def verdict(default: dict, dense: dict, mixed: dict) -> tuple[bool, list[str]]:
    adopted, reasons = True, []
    for floor in ILC_HELD_OUT:
        d, m = floor_ratio(dense, floor), floor_ratio(mixed, floor)
        adopted &= abs(m - 1) < abs(d - 1)
        reasons.append(f"ILC {floor}: median path ratio, dense {d:.3f} -> sparse0.1+dense {m:.3f}")
    for group in DENSE_SETS:
        base, ate = np.mean(set_ates(default, group)), np.mean(set_ates(mixed, group))
        adopted &= ate <= base * (1 + WORSE_AT_MOST)
        reasons.append(f"{group} validation: mean ATE, default {base:.3f} -> sparse0.1+dense {ate:.3f} m "
                       f"({ate / base - 1:+.1%})")  # fmt: skip
    return bool(adopted), reasons


def main() -> None:
    parser = argument_parser(__doc__)
    fine_tune_arguments(parser, steps=1200)
    parser.add_argument("--chunks", type=int, default=2, help="ILC chunks per step (sparse arm)")
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    args.freeze_bn = True  # probe_sparse_truth.fine_tune reads it: batch norm as shipped
    started = time.monotonic()
    RUNS.mkdir(parents=True, exist_ok=True)
    rows, training = {"default (untouched)": cached_rows(DEFAULT, args.data_root)}, {}
    dense = functools.cache(lambda: default_training_windows(args.data_root))  # read once, if at all
    for arm in ARMS:
        stem = RUNS / f"{arm}-{args.steps}-{args.lr:g}-{args.dense}-{args.chunks}"

        def train(arm: str = arm) -> tuple:
            sparse = None
            if arm != "dense":
                walks = [read_sequence(p) for p in ilc_paths(args.data_root, TRAIN_FLOORS)]
                sparse = SparseChunks(walks, 100.0, 100)
            return fine_tune(arm, dense(), sparse, args, SPARSE_WEIGHT)

        training[arm] = fine_tuned_once(stem, train)
        rows[arm] = cached_rows(stem, args.data_root)
    adopted, reasons = verdict(rows["default (untouched)"], rows["dense"], rows["sparse0.1+dense"])
    minutes = (time.monotonic() - started) / 60

    def pair(info: dict, key: str) -> str:
        first, last = info.get(f"{key}_first_fifth"), info.get(f"{key}_last_fifth")
        return "—" if first is None else f"{first:.3f} -> {last:.3f}"

    lines = [
        "# From the default: a fine-tune with the light segment term (ILC), a probe of minutes",
        "",
        "Made by `nice -n 10 python -m experiments.probe_light_finetune "
        f"--steps {args.steps} --lr {args.lr:g} --dense {args.dense} --chunks {args.chunks} "
        f"--out {args.out}` "
        f"({minutes:.0f} min this run, two shared cores). Its docstring: method and the rule, written "
        "before any arm was read. Phone only; ATE in m (ILC: median at the waypoints); path ratio median "
        "(walks in 0.85-1.15).",
        "",
        "| arm | steps | minutes | dense loss first -> last fifth | segment loss first -> last fifth |",
        "|---|--:|--:|---|---|",
        *(
            f"| {arm} | {t['steps']} | {t['minutes']:.1f} | {pair(t, 'dense_loss')} "
            f"| {pair(t, 'sparse_loss')} |"
            for arm, t in training.items()
        ),
        "",
        *rows_table(rows),
        "",
        f"**By the rule: {'a campaign arm' if adopted else 'not a campaign arm'}.**",
        "",
        *(f"- {r}" for r in reasons),
    ]
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
