"""Step-informed speed: does a step-length floor from the step detector rescue the damped-bounce
under-read (handbags, a phone held steadily in front) without hurting the walks read well?

Question (issue 34, part 3, "step-informed speed ... fused with the network where the step detector is
confident"): the default reads a handbag walk at 0.56-0.76 of its distance while the step detector
counts its steps; a street walk at 244 m of 478 m with 551 steps at 112 steps/min. Does raising the
network's speed to a share of what the steps say, where the steps are regular, bring such walks into
0.8-1.2 on walkers that chose nothing?

Method, phone only (``load_phone_only``: ``auto`` orientation, no motion capture), no training:
1. **Step length from cadence, fitted on training walkers only** (the default checkpoint's training
   parts of OxIOD, RIDI and Inria): over every 4 s stretch of regular steps, the true speed (ground
   truth) over the cadence is one step length; a line ``L = a + b * cadence`` is fitted (least
   squares on the per-stretch medians). No walk scored below took part.
2. Each scored walk is predicted once by the default checkpoint; the step detector
   (``ftin.metrics.steps.detect_steps``) runs on its raw specific force and gyroscope. A window is
   *confident* where the steps within 2 s of its middle number at least 4 with intervals within 1.5x
   of their median; there the steps say ``s = L(cadence) * cadence / 60``.
3. Rules, applied to the window velocities (direction kept, only the speed changes) and integrated
   as the app integrates (``ftin.infer.integrate_spans``):
   - ``floor q``: where the network's speed is under ``q * s`` in a confident window, raise it to
     ``q * s`` (only raises: a walk read well stays as read).
   - ``bout floor q``: the same judged over 20 s (the network's distance over the confident windows
     of the 20 s around each window against ``q`` times the steps'): one factor per stretch, so a
     single odd window cannot pull the speed around.
   - ``blend w``: ``(1 - w) |v| + w s`` in confident windows.
4. ``q`` and ``w`` are chosen on the validation walkers (OxIOD, RIDI, Inria validation parts); the
   30 new OxIOD walks (walkers, phones, carries no shipped checkpoint saw) are the check.

Scores: RoNIN convention ATE over standing still, distance ratio (predicted path over walked, in
bounds at 0.8-1.2), as the acceptance check scores.

    nice -n 10 python -m experiments.probe_step_speed --out docs/results/probes/step_speed.md
"""

from __future__ import annotations

import dataclasses
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from experiments.common import argument_parser, parse, write_report
from experiments.probe_new_oxiod_walks import NEW_WALKS, group_of
from ftin import protocol
from ftin.checkpoint import load_model
from ftin.data import Trajectory
from ftin.data.loading import load_phone_only
from ftin.evaluate import score
from ftin.files import DEFAULT_DATA_ROOT
from ftin.infer import Prediction, integrate_spans, predict_trajectory
from ftin.metrics.steps import detect_steps

CHECKPOINT = Path("checkpoints/ronin_resnet-walking")
CACHE = Path("runs/probes/step_speed")
HALF_SPAN_S = 2.0  # steps within this of a window's middle judge it
MIN_STEPS = 4
REGULAR = 1.5  # every step interval within this factor of their median
BOUT_S = 20.0
FLOORS = (0.8, 1.0, 1.2, 1.4)
BLENDS = (0.3, 0.5)
LOW, HIGH = 0.8, 1.2


def local_cadence(step_t: np.ndarray, t_mid: np.ndarray) -> np.ndarray:
    """Steps per minute around each time, NaN where the steps there are too few or irregular."""
    out = np.full(len(t_mid), np.nan)
    lo = np.searchsorted(step_t, t_mid - HALF_SPAN_S)
    hi = np.searchsorted(step_t, t_mid + HALF_SPAN_S)
    for k, (a, b) in enumerate(zip(lo, hi, strict=True)):
        if b - a < MIN_STEPS:
            continue
        gaps = np.diff(step_t[a:b])
        med = np.median(gaps)
        if gaps.max() > REGULAR * med or gaps.min() < med / REGULAR:
            continue
        out[k] = 60.0 / med
    return out


