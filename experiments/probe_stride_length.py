"""Does stretching the stride in training teach the default to read a long stride long? (issue 54, item 3)

Question: the networks read speed mostly from the vertical bounce and hardly from the horizontal swing
(``speed_cues_walking.md``: the along-track swing at 1.5x moves the speed by under 2 %), and long strides
read short. The ``stride_length`` augmentation (``ftin.train.augment``) stretches each window's
horizontal motion and its target alike at the same cadence and bounce, so only the swing tells the
stretch. Does it lengthen walks the network never saw, without hurting the dense validation sets?

Method (a fine-tune of minutes, not a campaign): ``experiments.probe_sparse_truth``'s fine-tune (from
``checkpoints/ronin_resnet-walking``, Adam at ``--lr``, batch norm as shipped, bf16 autocast, ``--steps``
steps of ``--dense`` windows of the default's own training walks, seed 0), dense truth only, in two arms
that differ only in the augmentation: ``mirror`` (the default's recipe) and ``mirror+stride_length``
(magnitude 0.3: 0.77-1.3x). Each fine-tuned network is saved under ``runs/probes/stride_length/`` and read
by the stride judge's rows (``experiments.judge_stride_retrain``: every group, phone only, flat lock and
all as the app runs), beside the untouched default.

The rule, written before any arm was read: ``stride_length`` goes into the next retrain's recipe when,
against ``mirror`` (the same fine-tune without it), the median path ratio is closer to 1 on at least three
of the four held-out groups (ILC B1, ILC F4, the new OxIOD walkers and phones, the long floor walks) and no
dense validation set (OxIOD, RIDI, Inria) has a mean ATE worse than ``mirror``'s by more than 5 %.

    nice -n 10 python -m experiments.probe_stride_length --out docs/results/probes/stride_length.md
"""

from __future__ import annotations

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
    new_walk_groups,
    rows_table,
    set_ates,
)
from experiments.probe_sparse_truth import (
    default_training_windows,
    fine_tune,
    fine_tune_arguments,
    fine_tuned_once,
)
from ftin.files import DEFAULT_DATA_ROOT
from ftin.protocol.stride_retrain import ILC_HELD_OUT

RUNS = Path("runs/probes/stride_length")
ARMS = {"mirror": {"mirror": None}, "mirror+stride_length": {"mirror": None, "stride_length": 0.3}}


def held_out_ratios(rows: dict) -> dict[str, float]:
    """Median path ratio of each held-out group the rule reads."""
    floors = {f"ILC {f}": floor_ratio(rows, f) for f in ILC_HELD_OUT}
    return floors | {
        name: float(np.median([w["ratio"] for w in part if w["ratio"] is not None]))
        for name, part in new_walk_groups(rows["new"]).items()
    }


def verdict(control: dict, arm: dict) -> tuple[bool, list[str]]:
    reasons, closer = [], 0
    before, after = held_out_ratios(control), held_out_ratios(arm)
    for group in before:
        better = abs(after[group] - 1) < abs(before[group] - 1)
        closer += better
        reasons.append(f"{group}: median path ratio {before[group]:.3f} -> {after[group]:.3f}")
    adopted = closer >= 3
    for group in DENSE_SETS:
        b, a = np.mean(set_ates(control, group)), np.mean(set_ates(arm, group))
        adopted &= a <= b * (1 + WORSE_AT_MOST)
        reasons.append(f"{group} validation: mean ATE {b:.3f} -> {a:.3f} m ({a / b - 1:+.1%})")
    return bool(adopted), [f"closer to 1 on {closer} of {len(before)} held-out groups", *reasons]


def main() -> None:
    parser = argument_parser(__doc__)
    fine_tune_arguments(parser, steps=400)
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    args.freeze_bn = True  # probe_sparse_truth.fine_tune reads it: batch norm as shipped
    started = time.monotonic()
    RUNS.mkdir(parents=True, exist_ok=True)
    rows, training = {"default (untouched)": cached_rows(DEFAULT, args.data_root)}, {}
    for arm, augment in ARMS.items():
        stem = RUNS / f"{arm}-{args.steps}-{args.lr:g}"

        def train(arm: str = arm, augment: dict = augment) -> tuple:
            return fine_tune(arm, default_training_windows(args.data_root, augment), None, args)

        training[arm] = fine_tuned_once(stem, train)
        rows[arm] = cached_rows(stem, args.data_root)
    adopted, reasons = verdict(rows["mirror"], rows["mirror+stride_length"])
    minutes = (time.monotonic() - started) / 60
    lines = [
        "# Stretching the stride in training (the `stride_length` augmentation): a fine-tune of minutes",
        "",
        "Made by `nice -n 10 python -m experiments.probe_stride_length "
        f"--steps {args.steps} --lr {args.lr:g} --dense {args.dense} --out {args.out}` "
        f"({minutes:.0f} min this run, two shared cores). Its "
        "docstring: method and the rule, written before any arm was read. Phone only; ATE in m (ILC: median "
        "at the waypoints); path ratio median (walks in 0.85-1.15).",
        "",
        "| arm | steps | minutes | dense loss first -> last fifth |",
        "|---|--:|--:|---|",
        *(
            f"| {arm} | {t['steps']} | {t['minutes']:.1f} | "
            f"{t['dense_loss_first_fifth']:.3f} -> {t['dense_loss_last_fifth']:.3f} |"
            for arm, t in training.items()
        ),
        "",
        *rows_table(rows),
        "",
        f"**By the rule: `stride_length` {'adopted' if adopted else 'not adopted'}** (against `mirror`).",
        "",
        *(f"- {r}" for r in reasons),
    ]
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
