"""Probe: does averaging a model over turned copies of its input make a better walker (phone only)?

    .venv/bin/python -m experiments.probe_yaw_ensemble [--checkpoint checkpoints/ftin-pedestrian] \
        [--data ../shared/data] [--out docs/results/probes/yaw_ensemble.md]

A walk's velocity turns with its world: turning the gravity-aligned input by a yaw turns the true
velocity by the same yaw. Our networks learn that only approximately (random yaw in training), and
docs/orientation.md found one recording's ATE moving by up to 4x when its world is turned. So at test
time: run the model on K copies of the world-frame input turned by 360/K degree steps, turn each
velocity back and average them. Both the vector mean and, beside it, the vector mean's direction with
the mean speed (a mean of vectors that disagree in direction is shorter than each of them).

Recordings: as ``experiments/probe_integration.py``, those that decide nothing else and that
``ftin-pedestrian`` never trained on (OxIOD and RIDI validation parts, Inria's Nexus 5 and iPhone 5
walks; the test parts stay unread), phone only; with ``--fold K`` (a checkpoint of the generalisation
campaign's fold K) that fold's held-out walkers. Per dataset: mean ATE, ATE over standing still and
the distance ratio for one copy at each of the K turns (the spread a single world gives), and for the
averages over K = 4 and 8, and over the 4 with their mirror images (the walk reflected through a
vertical plane, as the ``mirror`` augmentation reflects it; the velocity reflected back).
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
from ftin.infer import integrate_spans, predict_trajectory, run_windows

DATASETS = (protocol.OXIOD, protocol.RIDI, protocol.INRIA)


def turn_xy(values: np.ndarray, yaw: float) -> np.ndarray:
    """``values`` with the x and y of every 3-vector (columns 0-1, 3-4, ...) turned by ``yaw``."""
    out = np.array(values, dtype=np.float64, copy=True)
    c, s = np.cos(yaw), np.sin(yaw)
    for first in range(0, out.shape[1] - 1, 3):
        x, y = out[:, first].copy(), out[:, first + 1].copy()
        out[:, first], out[:, first + 1] = c * x - s * y, s * x + c * y
    return out


def mirror(imu: np.ndarray) -> np.ndarray:
    """The walk's mirror image through the vertical x-z plane (as the ``mirror`` augmentation): the
    gyroscope, an axial vector, changes the sign of x and z, the acceleration that of y."""
    return imu * np.array([-1.0, 1.0, -1.0, 1.0, -1.0, 1.0])


def velocities(loaded, imu: np.ndarray, starts: np.ndarray, yaw: float, mirrored: bool = False) -> np.ndarray:
    """The model's window velocities for the input (mirrored, then) turned by ``yaw``, turned back."""
    turned = turn_xy(mirror(imu) if mirrored else imu, yaw).astype(np.float32)
    parts, _ = run_windows(loaded, turned, starts, loaded.window, 1, 1024, None, False, yaw_copies=1)
    v = parts[:, 0, :]
    back = np.zeros((len(v), 3))
    back[:, : v.shape[1]] = v
    back = turn_xy(back, -yaw)[:, : v.shape[1]]
    if mirrored:
        back[:, 1] *= -1.0
    return back


def averaged(vs: list[np.ndarray], keep_speed: bool) -> np.ndarray:
    mean = np.mean(vs, axis=0)
    if not keep_speed:
        return mean
    speed = np.mean([np.linalg.norm(v[:, :2], axis=1) for v in vs], axis=0)
    norm = np.linalg.norm(mean[:, :2], axis=1)
    out = mean.copy()
    out[:, :2] *= (speed / np.maximum(norm, 1e-9))[:, None]
    return out