def fit_step_length(data_root: Path) -> dict:
    """``L = a + b * cadence`` from the training walkers' ground truth (module docstring, step 1)."""
    cadences, lengths = [], []
    for dataset in (protocol.OXIOD, protocol.RIDI, protocol.INRIA):
        paths = protocol.split_paths(data_root, dataset, "train")
        for seq in load_phone_only(paths, f"{dataset} train"):
            if seq.gt is None:
                continue
            steps = detect_steps(seq.t_s, seq.acc_m_s2, seq.gyro_rad_s)
            t0, t1 = seq.gt.t_s[0], seq.gt.t_s[-1]
            mids = np.arange(t0 + HALF_SPAN_S, t1 - HALF_SPAN_S, 2 * HALF_SPAN_S)
            cad = local_cadence(steps.t_s, mids)
            for tm, c in zip(mids, cad, strict=True):
                if not np.isfinite(c):
                    continue
                p = np.stack(
                    [
                        np.interp([tm - HALF_SPAN_S, tm + HALF_SPAN_S], seq.gt.t_s, seq.gt.p_world_m[:, i])
                        for i in (0, 1)
                    ]
                )
                speed = np.linalg.norm(p[:, 1] - p[:, 0]) / (2 * HALF_SPAN_S)
                if speed < 0.2:  # a trolley, a stand with the phone moving: not a step length
                    continue
                cadences.append(c)
                lengths.append(speed / (c / 60.0))
    c, length = np.asarray(cadences), np.asarray(lengths)
    b, a = np.polyfit(c, length, 1)
    residual = length - (a + b * c)
    return {
        "a": float(a),
        "b": float(b),
        "stretches": len(c),
        "residual_rms_m": float(np.sqrt(np.mean(residual**2))),
        "cadence_range": [float(np.percentile(c, 5)), float(np.percentile(c, 95))],
    }


def walk_record(model, seq, key: str) -> dict:
    """Predict once and keep what the rules need (cached under runs/, never committed)."""
    cache = CACHE / (key.replace("/", "__").replace(" ", "_") + ".npz")
    if cache.exists():
        return dict(np.load(cache))
    # The network's own directions (the body-locked heading came after this probe; its probe,
    # ``experiments.probe_body_heading``, reads this cache as "network alone").
    prediction = predict_trajectory(model, seq, keep_prepared=False, body_lock=False)
    steps = detect_steps(seq.t_s, seq.acc_m_s2, seq.gyro_rad_s)
    t = prediction.trajectory.t_s
    record = {
        "t_s": t,
        "span": np.searchsorted(t, prediction.span_t_s),
        "velocity": prediction.velocity_m_s,
        "step_t": steps.t_s,
        "truth_t_s": prediction.truth.t_s,
        "truth_p_m": prediction.truth.p_world_m,
        "truth_frame": np.array(prediction.truth_frame or ""),
    }
    CACHE.mkdir(parents=True, exist_ok=True)
    np.savez(cache, **record)
    return record


def rule_speeds(
    rule: str, value: float, speed: np.ndarray, steps_speed: np.ndarray, t_mid: np.ndarray
) -> np.ndarray:
    """The speed each window gets under a rule (module docstring, step 3)."""
    ok = np.isfinite(steps_speed)
    out = speed.copy()
    if rule == "floor":
        out[ok] = np.maximum(speed[ok], value * steps_speed[ok])
    elif rule == "blend":
        out[ok] = (1 - value) * speed[ok] + value * steps_speed[ok]
    elif rule == "bout":
        net = np.where(ok, speed, 0.0)
        said = np.where(ok, steps_speed, 0.0)
        c_net, c_said = np.concatenate([[0], np.cumsum(net)]), np.concatenate([[0], np.cumsum(said)])
        lo = np.searchsorted(t_mid, t_mid - BOUT_S / 2)
        hi = np.searchsorted(t_mid, t_mid + BOUT_S / 2)
        net_sum, said_sum = c_net[hi] - c_net[lo], c_said[hi] - c_said[lo]
        factor = np.where(net_sum > 0, np.maximum(1.0, value * said_sum / np.maximum(net_sum, 1e-9)), 1.0)
        out[ok] = speed[ok] * np.minimum(factor[ok], 3.0)
    return out


