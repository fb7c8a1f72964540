"""Probe: does the network inside an EKF (``ftin.filter``, after TLIO) lower what a phone alone costs?

    .venv/bin/python -m experiments.probe_ekf [--checkpoint checkpoints/ronin_resnet-walking] \
        [--sets oxiod-test oxiod-val ridi-val inria-val] [--arm NAME KEY=VALUE ...] \
        [--cache runs/probes/ekf] [--out docs/results/probes/ekf.md]

Issue 36: on the OxIOD test walks the default's phone-only ATE is 2.43x its motion-capture ATE and
VQF levels the phone to 1.68 deg of the truth. Each recording is read phone only (``auto``, as an
upload gets it; ``ftin.data.loading.load_phone_only``) and with the motion-capture orientation, and
scored start-aligned (RoNIN convention) four ways: the network on motion capture (the ground-truth
row), on ``auto`` (today's phone-only row), the EKF's own trajectory (started from ``auto``'s first
orientation, zero biases), and the network re-run on the EKF's orientation, integrated as inference
integrates. Tilt error: mean angle between the estimate's and motion capture's gravity directions over
the tracked samples. Consistency: the mean NIS of the updates (3 dof) and the mean tilt NEES (2 dof)
against motion capture, with the share of single values inside their 95 % chi-square bounds; and a
position NEES no marker mounting enters: the EKF's horizontal position error against the start-aligned
ground truth every 10 s with its own position covariance (2 dof), pooled over each set.

The measurement covariance of a model without a variance head (issue 36's consistency part):

    nice -n 10 .venv/bin/python -m experiments.probe_ekf --sets ridi-val inria-val oxiod-val oxiod-test \
        --arm fixed measurement_sigma=fixed --arm calibrated measurement_sigma=calibrated

``--fit`` first prints the network's velocity residuals against motion capture on the OxIOD and RIDI
validation walks (the fixed measurement covariance of a model without a variance head). ``--arm``
runs a named ``FilterConfig`` (repeatable; ``default`` is ``FilterConfig()``); results are cached per
arm and recording under ``--cache`` so that the report lists every arm tried. Test parts are read
only for the OxIOD test set the issue scores.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from experiments.common import argument_parser, parse, write_report
from ftin import protocol
from ftin.checkpoint import load_model
from ftin.data import frames
from ftin.data.loading import load_phone_only, load_sequences
from ftin.evaluate import score
from ftin.files import DEFAULT_DATA_ROOT
from ftin.filter import FilterConfig, filter_prediction
from ftin.filter.consistency import chi2_bounds, fraction_within, tilt_error_deg, tilt_nees
from ftin.filter.levelled import MAX_MEAN_NIS
from ftin.infer import predict_trajectory
from ftin.uncertainty import path_uncertainty
from ftin.uncertainty.radius import mahalanobis_sq

SETS = {
    "oxiod-test": (protocol.OXIOD, "test"),
    "oxiod-val": (protocol.OXIOD, "val"),
    "ridi-val": (protocol.RIDI, "val"),
    "inria-val": (protocol.INRIA, "val"),
    # Walkers and phones no shipped network trained on (stage three's held-out fold; the floor walks).
    "oxiod-new-val": (protocol.OXIOD, "new-val"),
    "oxiod-floor": (protocol.OXIOD, "floor"),
}
NEW_PARTS = {"new-val": protocol.NEW_VAL, "floor": protocol.FLOOR_DRIFT}


def set_paths(data_root: Path, dataset: str, part: str) -> list[Path]:
    """A set's recordings: a protocol part, or one of stage three's lists (``NEW_PARTS``)."""
    if part in NEW_PARTS:
        return [data_root / rel for rel in NEW_PARTS[part]]
    return protocol.split_paths(data_root, dataset, part)


START_S = 20.0  # the tilt over a walk's first seconds is also reported: how fast the filter settles
POSITION_EVERY_S = 10.0  # how often the position NEES is read (s): roughly independent checks
WAYS = ("truth", "auto", "ekf", "net_on_ekf", "net_on_ekf_tilt", "levelled")


def parse_arm(items: list[str]) -> tuple[str, dict]:
    """``NAME KEY=VALUE ...`` -> the arm's name and its ``FilterConfig`` overrides (and ``passes``, the
    filter's passes: ``filter_prediction``'s, not a ``FilterConfig`` field)."""
    name, overrides = items[0], {}
    for item in items[1:]:
        key, value = item.split("=", 1)
        if value == "none":
            overrides[key] = None
        elif key in ("heading_reference", "measurement_sigma"):
            overrides[key] = value
        else:
            overrides[key] = int(value) if key in ("update_every", "passes") else float(value)
    return name, overrides


def fit_residuals(model, data_root: Path) -> list[str]:
    """Per dataset: the per-axis RMS of the network's window velocity minus motion capture's."""
    lines = []
    for dataset in (protocol.OXIOD, protocol.RIDI):
        residuals = []
        for path in protocol.split_paths(data_root, dataset, "val"):
            prediction = predict_trajectory(model, load_sequences([path], orientation="ground_truth")[0])
            t, gt = prediction.prepared.seq.t_s, prediction.truth
            a = np.searchsorted(t, prediction.span_t_s[:, 0])
            b = np.searchsorted(t, prediction.span_t_s[:, 1])
            ok = gt.tracked_mask[a] & gt.tracked_mask[b]
            v = (gt.p_world_m[b] - gt.p_world_m[a])[:, :2] / (t[b] - t[a])[:, None]
            residuals.append((prediction.velocity_m_s[:, :2] - v)[ok])
        r = np.concatenate(residuals)
        rms = np.sqrt(np.mean(r**2, axis=0))
        lines.append(f"{dataset}: {len(r)} windows, residual RMS x {rms[0]:.3f}, y {rms[1]:.3f} m/s")
    return lines


def baseline(model, path: Path) -> dict:
    """The network without the filter: motion capture and ``auto``, and VQF's tilt error."""
    phone = load_phone_only([path])[0]
    truth = load_sequences([path], orientation="ground_truth")[0]
    auto = predict_trajectory(model, phone)
    seq = auto.prepared.seq
    tracked = seq.gt.tracked_mask
    auto_scored = score(auto, "start").metrics
    return {
        "name": phone.name,
        "minutes": round(phone.duration_s / 60.0, 2),
        "truth": score(predict_trajectory(model, truth), "start").metrics.ate,
        "auto": auto_scored.ate,
        "ratio_auto": _number(auto_scored.distance_ratio),
        "tilt_auto": float(
            tilt_error_deg(seq.q_world_device_wxyz[tracked], seq.gt.q_world_body_wxyz[tracked]).mean()
        ),
        "source": (seq.meta.get("orientation_choice") or {}).get("source", "?"),
    }


