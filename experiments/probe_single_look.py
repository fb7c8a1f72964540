"""Probe: can one look per window give what four turned copies give today (and at which stride)?

    .venv/bin/python -m experiments.probe_single_look [--checkpoint checkpoints/ronin_resnet-walking ...] \
        [--data ../shared/data] [--out docs/results/probes/single_look.md]

Every inference path averages the network over four copies of each window turned by quarter turns
about the vertical (``ftin.yaw_average``): the networks are not yaw-equivariant, and the average keeps
the part of the output that turns with the input. It costs four looks per window. Three ways to get
the same equivariance from one look, each measured against the four-copy average:

- **one copy**: the window as it is (what the average replaced; the baseline of "no fix").
- **cyclic turns**: window i turned by (i mod 4) quarter turns, its velocity turned back. The
  windows overlap (window 100, stride 20 at 100 Hz: five cover each sample), and the trajectory
  integrates the mean of the windows covering each interval, so the part fixed to the input's axes
  points in four directions over any four neighbouring windows and cancels in the path as it does in
  the four-copy mean, from one look per window.
- **canonical yaw**: each window turned into a frame fixed by its own horizontal motion (the major
  axis of its horizontal acceleration, the sign by that axis' third moment), the velocity turned back
  (RIO / EqNIO-style canonicalisation, without training): exactly equivariant per window.

and the stride (samples between windows) for the best of them, since fewer windows is fewer looks.

Walks: none of them decides anything else or was trained on by the shipped walking checkpoints:
OxIOD, RIDI and Inria validation parts, and the 30 OxIOD walks no checkpoint has seen (new walkers, an
iPhone 6, a Nexus 5, running, a pocket walk, the floor-1 Tango walks). Phone only (``auto``). Per set:
mean ATE, mean ATE over standing still's and the share of walks whose distance ratio is in 0.8-1.2.
Velocities are computed once per window at a base stride of 5 samples and subsampled for each stride.
"""

from __future__ import annotations

import dataclasses
import math
from collections import defaultdict
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from experiments.common import argument_parser, parse, write_report
from experiments.probe_new_oxiod_walks import NEW_WALKS
from ftin import protocol
from ftin.checkpoint import LoadedModel, load_model
from ftin.data.loading import load_phone_only
from ftin.data.types import Trajectory
from ftin.data.windows import window_starts, window_view
from ftin.evaluate import score
from ftin.files import DEFAULT_DATA_ROOT
from ftin.infer import integrate_spans, predict_trajectory, select_parts
from ftin.yaw_average import turn_velocities, turn_windows

BASE_STRIDE = 5


def canonical_yaw(x: torch.Tensor) -> torch.Tensor:
    """``(B,)`` the yaw of each window's own horizontal motion: the major axis of its horizontal
    acceleration (channels 3-4), the sign that makes the acceleration's third moment along it positive.
    Turning a window turns this angle with it (exact equivariance)."""
    a = x[:, 3:5, :].double()
    a = a - a.mean(dim=2, keepdim=True)
    sxx, syy, sxy = (a[:, 0] ** 2).mean(1), (a[:, 1] ** 2).mean(1), (a[:, 0] * a[:, 1]).mean(1)
    theta = 0.5 * torch.atan2(2.0 * sxy, sxx - syy)
    along = torch.cos(theta)[:, None] * a[:, 0] + torch.sin(theta)[:, None] * a[:, 1]
    return torch.where((along**3).mean(1) < 0, theta + math.pi, theta)


STRIDES = (20, 25, 40, 50)