def with_velocities(prediction: Prediction, record: dict, velocity: np.ndarray) -> Prediction:
    """``prediction`` with its trajectory integrated from ``velocity`` over the record's spans, as the
    app integrates (a rule's arm, scored like the rest)."""
    span = record["span"]
    p = integrate_spans(record["t_s"], span[:, 0], span[:, 1], velocity, prediction.trajectory.p_world_m[0])
    return dataclasses.replace(prediction, trajectory=dataclasses.replace(prediction.trajectory, p_world_m=p))


def scored(prediction: Prediction, record: dict, speeds: np.ndarray) -> tuple[float, float, float]:
    speed = np.linalg.norm(record["velocity"][:, :2], axis=1)
    scale = np.where(speed > 1e-6, speeds / np.maximum(speed, 1e-6), 1.0)
    result = score(with_velocities(prediction, record, record["velocity"] * scale[:, None]))
    values = result.metrics.values
    return values["ate"], result.stand_still.values["ate"], values.get("distance_ratio", float("nan"))


ARMS = (
    [("none", 0.0)]
    + [("floor", q) for q in FLOORS]
    + [("bout", q) for q in FLOORS]
    + [("blend", w) for w in BLENDS]
)


def arm_name(rule: str, value: float) -> str:
    return "network alone" if rule == "none" else f"{rule} {value:g}"


def score_set(
    model, fit: dict, paths: list[Path], keys: list[str], groups: list[str], label: str
) -> list[dict]:
    rows = []
    for key, group, seq in zip(keys, groups, load_phone_only(paths, label), strict=True):
        record = walk_record(model, seq, key)
        prediction = _prediction_for_scoring(model, record)
        t = record["t_s"]
        t_mid = 0.5 * (t[record["span"][:, 0]] + t[record["span"][:, 1]])
        cadence = local_cadence(record["step_t"], t_mid)
        steps_speed = (fit["a"] + fit["b"] * cadence) * cadence / 60.0
        speed = np.linalg.norm(record["velocity"][:, :2], axis=1)
        for rule, value in ARMS:
            ate, still, ratio = scored(
                prediction, record, rule_speeds(rule, value, speed, steps_speed, t_mid)
            )
            rows.append(
                {
                    "set": label,
                    "group": group,
                    "walk": key,
                    "carry": str(seq.meta.get("carry", "unknown")),
                    "arm": arm_name(rule, value),
                    "ate": ate,
                    "still": still,
                    "ratio": ratio,
                    "confident": float(np.isfinite(cadence).mean()),
                }
            )
        print(
            f"{label} {key}: network {rows[-len(ARMS)]['ratio']:.2f}, floor 1 "
            f"{next(r['ratio'] for r in rows[-len(ARMS) :] if r['arm'] == 'floor 1'):.2f}",
            flush=True,
        )
    return rows


def _prediction_for_scoring(model, record: dict) -> Prediction:
    """A Prediction with the truth the scorer reads, around the cached velocities; each rule replaces
    its trajectory."""
    truth = Trajectory(record["truth_t_s"], record["truth_p_m"])
    span = record["span"]
    p = integrate_spans(record["t_s"], span[:, 0], span[:, 1], record["velocity"], truth.p_world_m[0])
    return Prediction(
        trajectory=Trajectory(record["t_s"], p),
        window_t_s=record["t_s"][span[:, 0]],
        velocity_m_s=record["velocity"],
        orientation_source="estimated",
        frame="ground_truth",
        warnings=[],
        features=None,
        truth=truth,
        truth_frame=str(record["truth_frame"]) or None,
        window_s=model.window / float(model.imu_rate_hz),
    )


def summary(rows: list[dict], by: str, extra: tuple[tuple[str, str], ...] = ()) -> list[str]:
    """Per ``by`` and arm: walks, mean ATE, over standing still, ``extra`` means (header, row key)
    after it, the ratio's range and how many walks lie within bounds."""
    groups: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for r in rows:
        groups[(r[by], r["arm"])].append(r)
    headers = "".join(f" {header} |" for header, _ in extra)
    lines = [
        f"| {by} | arm | walks | mean ATE | ATE / still |{headers} ratio (min-max) | in 0.8-1.2 |",
        "|---|---|--:|--:|--:|" + "--:|" * len(extra) + "---|--:|",
    ]
    for (name, arm), rs in groups.items():
        ate = np.mean([r["ate"] for r in rs])
        still = np.mean([r["still"] for r in rs])
        means = "".join(f" {np.mean([r[key] for r in rs]):.2f} |" for _, key in extra)
        ratios = np.array([r["ratio"] for r in rs])
        inside = int(((ratios >= LOW) & (ratios <= HIGH)).sum())
        lines.append(
            f"| {name} | {arm} | {len(rs)} | {ate:.2f} | {ate / still:.2f} |{means} "
            f"{ratios.min():.2f}-{ratios.max():.2f} | {inside} of {len(rs)} |"
        )
    return lines


