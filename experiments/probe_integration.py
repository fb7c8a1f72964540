"""Probe: how inference turns window velocities into a path, on hidden walks (phone only).

    .venv/bin/python -m experiments.probe_integration [--checkpoint checkpoints/ftin-pedestrian] \
        [--data ../shared/data] [--out docs/results/probes/integration.md]

Each window velocity is the mean velocity over its window. Inference today gives each sample interval
the mean of the windows that cover it (``ftin.infer.integrate_spans``), so with 1 s windows every 0.2 s
the path is the truth averaged twice over 1 s: on tight turns it cuts the corners twice. RoNIN's
reference integrates each window's velocity over one stride instead (the truth averaged once). This
probe runs a checkpoint once per recording, phone only (as the hidden-walks check loads them), on
recordings that decide nothing else and that ``ftin-pedestrian`` never trained on: the validation parts
of OxIOD and RIDI and every Inria walk outside its test part (Nexus 5 and iPhone 5, both walkers; the
test parts stay unread), and integrates the same velocities both ways: each window's velocity over its
whole window (today) or over the stride at its centre. It reports ATE and the distance ratio (the path
as predicted over the walked distance, the truth smoothed over 1 s) per dataset and carry mode. A
correct window model is the reference: the true window velocities integrated both ways.
"""

from __future__ import annotations

import dataclasses
from collections import defaultdict
from pathlib import Path

import numpy as np
from tqdm import tqdm

from experiments.common import argument_parser, hidden_walk_paths, parse, write_report
from ftin import protocol
from ftin.checkpoint import load_model
from ftin.data.loading import load_phone_only
from ftin.data.types import Trajectory
from ftin.evaluate import score
from ftin.files import DEFAULT_DATA_ROOT
from ftin.infer import integrate_spans, predict_trajectory

DATASETS = (protocol.OXIOD, protocol.RIDI, protocol.INRIA)
WAYS = ("whole window", "centre stride")


def spans(starts: np.ndarray, window: int, stride: int, way: str) -> tuple[np.ndarray, np.ndarray]:
    """Each window's span under ``way``: the window itself, or the stride at its centre."""
    if way == "whole window":
        return starts, starts + window
    first = starts + (window - stride) // 2
    return first, first + stride


def integrate(t_s, starts, window, stride, velocity, start_m, way: str) -> np.ndarray:
    a, b = spans(starts, window, stride, way)
    if way == "centre stride":  # the head before the first centre keeps the first window's velocity
        a, b = np.r_[0, a], np.r_[a[0], b]
        velocity = np.vstack([velocity[:1], velocity])
        if a[1] == 0:
            a, b, velocity = a[1:], b[1:], velocity[1:]
    return integrate_spans(t_s, a, b, velocity, start_m)


def figures(prediction, p_world_m: np.ndarray) -> tuple[float, float | None]:
    trajectory = Trajectory(prediction.trajectory.t_s, p_world_m, prediction.trajectory.q_world_body_wxyz)
    scored = score(dataclasses.replace(prediction, trajectory=trajectory))
    return scored.metrics.values["ate"], scored.metrics.values.get("distance_ratio")


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", type=Path, default=Path("checkpoints/ftin-pedestrian"))
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=Path("docs/results/probes/integration.md"))
    args = parse(parser)
    loaded = load_model(args.checkpoint)
    window, stride = loaded.window, loaded.stride
    rows: dict[tuple[str, str], list[dict[str, float]]] = defaultdict(list)
    for dataset in DATASETS:
        paths = hidden_walk_paths(args.data, dataset)
        for seq in tqdm(load_phone_only(paths, f"{dataset} probe walks"), desc=dataset, unit="walk"):
            prediction = predict_trajectory(loaded, seq, keep_prepared=False, yaw_copies=1)
            t_s, starts = prediction.trajectory.t_s, prediction.starts
            assert len(starts) == len(prediction.velocity_m_s), "a window model with one part per window"
            gt = prediction.truth
            span_s = t_s[starts + window] - t_s[starts]
            true_v = (gt.p_world_m[starts + window] - gt.p_world_m[starts]) / span_s[:, None]
            start_m = prediction.trajectory.p_world_m[0]
            d = prediction.velocity_m_s.shape[1]
            row: dict[str, float] = {}
            for way in WAYS:
                est = integrate(t_s, starts, window, stride, prediction.velocity_m_s, start_m, way)
                row[f"ate {way}"], row[f"ratio {way}"] = figures(prediction, est)
                perfect = integrate(t_s, starts, window, stride, true_v[:, :d], gt.p_world_m[0], way)
                row[f"perfect ate {way}"], row[f"perfect ratio {way}"] = figures(prediction, perfect)
            carry = str(seq.meta.get("motion", seq.meta.get("carry", "unknown")))
            rows[protocol.DATASET_LABELS[dataset], carry].append(row)
    lines = [
        "# Integrating window velocities: over the whole window or over the stride at its centre",
        "",
        f"Made by `python -m experiments.probe_integration --checkpoint {args.checkpoint}` "
        "(its docstring: method). "
        "The validation parts of OxIOD and RIDI and Inria's Nexus 5 and iPhone 5 walks (no test part), "
        "phone only (`auto` orientation), RoNIN convention. Distance ratio: the path "
        "as predicted over the walked distance (the true path smoothed over 1 s). 'Correct model': the true "
        "window velocities integrated the same way.",
        "",
        "| dataset | carry | walks | ATE whole / centre (m) | distance ratio whole / centre "
        "| correct model: ATE whole / centre | correct model: ratio whole / centre |",
        "|---|---|--:|--:|--:|--:|--:|",
    ]

    def mean(group: list[dict[str, float]], key: str) -> float:
        return float(np.mean([r[key] for r in group if r[key] is not None]))

    def cells(group: list[dict[str, float]]) -> str:
        pairs = [("ate", 2), ("ratio", 2), ("perfect ate", 2), ("perfect ratio", 3)]
        return " | ".join(
            " / ".join(f"{mean(group, f'{key} {way}'):.{digits}f}" for way in WAYS) for key, digits in pairs
        )

    for (dataset, carry), group in sorted(rows.items()):
        lines.append(f"| {dataset} | {carry} | {len(group)} | {cells(group)} |")
    everything = [r for group in rows.values() for r in group]
    lines.append(f"| all | | {len(everything)} | {cells(everything)} |")
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
