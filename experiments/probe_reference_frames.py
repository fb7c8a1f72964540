"""Does each training walk's reference orientation belong to its IMU? (issue 34)

Question: stage three's retrain (``docs/results/probes/stage_three_retrain.md``) and the earlier
8-minute fine-tunes (``damped_bounce.md``) read some held-out walks shorter after training on the new
OxIOD walks (the Nexus 5's walk 8: 0.99 of its distance before, 0.34-0.47 after training on its walk 7).
Every checkpoint trains on ``orientation=ground_truth``: the IMU rotated into the world by the
reference (Vicon, Tango, Qualisys). If the reference tracks another body than the phone (markers on a
bag the phone sits in, a rig whose axes are not the phone's), the inputs carry gravity into the
horizontal channels and disagree with the labels.

Method, per walk, no network (``ftin.data.reference_check``, which now warns wherever a reference
orientation is applied): the IMU's specific force rotated into the world by an orientation, averaged
over 1 s, against the second derivative of the reference position averaged the same way;
``residual`` = RMS of the horizontal difference (m/s²), beside the true horizontal acceleration's RMS
(``signal``). Orientations: ``reference`` (what training reads), ``levelled`` (VQF 6-D's tilt from the
IMU alone, the reference's heading: ``ftin.data.frames.with_heading_of``), ``levelled+yaw`` (that, turned
by the one yaw offset per walk that best matches the two accelerations: a reference heading that
belongs to another body). ``tilt gap``: RMS angle between the reference's and VQF 6-D's gravity in the
phone's frame. A reference **disagrees with its IMU** when its residual is over 0.5 m/s² and over twice
the ``levelled+yaw`` one (the IMU levelled by itself explains the motion, the reference does not).

Walks: the walking dataset's training and validation parts (OxIOD, RIDI, Inria; ``ftin.protocol``)
and stage three's new OxIOD walks (``NEW_TRAIN``, ``NEW_VAL``, the floor walks).

    nice -n 10 .venv/bin/python -m experiments.probe_reference_frames \
        --out docs/results/probes/reference_frames.md
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from experiments.common import argument_parser, parse, write_report
from experiments.orientation_quality import tilt_error_deg
from ftin import protocol
from ftin.data.discovery import read_sequence
from ftin.data.preprocess import estimate_orientation
from ftin.data.reference_check import MIN_RESIDUAL_M_S2, RATIO, check_reference
from ftin.data.types import ImuSequence
from ftin.files import DEFAULT_DATA_ROOT
from ftin.protocol.stage_three import FLOOR_DRIFT, NEW_TRAIN, NEW_VAL

CACHE = Path("runs/probes/reference_frames.json")


def walk_row(rel: str, seq: ImuSequence) -> dict:
    reference = seq.gt.q_world_body_wxyz
    vqf = estimate_orientation(seq, use_magnetometer=False).q_world_device_wxyz
    found = check_reference(seq, reference, tilt_from=vqf)
    tracked = seq.gt.tracked_mask
    return {
        "walk": rel,
        "carry": str(seq.meta.get("carry", "unknown")),
        "signal": found.signal_m_s2,
        "reference": found.reference_m_s2,
        "levelled": found.unturned_m_s2,  # before the yaw turn
        "levelled_yaw": found.levelled_m_s2,
        "yaw_deg": found.yaw_offset_deg,
        "tilt_gap_deg": float(np.sqrt(np.mean(tilt_error_deg(vqf[tracked], reference[tracked]) ** 2))),
        "disagrees": found.disagrees,
    }


def disagrees(row: dict) -> bool:
    return row["disagrees"]


def walks(data_root: Path):
    """``(set, relative path)`` of every walk examined."""
    for dataset in (protocol.OXIOD, protocol.RIDI, protocol.INRIA):
        for part in ("train", "val"):
            for path in protocol.split_paths(data_root, dataset, part):
                yield f"{protocol.DATASET_LABELS[dataset]} {part}", str(path.relative_to(data_root))
    for label, rels in (("new train", NEW_TRAIN), ("new val", NEW_VAL), ("floor", FLOOR_DRIFT)):
        for rel in rels:
            yield label, rel


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    rows = json.loads(CACHE.read_text()) if CACHE.exists() else []
    done = {r["walk"] for r in rows}
    for label, rel in walks(args.data_root):
        if rel in done:
            continue
        row = {"set": label, **walk_row(rel, read_sequence(args.data_root / rel))}
        rows.append(row)
        print(
            f"{label} {rel}: reference {row['reference']:.2f}, levelled+yaw {row['levelled_yaw']:.2f}",
            flush=True,
        )
        CACHE.parent.mkdir(parents=True, exist_ok=True)
        CACHE.write_text(json.dumps(rows))
    lines = [
        "# Does each walk's reference orientation belong to its IMU?",
        "",
        "Made by `python -m experiments.probe_reference_frames` (its docstring: question, method, rule).",
        "Residuals: RMS (m/s²) of the horizontal IMU acceleration, rotated by each orientation, against the",
        "reference position's, both averaged over 1 s; signal: the latter's RMS. **Disagrees**: the",
        f"reference's residual over {MIN_RESIDUAL_M_S2} m/s² and over {RATIO:g}x the levelled+yaw one.",
        "",
        "## By set",
        "",
        "| set | walks | disagree | median residual: reference / levelled / levelled+yaw |",
        "|---|--:|--:|---|",
    ]
    for label in dict.fromkeys(r["set"] for r in rows):
        part = [r for r in rows if r["set"] == label]
        med = " / ".join(
            f"{np.median([r[k] for r in part]):.2f}" for k in ("reference", "levelled", "levelled_yaw")
        )
        lines.append(f"| {label} | {len(part)} | {sum(map(disagrees, part))} | {med} |")
    lines += [
        "",
        "## Walks whose reference disagrees with their IMU, then the ten next-largest residuals",
        "",
        "| set | walk | carry | signal | reference | levelled | levelled+yaw | yaw offset | tilt gap "
        "| disagrees |",
        "|---|---|---|--:|--:|--:|--:|--:|--:|---|",
    ]
    ranked = sorted(rows, key=lambda r: (not disagrees(r), -r["reference"]))
    shown = [r for r in ranked if disagrees(r)] + [r for r in ranked if not disagrees(r)][:10]
    for r in shown:
        lines.append(
            f"| {r['set']} | {r['walk']} | {r['carry']} | {r['signal']:.2f} | {r['reference']:.2f} "
            f"| {r['levelled']:.2f} | {r['levelled_yaw']:.2f} | {r['yaw_deg']:+.0f}° "
            f"| {r['tilt_gap_deg']:.1f}° | {'yes' if disagrees(r) else 'no'} |"
        )
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