def summary_sections(rows: list[dict], extra: tuple[tuple[str, str], ...] = ()) -> list[str]:
    """The report's "By set" and "By group" sections (``summary`` of each)."""
    return [
        "## By set",
        "",
        *summary(rows, "set", extra),
        "",
        "## By group",
        "",
        *summary(rows, "group", extra),
    ]


def probe_sets(data_root: Path, sets: list[str]):
    """``(paths, keys, groups, label)`` of each set a probe scores: the validation walkers of OxIOD,
    RIDI and Inria (``val``), the 30 new OxIOD walks (``new``)."""
    if "val" in sets:
        for dataset in (protocol.OXIOD, protocol.RIDI, protocol.INRIA):
            paths = protocol.split_paths(data_root, dataset, "val")
            keys = [str(p.relative_to(data_root)) for p in paths]
            yield paths, keys, [protocol.DATASET_LABELS[dataset]] * len(paths), "validation"
    if "new" in sets:
        root = data_root / protocol.DATA_FOLDERS[protocol.OXIOD]
        paths = [root / r for r in NEW_WALKS]
        keys = [r.removesuffix(".csv.xz") for r in NEW_WALKS]
        yield paths, keys, [group_of(r) for r in NEW_WALKS], "new OxIOD walks"


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--sets", nargs="+", default=["val", "new"], choices=["val", "new"])
    args = parse(parser)
    fit_path = CACHE / "step_length.json"
    if fit_path.exists():
        fit = json.loads(fit_path.read_text())
    else:
        fit = fit_step_length(args.data_root)
        CACHE.mkdir(parents=True, exist_ok=True)
        fit_path.write_text(json.dumps(fit))
    print("step length fit", fit, flush=True)
    model = load_model(CHECKPOINT)
    rows: list[dict] = []
    for paths, keys, groups, label in probe_sets(args.data_root, args.sets):
        rows += score_set(model, fit, paths, keys, groups, label)
    (CACHE / "rows.json").write_text(json.dumps(rows))
    lines = [
        "# Step-informed speed: a step-length floor under the network's speed (a probe, no training)",
        "",
        "Made by `python -m experiments.probe_step_speed` (its docstring: question, method). Phone only, the",
        f"default checkpoint (`{CHECKPOINT.name}`); ATE in m (RoNIN convention), ratio = predicted over "
        "walked distance.",
        "",
        "Step length fitted on the training walkers (OxIOD, RIDI, Inria training parts): "
        f"L = {fit['a']:.3f} + {fit['b']:.5f} x cadence (m, steps/min) over {fit['stretches']} "
        "stretches of 4 s, residual RMS "
        f"{fit['residual_rms_m']:.3f} m, cadence 5-95 % "
        f"{fit['cadence_range'][0]:.0f}-{fit['cadence_range'][1]:.0f}.",
        "",
        *summary_sections(rows),
        "",
        "## Per walk (ratio: network alone / floor 1 / bout 1; share of confident windows)",
        "",
        "| set | walk | carry | network | floor 1 | bout 1 | confident |",
        "|---|---|---|--:|--:|--:|--:|",
    ]
    by_walk: dict[str, dict[str, dict]] = defaultdict(dict)
    for r in rows:
        by_walk[r["walk"]][r["arm"]] = r
    for walk, arms in by_walk.items():
        first = arms["network alone"]
        lines.append(
            f"| {first['set']} | {walk} | {first['carry']} | {first['ratio']:.2f} | "
            f"{arms['floor 1']['ratio']:.2f} | "
            f"{arms['bout 1']['ratio']:.2f} | {first['confident']:.0%} |"
        )
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