def with_filter(model, path: Path, config: FilterConfig, passes: int = 1) -> dict:
    """The EKF over the phone-only recording: its ATE, the network on its orientation, tilt, NIS, NEES."""
    phone = load_phone_only([path])[0]
    began = time.perf_counter()
    prediction, run = filter_prediction(model, phone, config, passes=passes)
    seconds = time.perf_counter() - began
    seq = prediction.prepared.seq
    tracked = seq.gt.tracked_mask
    q_true = seq.gt.q_world_body_wxyz[tracked]
    q_ekf = run.q_world_device_wxyz[tracked]
    early = seq.t_s[tracked] < seq.t_s[0] + START_S  # the filter settling (ftin.filter.settle)
    rerun = predict_trajectory(model, seq.with_(q_world_device_wxyz=run.q_world_device_wxyz))
    # The EKF's tilt under auto's heading: how much of a difference is heading (gyro-only in the EKF).
    tilt_only = frames.with_heading_of(seq.q_world_device_wxyz, run.q_world_device_wxyz)
    rerun_tilt = predict_trajectory(model, seq.with_(q_world_device_wxyz=tilt_only))
    nees = tilt_nees(q_ekf, q_true, run.tilt_cov[tracked])
    scored = score(prediction, "start")
    P = run.position_cov_xy
    filter_cov = np.column_stack([P[:, 0, 0], P[:, 0, 1], P[:, 1, 1]])
    pos_nees = position_nees(scored.truth_in_estimate_frame(seq.gt), run.p_world_m, filter_cov)
    # The re-read's own path uncertainty (ftin.uncertainty), as --filter ekf answers with it.
    rerun_scored = score(rerun, "start")
    found = path_uncertainty(rerun, model.name, seq.meta.get("carry"))
    rerun_nees = np.zeros(0)
    if found is not None:
        truth_there = rerun_scored.truth_in_estimate_frame(seq.gt)
        rerun_nees = position_nees(truth_there, rerun.trajectory.p_world_m, found.cov_m2)
    half = len(run.speed_scale) // 2
    return {
        "ekf": scored.metrics.ate,
        "ratio_ekf": _number(scored.metrics.distance_ratio),
        "speed_scale": float(np.median(run.speed_scale[half:])),
        "net_on_ekf": rerun_scored.metrics.ate,
        "net_on_ekf_tilt": score(rerun_tilt, "start").metrics.ate,
        "tilt_ekf": float(tilt_error_deg(q_ekf, q_true).mean()),
        "tilt_ekf_start": float(tilt_error_deg(q_ekf[early], q_true[early]).mean()),
        "nis": float(run.nis.mean()),
        "nis_within": fraction_within(run.nis, 3),
        "nees": float(nees.mean()),
        "nees_within": fraction_within(nees, 2),
        "pos_nees": float(pos_nees.mean()) if len(pos_nees) else float("nan"),
        "pos_nees_within": fraction_within(pos_nees, 2),
        "pos_nees_values": [round(float(v), 3) for v in pos_nees],
        "net_on_ekf_nees_values": [round(float(v), 3) for v in rerun_nees],
        "rejected": int((~run.applied).sum()),
        "seconds": round(seconds, 1),
        "bias_end": {"gyro": run.gyro_bias_rad_s[-1].tolist(), "acc": run.acc_bias_m_s2[-1].tolist()},
    }


