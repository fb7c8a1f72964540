"""Where do the short carry modes (AR, phoning) lose their distance? (a probe of minutes)

    .venv/bin/python -m experiments.probe_slow_carry \
        --checkpoint 0=runs/generalisation/walking-f0/ftin-ordered-pace-s0/ftin-walking \
        --checkpoint 1=runs/generalisation/walking-f1/ftin-ordered-pace-s0/ftin-walking \
        --out docs/results/probes/slow_carry.md

Why: on walker-held-out validation every stage-one arm covers 0.22-0.43 of the walked distance on
Inria's AR walks and 0.66-0.77 on the phoning ones (docs/results/generalisation/crossval.md, path
ratio per carry mode), where the pockets reach 0.9. A model that reads speed from the bounce may
underread slow, smooth walking; or the walked distance of those walks may be mostly the phone moved
by the hand while the walker barely steps, which no step-reading model can see.

Walks: each fold checkpoint on its own validation walker's Inria walks (Nexus 5 and iPhone 5; the
iPhone 4S test walks unread), motion-capture orientation (speed alone, no heading error). Windows of
the checkpoint's length every ``--stride`` samples, split by the true speed of the window (mean
velocity over the window): standing (< 0.1 m/s), slow (0.1-0.5) and walking (>= 0.5). Per carry
mode and band: the share of the walked distance made in that band (window speed x duration) and
predicted over true distance in it. The bounce (vertical world-frame acceleration RMS) is the cue
the speed-cue probe found the models read.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from experiments.common import add_checkpoint_options, argument_parser, parse, write_report
from ftin.analysis.speed_cues import time_warp, window_predictor
from ftin.checkpoint import load_model
from ftin.data.loading import load_sequences
from ftin.data.prepare import prepare
from ftin.data.windows import velocity_targets, window_starts
from ftin.protocol import DATA_FOLDERS, INRIA, fold_parts
from ftin.report.crossval import carry_of

BANDS = (("standing", 0.0, 0.1), ("slow", 0.1, 0.5), ("walking", 0.5, np.inf))


def main() -> None:
    parser = argument_parser(__doc__)
    add_checkpoint_options(parser, stride=10, checkpoint_help="FOLD=checkpoint (repeatable)")
    args = parse(parser)
    lines = [
        "# Slow carry probe: where AR and phoning lose their distance",
        "",
        "Made by `python -m experiments.probe_slow_carry` (its docstring: walks, bands, method). Each fold "
        "checkpoint on its validation walker's Inria walks (Nexus 5, iPhone 5), motion-capture "
        "orientation. Share: of the walked distance, the part made in windows of that true speed; "
        "ratio: predicted over true distance in those windows; bounce: vertical acceleration RMS "
        "(m/s²) over the whole walks.",
        "",
        "| checkpoint | carry | walks | bounce | standing share / ratio | slow share / ratio "
        "| walking share / ratio | all: ratio |",
        "|---|---|--:|--:|--:|--:|--:|--:|",
    ]
    for spec in args.checkpoint:
        fold, path = spec.split("=", 1)
        loaded = load_model(path)
        predict = window_predictor(loaded)
        parts = fold_parts(INRIA, int(fold))
        folders = [args.data_root / DATA_FOLDERS[INRIA] / r for r in parts["val"]]
        rows: dict[str, list[np.ndarray]] = defaultdict(list)
        bounce: dict[str, list[float]] = defaultdict(list)
        for seq in load_sequences(folders, orientation="ground_truth"):
            prepared = prepare(seq, loaded.imu_rate_hz)
            s = prepared.seq
            starts = window_starts(len(s), loaded.window, args.stride)
            tracked = s.gt.tracked_mask
            starts = starts[tracked[starts] & tracked[starts + loaded.window]]
            true = np.linalg.norm(velocity_targets(s.t_s, s.gt.p_world_m, starts, loaded.window, 2), axis=1)
            pred = np.linalg.norm(
                predict(time_warp(prepared.imu_world, starts, loaded.window, 1.0))[:, :2], axis=1
            )
            mode = carry_of(INRIA, seq.name)
            rows[mode].append(np.column_stack([true, pred]))
            bounce[mode].append(float(np.std(prepared.imu_world[:, 5])))  # channels: gyro, acc xyz
        name = Path(path).parent.parent.name + "/" + Path(path).parent.name
        for mode in sorted(rows):
            true, pred = np.concatenate(rows[mode]).T
            cells = []
            for _, low, high in BANDS:
                band = (true >= low) & (true < high)
                share = true[band].sum() / true.sum()
                ratio = pred[band].sum() / true[band].sum() if true[band].sum() > 0 else np.nan
                cells.append(f"{100 * share:.0f} % / {ratio:.2f}")
            row = (
                f"| {name} | {mode} | {len(rows[mode])} | {np.mean(bounce[mode]):.2f} | "
                + " | ".join(cells)
                + f" | {pred.sum() / true.sum():.2f} |"
            )
            lines.append(row)
            print(row, flush=True)
    write_report(args.out, lines, echo=False)  # the rows were printed as they came


if __name__ == "__main__":
    main()
