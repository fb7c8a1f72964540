"""Probe: what a phone alone costs a network's walk, heading or tilt, on walker-held-out validation.

    .venv/bin/python -m experiments.probe_phone_cost [--runs runs/generalisation] \
        [--arm ronin_resnet-mirror] [--seed 0] [--out docs/results/probes/phone_cost.md]

Table 1's phone-only rows sit above its ground-truth rows (the default's test ATE: OxIOD 2.4x, RIDI
1.2x, Inria 1.05x). The orientation ``auto`` gives a phone export (VQF 9-D or 6-D, the rule of
``ftin.data.orientation_choice``) differs from motion capture in heading (drift, a magnetometer pulled
by steel) and in tilt (which leaks gravity into the horizontal acceleration the network reads). Which of
the two costs the walk decides where orientation work would pay. Each stage-one fold checkpoint of
``--arm`` (both folds) on the walkers it never trained on, each recording read four ways: the motion-
capture orientation; ``auto``'s estimate (turned into the truth's world over the first 2 s, as the
campaign scores it); the truth's heading with the estimate's tilt; the estimate's heading with the
truth's tilt (yaw / pitch / roll split in the world's z-y-x order). ATE (RoNIN convention, start-
aligned, the app's four-copy average) and the path's heading error. The test parts are never read.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation
from tqdm import tqdm

from experiments.common import argument_parser, arm_of, job_checkpoints, parse, write_report
from ftin import protocol
from ftin.campaign.folder import Campaign
from ftin.checkpoint import load_model
from ftin.data import frames
from ftin.data.discovery import read_sequence
from ftin.data.orientation_choice import choose_orientation
from ftin.data.orientation_option import phone_only
from ftin.data.preprocess import estimate_orientation
from ftin.data.types import ImuSequence
from ftin.evaluate import score
from ftin.infer import predict_trajectory
from ftin.report.crossval import carry_of

ALIGN_S = 2.0  # as the campaign turns an estimate's world into the truth's
WAYS = ("motion capture", "auto", "truth heading + auto tilt", "auto heading + truth tilt")


def auto_in_truth_world(seq: ImuSequence) -> tuple[np.ndarray, str]:
    """``auto``'s orientation of a phone export of ``seq``, turned into the truth's world at the start."""
    bare = phone_only(seq)
    source, _ = choose_orientation(bare)
    source = getattr(source, "value", source)
    estimate = estimate_orientation(bare, use_magnetometer=source == "vqf").q_world_device_wxyz
    truth = seq.gt.q_world_body_wxyz
    yaw, _ = frames.yaw_offset_rad(seq.t_s, estimate, truth, ALIGN_S)  # truth's world -> estimate's
    turned = frames.yaw_rotation(-yaw) * frames.rotation_from_wxyz(estimate)
    return frames.wxyz_from_rotation(turned), source


def mixed(heading_from: np.ndarray, tilt_from: np.ndarray) -> np.ndarray:
    """The yaw of ``heading_from`` with the pitch and roll of ``tilt_from`` (z-y-x Euler angles)."""
    yaw = Rotation.from_quat(heading_from, scalar_first=True).as_euler("ZYX")[:, 0]
    tilt = Rotation.from_quat(tilt_from, scalar_first=True).as_euler("ZYX")[:, 1:]
    return Rotation.from_euler("ZYX", np.column_stack([yaw, tilt])).as_quat(scalar_first=True)


def group(dataset: str, name: str) -> str:
    """Inria: ``Inria <carry mode>`` (``crossval.carry_of``); OxIOD and RIDI: the dataset."""
    return f"Inria {carry_of(dataset, name)}" if dataset == protocol.INRIA else dataset


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--runs", type=Path, default=Path("runs/generalisation"))
    parser.add_argument("--arm", default="ronin_resnet-mirror")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("docs/results/probes/phone_cost.md"))
    args = parse(parser)
    campaign = Campaign(args.runs)
    rows: dict[str, dict[str, list[tuple[float, float]]]] = defaultdict(lambda: defaultdict(list))
    sources: dict[str, list[str]] = defaultdict(list)
    for job, checkpoint in job_checkpoints(campaign, lambda j: arm_of(j) == args.arm and j.seed == args.seed):
        model = load_model(checkpoint)
        recordings = [
            (dataset, path)
            for dataset, part, _ in job.evaluation_sets()
            if part == "val"
            for path in job.paths(campaign.data_root, part, dataset)
        ]
        for dataset, path in tqdm(recordings, desc=job.name, unit="walk"):
            seq = read_sequence(path)
            truth = seq.gt.q_world_body_wxyz
            auto, source = auto_in_truth_world(seq)
            orientations = dict(zip(WAYS, (truth, auto, mixed(truth, auto), mixed(auto, truth)), strict=True))
            key = group(dataset, seq.name)
            sources[key].append(source)
            for way, q in orientations.items():
                scored = score(predict_trajectory(model, seq.with_(q_world_device_wxyz=q)), "start")
                rows[key][way].append((scored.metrics.ate, scored.metrics.values.get("heading_error_deg")))
    render(args, rows, sources)


def render(args: argparse.Namespace, rows: dict, sources: dict[str, list[str]]) -> None:
    lines = [
        "# What a phone alone costs: heading or tilt (a probe)",
        "",
        f"Made by `python -m experiments.probe_phone_cost --arm {args.arm} --seed {args.seed}`",
        "(its docstring: method).",
        "Stage one's fold checkpoints on the walkers they never trained on. Cells: ATE (m, RoNIN",
        "convention, start-aligned, four-copy average) / the path's heading error (deg), mean over",
        "recordings; `auto` = what the rule chose for a phone export (counts in the last column).",
        "",
        "| recordings | n | " + " | ".join(WAYS) + " | auto chose |",
        "|---|--:|" + "--:|" * len(WAYS) + "---|",
    ]
    for key in sorted(rows):
        cells = []
        for way in WAYS:
            values = np.array(rows[key][way], dtype=float)
            cells.append(f"{values[:, 0].mean():.2f} / {np.nanmean(values[:, 1]):.1f}")
        chose = ", ".join(f"{s} {sources[key].count(s)}" for s in sorted(set(sources[key])))
        lines.append(f"| {key} | {len(rows[key][WAYS[0]])} | " + " | ".join(cells) + f" | {chose} |")
    for dataset in (protocol.OXIOD, protocol.RIDI, "Inria"):
        keys = [k for k in rows if k.startswith(dataset)]
        means = [np.mean([v[0] for k in keys for v in rows[k][way]]) for way in WAYS]
        ratios = " / ".join(f"{m / means[0]:.2f}x" for m in means[1:])
        lines.append(
            f"| **{dataset}, all** | | " + " | ".join(f"**{m:.2f}**" for m in means) + f" | {ratios} |"
        )
    lines.append("")
    lines.append(
        "The last column of the bold rows: each way's ATE over motion capture's (auto, truth heading +"
    )
    lines.append("auto tilt, auto heading + truth tilt).")
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