def figures(prediction, velocity: np.ndarray, window: int) -> dict[str, float]:
    t_s, starts = prediction.trajectory.t_s, prediction.starts
    start_m = prediction.trajectory.p_world_m[0]
    p = integrate_spans(t_s, starts, starts + window, velocity, start_m)
    trajectory = Trajectory(t_s, p, prediction.trajectory.q_world_body_wxyz)
    scored = score(dataclasses.replace(prediction, trajectory=trajectory))
    return {
        "ate": scored.metrics.values["ate"],
        "still": scored.stand_still.values["ate"],
        "ratio": scored.metrics.values.get("distance_ratio"),
    }


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", type=Path, default=Path("checkpoints/ftin-pedestrian"))
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=Path("docs/results/probes/yaw_ensemble.md"))
    parser.add_argument(
        "--fold", type=int, default=None, help="a walker-fold model: its fold's held-out walkers instead"
    )
    args = parse(parser)
    loaded = load_model(args.checkpoint)
    turns = np.radians(np.arange(0, 360, 45))  # K = 8; K = 4 is every second one
    arms = [f"one copy at {d:.0f}°" for d in np.degrees(turns)] + [
        "mean of 4",
        "mean of 4, mean speed",
        "mean of 8",
        "mean of 8, mean speed",
        "mean of 4 and their mirror images",
    ]
    rows: dict[str, dict[str, list[dict[str, float]]]] = defaultdict(lambda: defaultdict(list))
    for dataset in DATASETS:
        paths = hidden_walk_paths(args.data, dataset, args.fold)
        for seq in tqdm(load_phone_only(paths, f"{dataset} probe walks"), desc=dataset, unit="walk"):
            prediction = predict_trajectory(loaded, seq, keep_prepared=False, yaw_copies=1)
            vs = [velocities(loaded, prediction.imu_world, prediction.starts, yaw) for yaw in turns]
            assert np.allclose(vs[0], prediction.velocity_m_s, atol=1e-5), "copy at 0° = inference"
            mirrored = [
                velocities(loaded, prediction.imu_world, prediction.starts, yaw, True) for yaw in turns[::2]
            ]
            label = protocol.DATASET_LABELS[dataset]
            for degrees, v in zip(np.degrees(turns), vs, strict=True):
                rows[label][f"one copy at {degrees:.0f}°"].append(figures(prediction, v, loaded.window))
            for k, chosen in ((4, vs[::2]), (8, vs)):
                for keep_speed, suffix in ((False, ""), (True, ", mean speed")):
                    v = averaged(chosen, keep_speed)
                    rows[label][f"mean of {k}{suffix}"].append(figures(prediction, v, loaded.window))
            both = averaged(vs[::2] + mirrored, False)
            rows[label]["mean of 4 and their mirror images"].append(figures(prediction, both, loaded.window))
    labels = list(rows)
    walks = (
        "OxIOD and RIDI validation parts, Inria's Nexus 5 and iPhone 5 walks (no test part)"
        if args.fold is None
        else f"walker fold {args.fold}'s held-out walkers (the model never trained on them)"
    )
    lines = [
        "# Averaging a model over turned copies of its input (test-time yaw ensemble)",
        "",
        f"Made by `python -m experiments.probe_yaw_ensemble --checkpoint {args.checkpoint}"
        f"{'' if args.fold is None else f' --fold {args.fold}'}` (its docstring: method). "
        f"Phone only (`auto`), RoNIN convention; {walks}. Cells: mean ATE (m) / mean ATE over "
        "standing still's / mean distance ratio.",
        "",
        "| arm | " + " | ".join(f"{label} ({len(rows[label][arms[0]])} walks)" for label in labels) + " |",
        "|---|" + "--:|" * len(labels),
    ]
    for arm in arms:
        cells = []
        for label in labels:
            group = rows[label][arm]
            ate = np.mean([r["ate"] for r in group])
            still = np.mean([r["ate"] / r["still"] for r in group])
            ratio = np.mean([r["ratio"] for r in group if r["ratio"] is not None])
            cells.append(f"{ate:.2f} / {still:.2f} / {ratio:.2f}")
        lines.append(f"| {arm} | " + " | ".join(cells) + " |")
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
