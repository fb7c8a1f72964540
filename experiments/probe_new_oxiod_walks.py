"""How the shipped checkpoints read the 30 OxIOD walks added to the shared data (walkers 3 and 4, an
iPhone 6, a Nexus 5, running, a pocket walk, ten long walks over an office floor), phone only.

Question: before stage three trains on them, where do today's walking checkpoints stand on walkers,
phones and carries no campaign has seen, and is the damped-bounce under-read (handbags, steady hands)
visible here? No checkpoint shipped today trained on any of these walks, so this is a clean baseline;
it chooses nothing (the walks become training and validation walkers of stage three).

Each walk is read as a phone alone gives it (``load_phone_only``: no motion-capture or Tango
orientation, ``auto`` from gyroscope, accelerometer and magnetometer) and scored as the acceptance
check scores (``ftin.report.hidden_walks``: RoNIN convention, no alignment; distance ratio = the path
as predicted over the walked distance). For the long floor walks also the end-point error per 100 m
walked (drift over minutes).

    python -m experiments.probe_new_oxiod_walks --checkpoint checkpoints/ronin_resnet-walking \
        --checkpoint checkpoints/ftin-walking --out docs/results/probes/new_oxiod_walks.md
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from experiments.common import argument_parser, parse, write_report
from ftin import protocol
from ftin.checkpoint import LoadedModel, load_model
from ftin.data import ImuSequence
from ftin.data.loading import load_phone_only
from ftin.evaluate import score
from ftin.files import DEFAULT_DATA_ROOT
from ftin.infer import predict_trajectory

# The folders the shared data gained ("More OxIOD walks" in its README), relative to oxiod/.
NEW_WALKS = (
    *(f"multi users/user3/syn/imu{i}.csv.xz" for i in (4, 5, 7)),
    *(f"multi users/user4/syn/imu{i}.csv.xz" for i in (4, 6, 7)),
    *(f"multi devices/iPhone 6/syn/imu{i}.csv.xz" for i in range(1, 10)),
    *(f"multi devices/nexus 5/syn/imu{i}.csv.xz" for i in (7, 8)),
    *(f"running/data1/syn/imu{i}.csv.xz" for i in (6, 7)),
    "pocket/data1/syn/imu5.csv.xz",
    *(f"large scale/floor1/syn/imu{i}.csv.xz" for i in range(1, 11)),
)


def group_of(relative: str) -> str:
    """The walker or phone a walk stands for in the table (its folder's meaning)."""
    top, folder = relative.split("/")[:2]
    return {"multi users": folder, "multi devices": folder, "large scale": "floor1 (Tango)"}.get(top, top)


def walk_row(model: LoadedModel, rel: str, seq: ImuSequence) -> dict:
    """One walk predicted and scored (RoNIN convention, no alignment): its table row. The heading error
    over 10-s windows is read after the start alignment, as issue 50 defines it (without it, a phone-only
    walk's first seconds' attitude offset stays in every window)."""
    prediction = predict_trajectory(model, seq, keep_prepared=False)
    scored = score(prediction)
    values = scored.metrics.values
    started = score(prediction, "start").metrics.values
    return {
        "walk": rel.removesuffix(".csv.xz"),
        "group": group_of(rel),
        "carry": str(seq.meta.get("carry", "unknown")),
        "orientation": (prediction.orientation_choice or {}).get("source"),
        "minutes": seq.duration_s / 60,
        "ate": values["ate"],
        "still": scored.stand_still.values["ate"],
        "ratio": values.get("distance_ratio"),
        "end_per_100m": 100 * values["pde"],  # final position error over the true path length
        "heading": started.get("heading_error_10s_deg"),  # median over 10-s windows (ftin.metrics.heading)
        "heading_late": started.get("heading_error_10s_after_2min_deg"),
    }


def score_walks(checkpoint: Path, data_root: Path) -> list[dict]:
    model = load_model(checkpoint)
    paths = [data_root / protocol.DATA_FOLDERS[protocol.OXIOD] / rel for rel in NEW_WALKS]
    rows = []
    for rel, seq in zip(NEW_WALKS, load_phone_only(paths, "new OxIOD walks"), strict=True):
        rows.append(walk_row(model, rel, seq))
        print(f"{checkpoint.stem} {rel}: ATE {rows[-1]['ate']:.2f} ratio {rows[-1]['ratio']}")
    return rows


def report(results: dict[str, list[dict]]) -> list[str]:
    lines = [
        "# Today's walking checkpoints on the 30 new OxIOD walks, phone only",
        "",
        "Made by `python -m experiments.probe_new_oxiod_walks` (its docstring: question, method). ATE in m,",
        "RoNIN convention; ratio: distance ratio (predicted path over the walked distance, the acceptance",
        "measure, in bounds at 0.8-1.2); end / 100 m: the end-point error per 100 m walked.",
        "",
        "| checkpoint | group | walks | carry | mean ATE | stand still | ATE / still | ratio (min-max) "
        "| in 0.8-1.2 | end / 100 m |",
        "|---|---|--:|---|--:|--:|--:|---|--:|--:|",
    ]
    for name, rows in results.items():
        groups: dict[str, list[dict]] = defaultdict(list)
        for row in rows:
            groups[row["group"]].append(row)
        for group, part in [*groups.items(), ("all", rows)]:
            ate, still = np.mean([r["ate"] for r in part]), np.mean([r["still"] for r in part])
            ratios = [r["ratio"] for r in part if r["ratio"] is not None]
            inside = sum(0.8 <= r <= 1.2 for r in ratios)
            carries = ", ".join(sorted({r["carry"] for r in part}))
            lines.append(
                f"| {name} | {group} | {len(part)} | {carries} | {ate:.2f} | {still:.2f} | {ate / still:.2f} "
                f"| {min(ratios):.2f}-{max(ratios):.2f} | {inside} of {len(ratios)} "
                f"| {np.mean([r['end_per_100m'] for r in part]):.1f} |"
            )
    lines += ["", "Per walk:", "", "| checkpoint | walk | carry | orientation | min | ATE | still | ratio |"]
    lines.append("|---|---|---|---|--:|--:|--:|--:|")
    for name, rows in results.items():
        for r in rows:
            ratio = "—" if r["ratio"] is None else f"{r['ratio']:.2f}"
            lines.append(
                f"| {name} | {r['walk']} | {r['carry']} | {r['orientation']} | {r['minutes']:.1f} "
                f"| {r['ate']:.2f} | {r['still']:.2f} | {ratio} |"
            )
    return lines


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", action="append", required=True, type=Path)
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    results = {path.stem: score_walks(path, args.data_root) for path in args.checkpoint}
    write_report(args.out, report(results))


if __name__ == "__main__":
    main()
