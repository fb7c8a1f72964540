"""Where the default stands on the ILC mall walks (issue 54): path ratio per floor, phone only.

The Indoor Location Competition's site-1 traces (``ftin.data.readers.ilc``; 571 walks on floors B1, F1-F4,
the phone held flat in front, 50 Hz, sparse truth: the surveyor's waypoints) read through the normal path
(``predict_trajectory``: ``auto`` orientation from gyroscope, accelerometer and magnetometer, no phone
attitude exists in these files; up-sampled to the model's 100 Hz) and scored at the waypoints
(``ftin.evaluate_sparse``: ATE after one 2-D rotation + translation per walk, the path ratio between the
first and last waypoint, segment ratios and turn errors, none of them fitted).

Walks: every ``--every``-th trace of each floor in file-name order (all with ``--every 1``), so that the
sample is fixed and spread over each floor's recording days. No choice is made here: it is the baseline
the sparse-truth and stride probes are read against.

    nice -n 10 python -m experiments.probe_ilc_baseline --every 5 --out docs/results/probes/ilc_baseline.md
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from experiments.common import argument_parser, parse, write_report
from ftin.checkpoint import load_model
from ftin.data.discovery import read_sequence
from ftin.evaluate_sparse import RATIO_BAND, WaypointReport, evaluate_waypoints
from ftin.files import DEFAULT_DATA_ROOT

FLOORS = ("B1", "F1", "F2", "F3", "F4")


def floor_walks(data_root: Path, floor: str, every: int) -> list[Path]:
    return sorted((data_root / "ilc" / "site1" / floor).glob("*.txt.xz"))[::every]


def floor_lines(floor: str, report: WaypointReport) -> str:
    ratios = [r.metrics.path_ratio for r in report.sequences if r.metrics.path_ratio is not None]
    low, high = RATIO_BAND
    s = report.summary()
    q10, q50, q90 = np.percentile(ratios, [10, 50, 90])
    band, wide = sum(low <= x <= high for x in ratios), sum(0.8 <= x <= 1.2 for x in ratios)
    ate, still = s["mean_ate_at_waypoints_m"], s["mean_stand_still_ate_m"]
    return (
        f"| {floor} | {len(report.sequences)} | {q50:.2f} | {q10:.2f}-{q90:.2f} | {band} of {len(ratios)} "
        f"| {wide} | {s['median_segment_ratio']:.2f} | {ate:.2f} | {still:.2f} "
        f"| {s['median_abs_turn_error_deg']:.0f} |"
    )


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", type=Path, default=Path("checkpoints/ronin_resnet-walking"))
    parser.add_argument("--every", type=int, default=5, help="every k-th trace of each floor")
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--json", type=Path, default=None, help="the per-walk rows as JSON")
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    model = load_model(args.checkpoint)
    started = time.monotonic()
    reports = {}
    for floor in FLOORS:
        seqs = [read_sequence(p) for p in floor_walks(args.data_root, floor, args.every)]
        reports[floor] = evaluate_waypoints(model, seqs)
        print(floor_lines(floor, reports[floor]), flush=True)
    minutes = (time.monotonic() - started) / 60
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({f: r.to_json() for f, r in reports.items()}))
    pooled = WaypointReport(model.name, [r for rep in reports.values() for r in rep.sequences])
    lines = [
        f"# The default on the ILC mall walks (phone only, `{args.checkpoint}`)",
        "",
        f"Made by `nice -n 10 python -m experiments.probe_ilc_baseline --every {args.every} --out "
        f"docs/results/probes/ilc_baseline.md` ({minutes:.0f} min on two shared cores). Its docstring: "
        "method. Path ratio: predicted path between the first and last waypoint over the waypoints' "
        "polyline; segment ratio: predicted displacement over a segment's length (segments of 1 m or more); "
        "ATE at the waypoints after one 2-D rotation + translation per walk, beside standing still at the "
        "same marks; turn: median |turn error| at the waypoints, degrees.",
        "",
        "| floor | walks | path ratio median | 10-90 % | in 0.85-1.15 | in 0.8-1.2 | segment ratio median "
        "| ATE @ waypoints (m) | stand still (m) | turn error (deg) |",
        "|---|--:|--:|---|--:|--:|--:|--:|--:|--:|",
        *(floor_lines(f, r) for f, r in reports.items()),
        floor_lines("all", pooled),
    ]
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