def looks(loaded: LoadedModel, imu: np.ndarray, starts: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """``(M, D)`` velocities of the windows at ``starts``, each turned by its angle, turned back."""
    view = window_view(imu, loaded.window)
    out = []
    with torch.inference_mode():
        for first in range(0, len(starts), 1024):
            rows = slice(first, first + 1024)
            x = torch.from_numpy(np.ascontiguousarray(view[starts[rows]]))
            turned = turn_windows(x, torch.from_numpy(angles[rows]))
            v = loaded.model(loaded.normalization.apply(turned)).velocity.double().numpy()
            out.append(turn_velocities(v, -angles[rows]))
    return np.concatenate(out)


def figures(prediction, starts: np.ndarray, stride: int, velocity: np.ndarray, window: int) -> dict:
    t_s = prediction.trajectory.t_s
    span_start, span_end, v = select_parts(starts, window, stride, velocity[:, None, :])
    p = integrate_spans(t_s, span_start, span_end, v, prediction.trajectory.p_world_m[0])
    trajectory = Trajectory(t_s, p, prediction.trajectory.q_world_body_wxyz)
    scored = score(dataclasses.replace(prediction, trajectory=trajectory))
    ratio = scored.metrics.values.get("distance_ratio")
    return {
        "ate": scored.metrics.values["ate"],
        "still": scored.stand_still.values["ate"],
        "inside": ratio is not None and 0.8 <= ratio <= 1.2,
    }


def arms_of(loaded: LoadedModel, prediction) -> dict[str, dict]:
    imu, window = prediction.imu_world, loaded.window
    base = window_starts(len(imu), window, BASE_STRIDE)
    quarter = np.arange(4) * (math.pi / 2)
    copies = [looks(loaded, imu, base, np.full(len(base), a)) for a in quarter]  # (4) x (M, D)
    x = torch.from_numpy(np.ascontiguousarray(window_view(imu, window)[base]))
    canonical = looks(loaded, imu, base, -canonical_yaw(x).numpy())
    arms: dict[str, dict] = {}
    for stride in STRIDES:
        pick = np.arange(0, len(base), stride // BASE_STRIDE)
        starts = base[pick]
        mean4 = np.mean([c[pick] for c in copies], axis=0)
        cyclic = np.stack([copies[i % 4][j] for i, j in enumerate(pick)])
        for name, v in (
            ("four copies", mean4),
            ("one copy", copies[0][pick]),
            ("cyclic turns", cyclic),
            ("canonical yaw", canonical[pick]),
        ):
            arms[f"{name}, stride {stride}"] = figures(prediction, starts, stride, v, window)
    return arms


def walk_sets(data_root: Path) -> dict[str, list[Path]]:
    sets = {
        protocol.DATASET_LABELS[d]: protocol.split_paths(data_root, d, "val")
        for d in (protocol.OXIOD, protocol.RIDI, protocol.INRIA)
    }
    oxiod = data_root / protocol.DATA_FOLDERS[protocol.OXIOD]
    sets["OxIOD new walks"] = [oxiod / rel for rel in NEW_WALKS]
    return sets


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", type=Path, action="append", default=None)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=Path("docs/results/probes/single_look.md"))
    args = parse(parser)
    checkpoints = args.checkpoint or [
        Path("checkpoints/ronin_resnet-walking"),
        Path("checkpoints/ftin-walking"),
    ]
    models = [load_model(c) for c in checkpoints]
    for m in models:
        m.model.eval()
    rows: dict[str, dict[str, dict[str, list[dict]]]] = {
        m.name: defaultdict(lambda: defaultdict(list)) for m in models
    }
    sets = walk_sets(args.data)
    for label, paths in sets.items():
        for seq in tqdm(load_phone_only(paths, label), desc=label, total=len(paths), unit="walk"):
            for loaded in models:
                prediction = predict_trajectory(loaded, seq, keep_prepared=False, yaw_copies=1)
                for arm, row in arms_of(loaded, prediction).items():
                    rows[loaded.name][label][arm].append(row)
    lines = [
        "# One look per window instead of four turned copies",
        "",
        "Made by `python -m experiments.probe_single_look` (its docstring: arms, walks). Phone only "
        "(`auto`), RoNIN convention. Cells: mean ATE (m) / mean ATE over standing still's / walks with "
        "distance ratio in 0.8-1.2. Looks per window: four copies 4, every other arm 1.",
        "",
    ]
    for name, by_set in rows.items():
        labels = list(by_set)
        arms = list(by_set[labels[0]])
        lines += [
            f"## {name}",
            "",
            "| arm | "
            + " | ".join(f"{lab} ({len(by_set[lab][arms[0]])} walks)" for lab in labels)
            + " | all: ATE / still |",
            "|---|" + "--:|" * (len(labels) + 1),
        ]
        for arm in arms:
            cells, ratios = [], []
            for lab in labels:
                part = by_set[lab][arm]
                ate, still = np.mean([r["ate"] for r in part]), np.mean([r["still"] for r in part])
                ratios += [r["ate"] / r["still"] for r in part]
                cells.append(
                    f"{ate:.2f} / {ate / still:.2f} / {sum(r['inside'] for r in part)} of {len(part)}"
                )
            lines.append(f"| {arm} | " + " | ".join(cells) + f" | {np.mean(ratios):.3f} |")
        lines.append("")
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