def _number(value: float | None) -> float:
    """A metric for the cache: nan where it is undefined (a walk too short for a distance ratio)."""
    return float("nan") if value is None else float(value)


def position_nees(
    truth, p_m: np.ndarray, cov_m2: np.ndarray, every_s: float = POSITION_EVERY_S
) -> np.ndarray:
    """The filter's horizontal position NEES (2 dof) against the ground truth (already moved into the
    estimate's frame by the start alignment) every ``every_s`` seconds of tracked truth after the
    start: no motion-capture mounting enters it, only where the device was. ``cov_m2`` ``(N, 3)``:
    ``[xx, xy, yy]`` per sample, as ``ftin.uncertainty`` gives it."""
    t = truth.t_s
    marks = np.arange(t[0] + every_s, t[-1], every_s)
    idx = np.unique(np.clip(np.searchsorted(t, marks), 0, len(t) - 1))
    idx = idx[truth.tracked_mask[idx]]
    return mahalanobis_sq(truth.p_world_m[idx, :2] - p_m[idx, :2], cov_m2[idx])


def cached(cache: Path, key: str, make) -> dict:
    path = cache / f"{key}.json"
    if path.exists():
        return json.loads(path.read_text())
    value = make()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(value))
    return value


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", default="checkpoints/ronin_resnet-walking")
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--sets", nargs="+", default=list(SETS)[:4], choices=list(SETS))
    parser.add_argument("--arm", nargs="+", action="append", help="NAME KEY=VALUE ... (FilterConfig fields)")
    parser.add_argument("--limit", type=int, default=None, help="at most this many recordings per set")
    parser.add_argument("--fit", action="store_true", help="print the network's validation residuals first")
    parser.add_argument("--cache", type=Path, default=Path("runs/probes/ekf"))
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument(
        "--report-arms", nargs="*", default=None, help="arms in the report (default: all run)"
    )
    parser.add_argument("--cached-only", action="store_true", help="report only what the cache holds")
    args = parse(parser)
    model = load_model(args.checkpoint)
    if args.fit:
        print("\n".join(fit_residuals(model, args.data_root)))
    arms = dict(parse_arm(a) for a in (args.arm or [["default"]]))
    rows: dict[str, dict[str, list[dict]]] = {}
    for set_name in args.sets:
        dataset, part = SETS[set_name]
        paths = set_paths(args.data_root, dataset, part)[: args.limit]
        for path in tqdm(paths, desc=set_name, unit="walk"):
            key = f"{set_name}/{path.relative_to(args.data_root)}".replace("/", "__").replace(" ", "_")
            # baseline-v2: auto with the body-locked heading (ftin.body_heading), and its distance ratio
            base = cached(args.cache / "baseline-v2", key, lambda p=path: baseline(model, p))
            for arm, overrides in arms.items():
                if args.cached_only and not (args.cache / arm / f"{key}.json").exists():
                    continue
                passes = overrides.get("passes", 1)
                config = FilterConfig(**{k: v for k, v in overrides.items() if k != "passes"})
                result = cached(
                    args.cache / arm, key, lambda p=path, c=config, n=passes: with_filter(model, p, c, n)
                )
                result["overrides"] = overrides
                # ftin.filter.levelled's rule from what is cached: net/ekf unless the walk's mean NIS is high
                result["levelled"] = result["net_on_ekf"] if result["nis"] <= MAX_MEAN_NIS else base["auto"]
                rows.setdefault(arm, {}).setdefault(set_name, []).append({**base, **result})
    write_report(args.out, render(args, rows, arms))


