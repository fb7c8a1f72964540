"""Probe: should a live ``filter=ekf`` session stream the network re-read on the filter's orientation
instead of the filter's own path (``docs/filter.md``, "Live sessions")?

    nice -n 10 .venv/bin/python -m experiments.probe_live_levelled --out docs/results/probes/live_levelled.md

A live session has no offline orientation: it orients with VQF run forwards (``ftin.live.orientation``,
6-D here) and its EKF holds its heading to that (``heading_reference="causal"``). Each walker-held-out
validation walk (OxIOD, RIDI, Inria val), phone only, is turned by VQF run forwards and read three
ways, each causal in its orientation: the model on that orientation (what a live session without the
filter streams), the filter's own path (what a live ``filter=ekf`` session streams today), and the
model re-read on the filter's orientation (``levelled``: on VQF's where the walk's mean NIS so far is
over ``ftin.filter.levelled.MAX_MEAN_NIS``, here the whole walk's as a stand-in for the running one).
The model reads as an upload is read (``predict_trajectory``), not window by window as a stream is: the
orientations are what differ between the ways. Start-aligned ATE (RoNIN convention) and tilt against
motion capture. Test parts are not read.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from tqdm import tqdm
from vqf import VQF

from experiments.common import argument_parser, parse, write_report
from experiments.probe_ekf import SETS, set_paths
from ftin.checkpoint import load_model
from ftin.data import frames
from ftin.data.loading import load_phone_only
from ftin.data.prepare import prepare
from ftin.evaluate import score
from ftin.files import DEFAULT_DATA_ROOT
from ftin.filter import FilterConfig, filter_prediction
from ftin.filter.consistency import tilt_error_deg
from ftin.filter.levelled import MAX_MEAN_NIS
from ftin.infer import predict_trajectory

VALIDATION = ("oxiod-val", "ridi-val", "inria-val")
WAYS = ("vqf_forwards", "ekf_own", "levelled")


def forwards(seq):
    """``seq`` turned by VQF 6-D run forwards only (the live session's causal orientation), marked so that
    the filter's causal heading reference is this orientation's own."""
    online = VQF(float(np.median(np.diff(seq.t_s))))
    q = online.updateBatch(np.ascontiguousarray(seq.gyro_rad_s), np.ascontiguousarray(seq.acc_m_s2))["quat6D"]
    q = np.asarray(q, dtype=np.float64)
    turn = frames.yaw_rad(seq.q_world_device_wxyz[0]) - frames.yaw_rad(q[0])  # into the scored world
    q = frames.wxyz_from_rotation(frames.yaw_rotation(turn) * frames.rotation_from_wxyz(q))
    meta = {**seq.meta, "orientation_choice": {"source": "device"}, "orientation_source": "device"}
    return seq.with_(q_world_device_wxyz=q, meta=meta)


def one_walk(model, path: Path) -> dict:
    phone = load_phone_only([path])[0]
    prepared = prepare(phone, model.imu_rate_hz, model.window, model.stride, "auto").seq
    causal = forwards(prepared)
    tracked = causal.gt.tracked_mask
    truth_q = causal.gt.q_world_body_wxyz[tracked]
    plain = predict_trajectory(model, causal)
    own, run = filter_prediction(model, causal, FilterConfig(heading_reference="causal"))
    nis = float(np.mean(run.nis))
    levelled_q = run.q_world_device_wxyz if nis <= MAX_MEAN_NIS else causal.q_world_device_wxyz
    levelled = predict_trajectory(model, causal.with_(q_world_device_wxyz=levelled_q))
    return {
        "name": phone.name,
        "vqf_forwards": score(plain, "start").metrics.ate,
        "ekf_own": score(own, "start").metrics.ate,
        "levelled": score(levelled, "start").metrics.ate,
        "tilt_vqf_forwards": float(tilt_error_deg(causal.q_world_device_wxyz[tracked], truth_q).mean()),
        "tilt_ekf": float(tilt_error_deg(run.q_world_device_wxyz[tracked], truth_q).mean()),
        "nis": nis,
    }


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", default="checkpoints/ronin_resnet-walking")
    parser.add_argument("--cache", type=Path, default=Path("runs/probes/live_levelled"))
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    model = load_model(args.checkpoint)
    lines = [
        "# Live `filter=ekf`: the filter's own path or the model re-read on its orientation (a probe)",
        "",
        f"Made by `python -m experiments.probe_live_levelled --checkpoint {args.checkpoint}` (its docstring:"
        " method). Start-aligned ATE (m), mean over walks, phone only, every orientation causal (VQF 6-D"
        " run forwards); tilt (deg) against motion capture; in brackets the change against VQF forwards.",
        "",
        "| set | n | VQF forwards (live, no filter) | the EKF's own path (live `filter=ekf` today) |"
        " re-read on the EKF's orientation | walks kept on VQF's | tilt VQF forwards / EKF |",
        "|---|--:|--:|--:|--:|--:|--:|",
    ]
    per_walk = []
    for set_name in VALIDATION:
        records = []
        for path in tqdm(set_paths(DEFAULT_DATA_ROOT, *SETS[set_name]), desc=set_name, unit="walk"):
            key = f"{set_name}/{path.relative_to(DEFAULT_DATA_ROOT)}".replace("/", "__").replace(" ", "_")
            cache = args.cache / f"{Path(args.checkpoint).name}" / f"{key}.json"
            if not cache.exists():
                cache.parent.mkdir(parents=True, exist_ok=True)
                cache.write_text(json.dumps(one_walk(model, path)))
            records.append(json.loads(cache.read_text()))
        m = {k: float(np.mean([r[k] for r in records])) for k in (*WAYS, "tilt_vqf_forwards", "tilt_ekf")}
        base = m["vqf_forwards"]
        kept = sum(r["nis"] > MAX_MEAN_NIS for r in records)
        lines.append(
            f"| {set_name} | {len(records)} | {base:.3f} |"
            f" {m['ekf_own']:.3f} ({m['ekf_own'] / base - 1:+.1%}) |"
            f" {m['levelled']:.3f} ({m['levelled'] / base - 1:+.1%}) | {kept} |"
            f" {m['tilt_vqf_forwards']:.2f} / {m['tilt_ekf']:.2f} |"
        )
        per_walk += [
            f"- {set_name}, {r['name']}: {' / '.join(f'{r[w]:.2f}' for w in WAYS)}; tilt"
            f" {r['tilt_vqf_forwards']:.2f} / {r['tilt_ekf']:.2f}; NIS {r['nis']:.1f}"
            for r in records
        ]
    lines += [
        "",
        "Per walk (ATE VQF forwards / the EKF's own path / re-read; tilt; mean NIS):",
        "",
        *per_walk,
    ]
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
