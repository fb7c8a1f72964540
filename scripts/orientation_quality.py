"""Orientation filters against motion-capture orientation on the OxIOD recordings (docs/orientation.md).

For every OxIOD sequence under the given root: the ground-truth device orientation (Vicon marker
orientation times the solved marker-to-device rotation, ``oxiod.read(orientation="ground_truth")``)
is compared with
- ``device``: the iPhone's own CoreMotion attitude (what a phone export carries),
- ``vqf-6d`` / ``vqf-9d``: ``ftin.data.preprocess.estimate_orientation`` (VQF offline, without and
  with the magnetometer columns of ``imuN.csv``),
- ``madgwick``: the previous default (``ahrs`` Madgwick, one Python call per sample).
Errors: tilt = angle between the estimated and the true gravity direction in the device frame (no
heading involved); heading = yaw of ``R_true(t) R_est(t)^-1`` minus its mean over the first 5 s
(the two world frames differ by a constant yaw), wrapped to +-180 deg, as RMS and at the end.

    .venv/bin/python scripts/orientation_quality.py ../shared/data/oxiod --out docs/orientation.md
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import pandas as pd

from ftin.data import frames
from ftin.data.preprocess import estimate_orientation
from ftin.data.readers import oxiod

ALIGN_S = 5.0


def tilt_error_deg(q_est: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    up = np.array([0.0, 0.0, 1.0])
    u_est = frames.rotation_from_wxyz(q_est).inv().apply(up)
    u_true = frames.rotation_from_wxyz(q_true).inv().apply(up)
    return np.degrees(np.arccos(np.clip(np.sum(u_est * u_true, axis=1), -1.0, 1.0)))


def heading_error_deg(t_s: np.ndarray, q_est: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    offset = frames.rotation_from_wxyz(q_true) * frames.rotation_from_wxyz(q_est).inv()
    yaw = np.unwrap(np.asarray(frames.yaw_rad(frames.wxyz_from_rotation(offset))))
    first = t_s <= t_s[0] + ALIGN_S
    err = np.degrees(yaw - yaw[first].mean())
    return (err + 180.0) % 360.0 - 180.0


def magnetometer(imu_path: Path, n_kept: int) -> np.ndarray:
    raw = pd.read_csv(imu_path, header=None).to_numpy(dtype=np.float64)
    kept = raw[1200 : len(raw) - 300, 13:16]
    if len(kept) != n_kept:
        raise SystemExit(f"{imu_path}: {len(kept)} magnetometer rows for {n_kept} samples")
    return kept


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    rows = []
    totals: dict[str, list[float]] = {}
    for path in oxiod.discover(args.root):
        truth = oxiod.read(path)
        device = oxiod.read(path, orientation="device")
        name = path.relative_to(args.root).with_suffix("").as_posix()
        q_true = truth.q_world_device_wxyz
        bare = truth.with_(q_world_device_wxyz=None, gt=None, meta={})
        mag = magnetometer(path, len(truth))
        estimates: dict[str, tuple[np.ndarray, float]] = {"device": (device.q_world_device_wxyz, 0.0)}
        for label, seq, method in (
            ("vqf-6d", bare, "vqf"),
            ("vqf-9d", bare.with_(meta={"mag_uT": mag}), "vqf"),
            ("madgwick", bare, "madgwick"),
        ):
            start = time.perf_counter()
            out = estimate_orientation(seq, method)
            estimates[label] = (out.q_world_device_wxyz, time.perf_counter() - start)
            assert label != "vqf-9d" or out.meta["orientation_filter"] == "vqf-9d"
        for label, (q, seconds) in estimates.items():
            tilt = tilt_error_deg(q, q_true)
            heading = heading_error_deg(truth.t_s, q, q_true)
            row = {
                "sequence": name,
                "minutes": truth.duration_s / 60.0,
                "filter": label,
                "tilt_rms": float(np.sqrt(np.mean(tilt**2))),
                "tilt_max": float(tilt.max()),
                "heading_rms": float(np.sqrt(np.mean(heading**2))),
                "heading_end": float(abs(heading[-1])),
                "seconds": seconds,
            }
            rows.append(row)
            for key in ("tilt_rms", "tilt_max", "heading_rms", "heading_end", "seconds"):
                totals.setdefault(f"{label}:{key}", []).append(row[key])
        print(name, "done", flush=True)
    lines = [
        "| filter | tilt RMS (deg) | tilt max (deg) | heading RMS (deg) | heading error at end (deg) | "
        "time per sequence (s) |",
        "|:--|--:|--:|--:|--:|--:|",
    ]
    for label in ("device", "vqf-6d", "vqf-9d", "madgwick"):
        m = {
            key: float(np.mean(totals[f"{label}:{key}"]))
            for key in ("tilt_rms", "tilt_max", "heading_rms", "heading_end", "seconds")
        }
        seconds = "-" if label == "device" else f"{m['seconds']:.2f}"
        lines.append(
            f"| {label} | {m['tilt_rms']:.2f} | {m['tilt_max']:.2f} | {m['heading_rms']:.1f} | "
            f"{m['heading_end']:.1f} | {seconds} |"
        )
    per_seq = [
        "| sequence | min | filter | tilt RMS | tilt max | heading RMS | heading end |",
        "|:--|--:|:--|--:|--:|--:|--:|",
    ]
    for r in rows:
        per_seq.append(
            f"| {r['sequence']} | {r['minutes']:.1f} | {r['filter']} | {r['tilt_rms']:.2f} | "
            f"{r['tilt_max']:.2f} | "
            f"{r['heading_rms']:.1f} | {r['heading_end']:.1f} |"
        )
    summary = "\n".join(lines)
    print(summary)
    if args.out is not None:
        # Replace what lies between the markers; keep the prose around them.
        text = args.out.read_text() if args.out.exists() else "<!-- table:start -->\n<!-- table:end -->\n"
        head, rest = text.split("<!-- table:start -->", 1)
        tail = rest.split("<!-- table:end -->", 1)[1]
        table = summary + "\n\nPer sequence:\n\n" + "\n".join(per_seq)
        args.out.write_text(f"{head}<!-- table:start -->\n{table}\n<!-- table:end -->{tail}")


if __name__ == "__main__":
    main()