def summary(records: list[dict]) -> dict:
    keys = (*WAYS, "tilt_auto", "tilt_ekf", "tilt_ekf_start", "nis", "nees", "nis_within", "nees_within")
    keys += ("ratio_auto",)
    keys += ("ratio_ekf", "speed_scale")
    # arms run before a column lack it: nan
    mean = {k: float(np.mean([r.get(k, np.nan) for r in records])) for k in keys}
    # Position NEES pooled over the set's checks (every POSITION_EVERY_S), not averaged per walk.
    pooled = [v for r in records for v in r.get("pos_nees_values", [])]
    mean["pos_nees"] = float(np.mean(pooled)) if pooled else float("nan")
    mean["pos_nees_within"] = fraction_within(np.array(pooled), 2) if pooled else float("nan")
    mean["pos_nees_n"] = len(pooled)
    # The re-read's own path uncertainty (arms run before it was added: none).
    pooled = [v for r in records for v in r.get("net_on_ekf_nees_values", [])]
    mean["net_nees"] = float(np.mean(pooled)) if pooled else float("nan")
    mean["net_nees_within"] = fraction_within(np.array(pooled), 2) if pooled else float("nan")
    mean["net_nees_n"] = len(pooled)
    return mean


def render(args, rows: dict, arms: dict) -> list[str]:
    low3, high3 = chi2_bounds(3)
    low2, high2 = chi2_bounds(2)
    command = f"python -m experiments.probe_ekf --checkpoint {args.checkpoint} --sets {' '.join(args.sets)}"
    lines = [
        "# The network inside an EKF, phone only (a probe)",
        "",
        f"Made by `{command}` with the arms below (its docstring: method).",
        "",
        "ATE in metres (RoNIN convention, start-aligned), mean over recordings: the network on motion",
        "capture (`truth`), on `auto` (today's phone only), the EKF's own trajectory (`ekf`), the network",
        "re-run on the EKF's orientation (`net/ekf`) and on the EKF's tilt under `auto`'s heading",
        "(`net/ekf tilt`), and `levelled` (`ftin.filter.levelled`: `net/ekf` where the walk's mean NIS is at",
        f"most {MAX_MEAN_NIS:g}, else `auto`); the ratios are over `truth`, and `levelled`'s also over",
        "`auto`.",
        "Tilt: mean angle (deg) between the estimate's and motion capture's gravity direction (in",
        f"brackets the EKF's over the first {START_S:.0f} s; arms run before it was added: nan).",
        "NIS (3 dof, expected 3, single-value 95 % bounds",
        f"{low3:.2f}-{high3:.2f}) and tilt NEES against motion capture (2 dof, expected 2, bounds",
        f"{low2:.2f}-{high2:.2f}): mean, and the share of values inside the bounds. Position NEES: the",
        "EKF's horizontal position error against the start-aligned ground truth every"
        f" {POSITION_EVERY_S:.0f} s with its own",
        "position covariance (2 dof, same bounds; no motion-capture mounting enters it), pooled over the",
        "set's checks: mean, share inside the bounds, number of checks (arms run before it was added: -);",
        "`net/ekf NEES` the same for the re-read path with the model's own path uncertainty",
        "(`ftin.uncertainty`), what `--filter ekf` answers with.",
        "Distance: the distance ratio (`ftin.metrics`, predicted path / walked) of `auto` and of the EKF's",
        "path, mean over recordings; k: the median speed scale the filter estimated over each walk's second",
        "half (1 where it estimates none), mean over recordings.",
        "",
        "| arm | set | n | truth | auto | ekf | net/ekf | net/ekf tilt | levelled | over truth: auto / ekf /"
        " net/ekf / net/ekf tilt / levelled | levelled / auto | tilt VQF / EKF (first 20 s) | NIS (in) |"
        " tilt NEES (in) |"
        " position NEES (in, checks) | net/ekf NEES (in, checks) | distance auto / ekf | k |",
        "|---|---|--:|--:|--:|--:|--:|--:|--:|---|--:|---|---|---|---|---|---|--:|",
    ]
    for arm in args.report_arms or list(rows):
        for set_name, records in rows.get(arm, {}).items():
            m = summary(records)
            ratios = " / ".join(f"{m[w] / m['truth']:.2f}x" for w in WAYS[1:])
            ates = " | ".join(f"{m[w]:.3f}" for w in WAYS)
            position = (
                f"{m['pos_nees']:.2f} ({m['pos_nees_within']:.0%}, {m['pos_nees_n']}) |"
                if m["pos_nees_n"]
                else "- |"
            )
            position += (
                f" {m['net_nees']:.2f} ({m['net_nees_within']:.0%}, {m['net_nees_n']}) |"
                if m["net_nees_n"]
                else " - |"
            )
            lines.append(
                f"| {arm} | {set_name} | {len(records)} | {ates} | {ratios} |"
                f" {m['levelled'] / m['auto'] - 1:+.1%} |"
                f" {m['tilt_auto']:.2f} / {m['tilt_ekf']:.2f} ({m['tilt_ekf_start']:.2f}) |"
                f" {m['nis']:.2f} ({m['nis_within']:.0%}) | {m['nees']:.1f} ({m['nees_within']:.0%}) |"
                f" {position} {m['ratio_auto']:.2f} / {m['ratio_ekf']:.2f} | {m['speed_scale']:.2f} |"
            )
    lines += ["", "Arms (`FilterConfig` overrides of the defaults; `passes`: `filter_prediction`'s):", ""]
    for arm in args.report_arms or list(rows):
        lines.append(f"- `{arm}`: {arms.get(arm) or 'the defaults'}")
    lines += [
        "",
        "Per recording (ATE truth / auto / ekf / net/ekf / net/ekf tilt / levelled; tilt VQF / EKF; auto's"
        " source; mean NIS):",
        "",
    ]
    for arm in args.report_arms or list(rows):
        for set_name, records in rows.get(arm, {}).items():
            for r in records:
                ates = " / ".join(f"{r.get(w, np.nan):.2f}" for w in WAYS)
                lines.append(
                    f"- {arm}, {set_name}, {r['name']} ({r['minutes']} min): {ates};"
                    f" tilt {r['tilt_auto']:.2f} / {r['tilt_ekf']:.2f}; {r['source']}; NIS {r['nis']:.1f};"
                    f" distance {r.get('ratio_auto', np.nan):.2f} / {r.get('ratio_ekf', np.nan):.2f},"
                    f" k {r.get('speed_scale', np.nan):.2f}"
                )
    return lines


if __name__ == "__main__":
    main()
