"""Does an accelerometer that saturates at ±2 g change the speed a model reads? (a probe of minutes)

    .venv/bin/python -m experiments.probe_saturation \
        --checkpoint checkpoints/ftin-pedestrian --checkpoint checkpoints/ronin_resnet-oxiod \
        --out docs/results/probes/saturation.md

Why: the Nexus 5 and the iPhone 4S clip at ±2 g per axis (``../shared/data/README.md``; a Nexus 5
running in a pocket has 11 % of its samples at 19.6 m/s²), the iPhone 5 reads up to ~5 g. A model
that reads speed from the bounce reads a clipped bounce as a slower walk.

Walks: the Inria iPhone 5 walks of both walkers (never the test part, the iPhone 4S walks), with the
motion-capture orientation; the shipped checkpoints never trained on Inria. Each walk is read twice:
as recorded, and with every device-frame acceleration axis clipped to ±``--clip-g`` g, before the
rotation into the world frame (where a phone clips). Per carry mode: the share of samples clipped,
and the mean predicted speed over moving windows (true speed >= 0.3 m/s) as recorded and clipped,
each against the true speed of the same windows.
"""

from __future__ import annotations

import dataclasses
from collections import defaultdict
from pathlib import Path

import numpy as np

from experiments.common import add_checkpoint_options, argument_parser, parse, write_report
from ftin.analysis.speed_cues import probe_windows, window_predictor
from ftin.checkpoint import load_model
from ftin.data.loading import load_sequences
from ftin.data.prepare import prepare
from ftin.data.types import ImuSequence
from ftin.data.windows import velocity_targets
from ftin.protocol import DATA_FOLDERS, INRIA

G = 9.80665


def clipped(seq: ImuSequence, limit_m_s2: float) -> ImuSequence:
    """``seq`` as a phone whose accelerometer saturates at ±``limit_m_s2`` on every axis."""
    return dataclasses.replace(seq, acc_m_s2=np.clip(seq.acc_m_s2, -limit_m_s2, limit_m_s2))


def carry_mode(name: str) -> str:
    return name.split("_")[-1]


def main() -> None:
    parser = argument_parser(__doc__)
    add_checkpoint_options(parser, stride=20, checkpoint_help="checkpoint (repeatable)")
    parser.add_argument("--clip-g", type=float, default=2.0, help="saturation per axis, in g")
    args = parse(parser)
    limit = args.clip_g * G
    folders = sorted((args.data_root / DATA_FOLDERS[INRIA] / "ios").glob("*_iPhone5_*"))
    walks = load_sequences(folders, orientation="ground_truth")
    share: dict[str, list[float]] = defaultdict(list)
    for seq in walks:
        share[carry_mode(seq.name)].append(float(np.mean(np.any(np.abs(seq.acc_m_s2) >= limit, axis=1))))
    lines = [
        f"# Saturation probe: the accelerometer clipped at ±{args.clip_g:g} g",
        "",
        "Made by `python -m experiments.probe_saturation` (its docstring: walks, method). "
        f"{len(walks)} Inria iPhone 5 "
        "walks (both walkers, motion-capture orientation; the test part's iPhone 4S walks unread); "
        "moving windows only. Speed ratio: mean predicted / mean true speed of the same windows, as "
        f"recorded and with every device axis clipped to ±{args.clip_g:g} g; change: clipped against "
        "as recorded.",
        "",
        "| checkpoint | carry | walks | samples clipped | windows | ratio as recorded | ratio clipped "
        "| change |",
        "|---|---|--:|--:|--:|--:|--:|--:|",
    ]
    for path in args.checkpoint:
        loaded = load_model(path)
        predict = window_predictor(loaded)
        speeds: dict[str, list[np.ndarray]] = defaultdict(list)
        for seq in walks:
            mode = carry_mode(seq.name)
            plain = prepare(seq, loaded.imu_rate_hz)
            starts, x, _ = probe_windows(plain, loaded.window, args.stride, reach=1.0)
            if not len(starts):
                continue
            cut = prepare(clipped(seq, limit), loaded.imu_rate_hz)
            _, x_cut, _ = probe_windows(cut, loaded.window, args.stride, reach=1.0)
            v = velocity_targets(plain.seq.t_s, plain.seq.gt.p_world_m, starts, loaded.window, 2)
            speeds[mode].append(
                np.column_stack(
                    [
                        np.linalg.norm(v, axis=1),
                        np.linalg.norm(predict(x)[:, :2], axis=1),
                        np.linalg.norm(predict(x_cut)[:, :2], axis=1),
                    ]
                )
            )
        for mode in sorted(speeds):
            true, plain_speed, cut_speed = np.concatenate(speeds[mode]).mean(axis=0)
            row = (
                f"| {Path(path).name.removesuffix('.safetensors')} | {mode} | {len(speeds[mode])} | "
                f"{100 * np.mean(share[mode]):.1f} % | {sum(len(s) for s in speeds[mode])} | "
                f"{plain_speed / true:.2f} | {cut_speed / true:.2f} | "
                f"{100 * (cut_speed / plain_speed - 1):+.1f} % |"
            )
            lines.append(row)
            print(row, flush=True)
    write_report(args.out, lines, echo=False)  # the rows were printed as they came


if __name__ == "__main__":
    main()
