"""Can a stride-aware speed head on the default's frozen network read a long stride as long? (issue 54, 3)

Question: the default reads the ILC mall walks short even with the direction taken from the phone
(0.78-0.82 of the waypoint path, ``ilc_direction.md``: window speed 0.93-1.07 m/s against 1.12 m/s
true), and the issue finds that its implied step length moves only 0.39x as much as the true one. A
step-length floor from cadence alone did not help (``step_speed.md``). Does a small head, fitted in
seconds on the frozen network's outputs plus **stride features** from the step detector, read the speed
of walkers and floors that chose nothing closer to the truth, without hurting the dense validation sets?

Method (phone only, ``checkpoints/ronin_resnet-walking`` frozen, no retraining):

1. Every walk is predicted once as the product predicts it (``predict_trajectory`` defaults: ``auto``
   orientation, one cycled look, the body lock), keeping each window's velocity and the backbone's
   output averaged over time (512 channels); the step detector (``ftin.metrics.steps.detect_steps``)
   runs on the raw specific force and gyroscope; per window the world-frame vertical specific force's
   standard deviation, the horizontal one's rms and the rotation rate's rms are taken from the input the
   model saw. Cached under ``/tmp/stride_head`` (delete to recompute).
2. **A stretch** is a span of time: 4 s (dense truth) or one segment between two waypoints (ILC, 2 m or
   more, 2-15 s). Its features (``stretch_features``): log cadence (steps over the stretch), the step
   intervals' coefficient of variation, log vertical std, log horizontal rms, log rotation rms (means over
   the windows whose middle lies in it), log of the network's mean window speed, and the backbone
   channels' mean over those windows (reduced by PCA to ``PCS`` components fitted on the training
   stretches). A stretch is *walking* when it holds at least ``MIN_STEPS`` steps and the network's mean
   speed is at least ``MIN_NET_SPEED``.
3. **Target**: log of the true speed over the stretch. Dense truth: the mean over the stretch's windows of
   the true displacement over each window's span (the quantity the network was trained on). ILC: the
   segment's length over its duration (the walk between two marks taken as straight, as the scoring
   does). A log speed predicted from features that include log cadence is a log step length plus log
   cadence, and with log network speed among them it is a log speed scale: in a linear head the three
   parametrisations are the same model (Elyasi and Manduchi's step length is in it).
4. **Head**: ridge regression on standardised features, its penalty chosen by 5-fold cross-validation
   grouped by walk on the training stretches only; sample weights 1. Fitted on the default's own
   training walkers (``train_config.data`` of its JSON: OxIOD, RIDI, Inria and the new OxIOD walkers of
   ``NEW_TRAIN``, phone only) and, where the arm says so, the ILC training floors ``ILC_TRAIN_FLOORS``
   (F1-F3, every walk, their waypoint segments).
5. **Applied**: per window, the same features over the ``CONTEXT_S`` around its middle; where that
   context is walking, the window's velocity is scaled by ``exp(predicted log speed) / network mean
   speed`` (clipped to ``SCALE_RANGE``; direction kept), elsewhere left as is; integrated over the same
   spans as the app integrates (``ftin.infer.integrate_spans``).

Arms: ``network alone`` (the shipped default); ``stride only`` (stride features, the network's speed not
among them: a step-length model); ``speed + stride`` (stride features and log network speed);
``network + stride`` (those and the backbone's PCs); ``speed + stride, no ILC`` and
``network + stride, no ILC`` (the same fitted on dense truth alone: what the ILC segments add).

Scored: the held-out ILC floors ``ILC_HELD_OUT`` (B1, F4: every ``--every``-th walk; path ratio, ATE at
the waypoints, ``ftin.metrics.waypoints``; and the *speed ratio*: the predicted speeds integrated over the
marks' span over the marks' polyline, what the path ratio would be with a perfect direction); the new
OxIOD walks no shipped weight trained on (``NEW_VAL``: walker 4, iPhone 6 walks 7-9, Nexus 5 walk 8,
running walk 7, the pocket walk; ``FLOOR_DRIFT``: the ten long floor walks); the dense validation walks of
the default's JSON (OxIOD, RIDI, Inria), RoNIN-convention ATE and the distance ratio (``score``). The
training floors F1-F3 are reported too, as fitted (in-sample).

**The candidate** is the arm fitted with ILC whose grouped cross-validation RMSE (log speed, training
stretches) is lowest: chosen before any held-out walk is scored.

**The rule, written before any held-out number was read.** The candidate is adopted (for the retrain's
recipe or the product) when all of these hold:
- on each held-out ILC floor (B1 and F4) its median path ratio is closer to 1 than the network alone's by
  0.05 or more, and more walks lie in 0.85-1.15;
- on the new OxIOD walks (``NEW_VAL`` and ``FLOOR_DRIFT`` together) no fewer walks lie in 0.85-1.15 and
  the mean ATE is not worse by more than 5 %;
- on each dense validation set (OxIOD, RIDI, Inria) the mean ATE is not worse by more than 5 %.
Nothing is tuned after the held-out rows are read; a failed clause is reported as failed.

    nice -n 10 python -m experiments.probe_stride_head --out docs/results/probes/stride_head.md
"""

from __future__ import annotations

import json
import time
from collections import defaultdict
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from experiments.common import argument_parser, parse, weights_key, write_report
from ftin.checkpoint import LoadedModel, load_model
from ftin.data import Trajectory
from ftin.data.discovery import read_sequence
from ftin.data.loading import load_phone_only
from ftin.data.types import ImuSequence, Waypoints
from ftin.data.windows import window_view
from ftin.evaluate import score
from ftin.evaluate_sparse import RATIO_BAND
from ftin.files import DEFAULT_DATA_ROOT
from ftin.infer import Prediction, integrate_spans, predict_trajectory
from ftin.metrics.steps import detect_steps
from ftin.metrics.waypoints import marks_inside, score_waypoints
from ftin.protocol.stage_three import FLOOR_DRIFT, NEW_VAL
from ftin.protocol.stride_retrain import ILC_HELD_OUT, ILC_TRAIN_FLOORS

CHECKPOINT = Path("checkpoints/ronin_resnet-walking")
CACHE = Path("/tmp/stride_head")
STRETCH_S = 4.0  # dense training stretches
CONTEXT_S = 4.0  # what a window's scale is judged on (centred)
MIN_STEPS = 4
MIN_NET_SPEED = 0.2  # m/s
MIN_TRUE_SPEED = 0.3  # a dense stretch with less is standing, not a stride to learn
MIN_SEGMENT_M = 2.0
SEGMENT_S = (2.0, 15.0)
SCALE_RANGE = (0.5, 2.5)
PCS = 16
ALPHAS = (0.1, 1.0, 10.0, 100.0, 1000.0)
FOLDS = 5
WORSE_AT_MOST = 0.05
READING = "## Reading"  # the report's hand-written section from here on survives a rerun
STRIDE = ("log cadence", "interval cv", "log vertical std", "log horizontal rms", "log rotation rms")
ARMS: dict[str, tuple[str, bool]] = {  # arm -> (features, with ILC)
    "stride only": ("stride", True),
    "speed + stride": ("speed", True),
    "network + stride": ("network", True),
    "speed + stride, no ILC": ("speed", False),
    "network + stride, no ILC": ("network", False),
}


# --- one walk, predicted once -----------------------------------------------------------------------


def window_amplitudes(imu_world: np.ndarray, starts: np.ndarray, window: int) -> np.ndarray:
    """``(M, 3)`` per window: vertical specific force std, horizontal rms about its mean, rotation rms."""
    view = window_view(imu_world, window)[starts].astype(np.float64)  # (M, 6, L)
    gyro, acc = view[:, 0:3], view[:, 3:6]
    vertical = acc[:, 2].std(axis=1)
    horizontal = acc[:, 0:2] - acc[:, 0:2].mean(axis=2, keepdims=True)
    horizontal_rms = np.sqrt(np.mean(np.sum(horizontal**2, axis=1), axis=1))
    rotation = np.sqrt(np.mean(np.sum(gyro**2, axis=1), axis=1))
    return np.column_stack([vertical, horizontal_rms, rotation])


def walk_record(loaded: LoadedModel, seq: ImuSequence, key: str) -> dict:
    """What every arm needs of one walk (module docstring, step 1), cached."""
    cache = CACHE / weights_key(loaded) / (key.replace("/", "__").replace(" ", "_") + ".npz")
    if cache.exists():
        with np.load(cache, allow_pickle=False) as data:
            return dict(data)
    prediction = predict_trajectory(loaded, seq, keep_prepared=False, return_features=True)
    pooled = prediction.features["backbone"].mean(axis=2).astype(np.float32)  # (M, 512)
    steps = detect_steps(seq.t_s, seq.acc_m_s2, seq.gyro_rad_s)
    record = {
        "t_s": prediction.trajectory.t_s,
        "span_t_s": prediction.span_t_s,
        "velocity": prediction.velocity_m_s,
        "pooled": pooled,
        "amplitudes": window_amplitudes(prediction.imu_world, prediction.starts, loaded.window),
        "step_t": steps.t_s,
        "truth_frame": np.array(prediction.truth_frame or ""),
    }
    if prediction.truth is not None:
        record["truth_t_s"], record["truth_p_m"] = prediction.truth.t_s, prediction.truth.p_world_m
    if seq.waypoints is not None:
        record["marks_t_s"], record["marks_xy_m"] = seq.waypoints.t_s, seq.waypoints.xy_map_m
    cache.parent.mkdir(parents=True, exist_ok=True)
    np.savez(cache, **record)
    return record


# --- stretches and their features -------------------------------------------------------------------


def stretch_features(record: dict, lo: np.ndarray, hi: np.ndarray) -> dict[str, np.ndarray]:
    """Per stretch ``[lo, hi]`` (module docstring, step 2): the stride features ``(S, 5)``, log network
    speed ``(S,)``, pooled backbone ``(S, 512)``, step count and whether it is walking."""
    t_mid = record["span_t_s"].mean(axis=1)
    a, b = np.searchsorted(t_mid, lo), np.searchsorted(t_mid, hi, side="right")
    n = np.maximum(b - a, 1)

    def mean_of(values: np.ndarray) -> np.ndarray:
        c = np.concatenate([np.zeros((1, *values.shape[1:])), np.cumsum(values, axis=0)])
        return (c[b] - c[a]) / n.reshape(-1, *([1] * (values.ndim - 1)))

    speed = np.linalg.norm(record["velocity"][:, :2], axis=1)
    net_speed = mean_of(speed)
    amplitudes = mean_of(record["amplitudes"])
    pooled = mean_of(record["pooled"].astype(np.float64))
    step_t = record["step_t"]
    sa, sb = np.searchsorted(step_t, lo), np.searchsorted(step_t, hi, side="right")
    count = sb - sa
    cadence = np.full(len(lo), np.nan)
    cv = np.full(len(lo), np.nan)
    for k in np.flatnonzero(count >= 2):
        gaps = np.diff(step_t[sa[k] : sb[k]])
        cadence[k] = 60.0 / gaps.mean()
        cv[k] = gaps.std() / gaps.mean()
    walking = (count >= MIN_STEPS) & (net_speed >= MIN_NET_SPEED) & (b > a)
    stride = np.column_stack(
        [
            np.log(np.where(walking, cadence, 100.0)),
            np.where(walking, cv, 0.0),
            *np.log(amplitudes.T + 1e-3).reshape(3, -1),
        ]
    )
    return {
        "stride": stride,
        "log_speed": np.log(np.maximum(net_speed, 1e-3)),
        "pooled": pooled,
        "walking": walking,
    }


def dense_stretches(record: dict) -> tuple[dict, np.ndarray]:
    """4-s stretches of a dense-truth walk: features and log true speed (NaN where not a stride)."""
    t_truth, p = record["truth_t_s"], record["truth_p_m"]
    lo = np.arange(t_truth[0], t_truth[-1] - STRETCH_S, STRETCH_S)
    hi = lo + STRETCH_S
    f = stretch_features(record, lo, hi)
    span = record["span_t_s"]
    ends = [np.column_stack([np.interp(span[:, j], t_truth, p[:, i]) for i in (0, 1)]) for j in (0, 1)]
    true_speed = np.linalg.norm(ends[1] - ends[0], axis=1) / np.maximum(span[:, 1] - span[:, 0], 1e-6)
    t_mid = span.mean(axis=1)
    a, b = np.searchsorted(t_mid, lo), np.searchsorted(t_mid, hi, side="right")
    c = np.concatenate([[0.0], np.cumsum(true_speed)])
    mean_true = (c[b] - c[a]) / np.maximum(b - a, 1)
    ok = f["walking"] & (mean_true >= MIN_TRUE_SPEED)
    return f, np.where(ok, np.log(np.maximum(mean_true, 1e-3)), np.nan)


def ilc_stretches(record: dict) -> tuple[dict, np.ndarray]:
    """The segments between consecutive waypoints (2 m or more, 2-15 s) inside the predicted span."""
    t0, t1 = record["t_s"][0], record["t_s"][-1]
    t, xy = record["marks_t_s"], record["marks_xy_m"]
    keep = (t >= t0) & (t <= t1)
    t, xy = t[keep], xy[keep]
    length, duration = np.linalg.norm(np.diff(xy, axis=0), axis=1), np.diff(t)
    f = stretch_features(record, t[:-1], t[1:])
    ok = f["walking"] & (length >= MIN_SEGMENT_M) & (duration >= SEGMENT_S[0]) & (duration <= SEGMENT_S[1])
    return f, np.where(ok, np.log(np.maximum(length / np.maximum(duration, 1e-6), 1e-3)), np.nan)


# --- the head ---------------------------------------------------------------------------------------


class Head:
    """Ridge regression of log speed on one arm's features (module docstring, step 4)."""

    def __init__(self, kind: str) -> None:
        self.kind = kind

    def design(self, f: dict) -> np.ndarray:
        columns = [f["stride"]]
        if self.kind in ("speed", "network"):
            columns.append(f["log_speed"][:, None])
        if self.kind == "network":
            columns.append((f["pooled"] - self.pca_mean) @ self.pca_axes.T)
        return np.concatenate(columns, axis=1)

    def fit(self, f: dict, y: np.ndarray, groups: np.ndarray) -> Head:
        if self.kind == "network":
            centred = f["pooled"] - f["pooled"].mean(axis=0)
            self.pca_mean = f["pooled"].mean(axis=0)
            self.pca_axes = np.linalg.svd(centred, full_matrices=False)[2][:PCS]
        x = self.design(f)
        self.mu, self.sd = x.mean(axis=0), x.std(axis=0) + 1e-9
        folds = np.unique(groups) % FOLDS
        fold_of = folds[np.searchsorted(np.unique(groups), groups)]
        self.cv_rmse = {}
        for alpha in ALPHAS:
            residuals = []
            for k in range(FOLDS):
                train, test = fold_of != k, fold_of == k
                w, c = _ridge((x[train] - self.mu) / self.sd, y[train], alpha)
                residuals.append(y[test] - ((x[test] - self.mu) / self.sd @ w + c))
            self.cv_rmse[alpha] = float(np.sqrt(np.mean(np.concatenate(residuals) ** 2)))
        self.alpha = min(self.cv_rmse, key=self.cv_rmse.get)
        self.w, self.c = _ridge((x - self.mu) / self.sd, y, self.alpha)
        self.fit_rmse = float(np.sqrt(np.mean((y - self.predict(f)) ** 2)))
        return self

    def predict(self, f: dict) -> np.ndarray:
        return (self.design(f) - self.mu) / self.sd @ self.w + self.c


def _ridge(x: np.ndarray, y: np.ndarray, alpha: float) -> tuple[np.ndarray, float]:
    c = y.mean()
    w = np.linalg.solve(x.T @ x + alpha * np.eye(x.shape[1]), x.T @ (y - c))
    return w, float(c)


def pooled_stretches(items: Iterable[tuple[str, dict, np.ndarray]]) -> tuple[dict, np.ndarray, np.ndarray]:
    """Stack the usable stretches of many walks: features, targets, walk index."""
    fs, ys, gs = [], [], []
    for g, (_, f, y) in enumerate(items):
        ok = np.isfinite(y)
        fs.append({k: v[ok] for k, v in f.items()})
        ys.append(y[ok])
        gs.append(np.full(ok.sum(), g))
    joined = {k: np.concatenate([f[k] for f in fs]) for k in fs[0]}
    return joined, np.concatenate(ys), np.concatenate(gs)


# --- applied and scored -----------------------------------------------------------------------------


def scaled_velocity(record: dict, head: Head | None) -> np.ndarray:
    """The window velocities with the head's speed where the context is walking (step 5)."""
    velocity = record["velocity"]
    if head is None:
        return velocity
    t_mid = record["span_t_s"].mean(axis=1)
    f = stretch_features(record, t_mid - CONTEXT_S / 2, t_mid + CONTEXT_S / 2)
    scale = np.clip(np.exp(head.predict(f) - f["log_speed"]), *SCALE_RANGE)
    return velocity * np.where(f["walking"], scale, 1.0)[:, None]


def trajectory_of(record: dict, velocity: np.ndarray) -> Trajectory:
    t = record["t_s"]
    span = np.searchsorted(t, record["span_t_s"])
    start = record["truth_p_m"][0] if "truth_p_m" in record else np.zeros(3)
    return Trajectory(t, integrate_spans(t, span[:, 0], span[:, 1], velocity, start))


def dense_row(record: dict, velocity: np.ndarray, window_s: float) -> dict:
    """ATE (RoNIN convention) and distance ratio, as ``score`` gives the product's prediction."""
    prediction = Prediction(
        trajectory=trajectory_of(record, velocity),
        window_t_s=record["span_t_s"].mean(axis=1),
        velocity_m_s=velocity,
        orientation_source="estimated",
        frame="ground_truth",
        warnings=[],
        features=None,
        span_t_s=record["span_t_s"],
        truth=Trajectory(record["truth_t_s"], record["truth_p_m"]),
        truth_frame=str(record["truth_frame"]) or None,
        window_s=window_s,
    )
    values = score(prediction).metrics.values
    return {"ate": values["ate"], "ratio": values.get("distance_ratio"), "speed_ratio": None}


def ilc_row(record: dict, velocity: np.ndarray) -> dict:
    """Path ratio and ATE at the waypoints; speed ratio: speeds integrated over the marks' span."""
    marks = Waypoints(record["marks_t_s"], record["marks_xy_m"])
    trajectory = trajectory_of(record, velocity)
    m = score_waypoints(trajectory, marks)
    inside = marks_inside(trajectory, marks)
    span = record["span_t_s"]
    covered = np.clip(np.minimum(span[:, 1], inside.t_s[-1]) - np.maximum(span[:, 0], inside.t_s[0]), 0, None)
    # windows overlap: each instant lies in (window / stride) spans, so each counts stride / window of it
    weight = _stride_s(span) / np.median(span[:, 1] - span[:, 0])
    distance = float(np.sum(np.linalg.norm(velocity[:, :2], axis=1) * covered) * weight)
    return {
        "ate": m.ate_m,
        "ratio": m.path_ratio,
        "speed_ratio": distance / m.truth_path_m if m.truth_path_m >= 1.0 else None,
    }


def _stride_s(span: np.ndarray) -> float:
    return float(np.median(np.diff(span[:, 0]))) if len(span) > 1 else float(span[0, 1] - span[0, 0])


# --- the walks --------------------------------------------------------------------------------------


def ilc_walks(data_root: Path, floors: Iterable[str], every: int) -> list[tuple[str, Path]]:
    return [
        (str(p.relative_to(data_root)), p)
        for f in floors
        for p in sorted((data_root / "ilc" / "site1" / f).glob("*.txt.xz"))[::every]
    ]


def records_of(
    loaded: LoadedModel, data_root: Path, walks: list[tuple[str, Path]], phone_only: bool, label: str
):
    """``(key, record)`` of each walk, read only when its record is not cached."""
    out = []
    started = time.monotonic()
    for k, (key, path) in enumerate(walks):
        cached = CACHE / weights_key(loaded) / (key.replace("/", "__").replace(" ", "_") + ".npz")
        seq = None
        if not cached.exists():
            seq = load_phone_only([path], label)[0] if phone_only else read_sequence(path)
        out.append((key, walk_record(loaded, seq, key)))
        if (k + 1) % 25 == 0 or k + 1 == len(walks):
            print(
                f"  {label}: {k + 1} of {len(walks)} walks ({time.monotonic() - started:.0f} s)", flush=True
            )
    return out


def dense_walks(data_root: Path, relatives: Iterable[str]) -> list[tuple[str, Path]]:
    return [(r, data_root / r) for r in relatives]


def group_rows(records: list[tuple[str, dict]], heads: dict[str, Head | None], sparse: bool, window_s: float):
    """Per arm, one row per walk."""
    rows: dict[str, list[dict]] = defaultdict(list)
    for key, record in records:
        for arm, head in heads.items():
            velocity = scaled_velocity(record, head)
            row = ilc_row(record, velocity) if sparse else dense_row(record, velocity, window_s)
            rows[arm].append({"walk": key, **row})
    return rows


def summary(rows: list[dict]) -> dict:
    ratios = np.array([r["ratio"] for r in rows if r["ratio"] is not None])
    speed = [r["speed_ratio"] for r in rows if r["speed_ratio"] is not None]
    low, high = RATIO_BAND
    return {
        "walks": len(rows),
        "median_ratio": float(np.median(ratios)),
        "in_band": int(((ratios >= low) & (ratios <= high)).sum()),
        "with_ratio": len(ratios),
        "mean_ate": float(np.mean([r["ate"] for r in rows if r["ate"] is not None])),
        "median_speed_ratio": float(np.median(speed)) if speed else None,
        "speed_in_band": sum(low <= x <= high for x in speed),
    }


def stride_sensitivity(items: list[tuple[str, dict, np.ndarray]], heads: dict[str, Head | None]) -> dict:
    """Per arm over the walking stretches of ``items``: the median read / true speed and the slope of log
    read speed on log true speed (1: a stride twice as long reads twice as fast; the issue found the
    network's implied step length moving 0.39x as much as the true one)."""
    f, y, _ = pooled_stretches(items)
    out = {}
    for arm, head in heads.items():
        read = f["log_speed"] if head is None else head.predict(f)
        out[arm] = {
            "stretches": len(y),
            "median_read_over_true": float(np.median(np.exp(read - y))),
            "slope": float(np.polyfit(y, read, 1)[0]),
        }
    return out


def judge(results: dict[str, dict[str, dict]], candidate: str) -> list[str]:
    """The docstring's rule, clause by clause, for ``candidate`` against ``network alone``."""
    base, lines, passed = "network alone", [], True

    def clause(text: str, ok: bool) -> None:
        nonlocal passed
        passed &= ok
        lines.append(f"- {'pass' if ok else '**fail**'}: {text}")

    for floor in ILC_HELD_OUT:
        b, c = results[f"ILC {floor}"][base], results[f"ILC {floor}"][candidate]
        moved = abs(b["median_ratio"] - 1) - abs(c["median_ratio"] - 1)
        clause(
            f"ILC {floor} median path ratio {b['median_ratio']:.3f} -> {c['median_ratio']:.3f} "
            f"(closer to 1 by {moved:+.3f}, needs >= 0.05), in band {b['in_band']} -> {c['in_band']} "
            "(needs more)",
            moved >= 0.05 and c["in_band"] > b["in_band"],
        )
    b, c = results["new OxIOD, all"][base], results["new OxIOD, all"][candidate]
    clause(
        f"new OxIOD walks in band {b['in_band']} -> {c['in_band']} (no fewer), "
        f"mean ATE {b['mean_ate']:.2f} -> "
        f"{c['mean_ate']:.2f} m ({c['mean_ate'] / b['mean_ate'] - 1:+.1%}, at most +5 %)",
        c["in_band"] >= b["in_band"] and c["mean_ate"] <= (1 + WORSE_AT_MOST) * b["mean_ate"],
    )
    for group in ("OxIOD validation", "RIDI validation", "Inria validation"):
        b, c = results[group][base], results[group][candidate]
        clause(
            f"{group} mean ATE {b['mean_ate']:.3f} -> {c['mean_ate']:.3f} m "
            f"({c['mean_ate'] / b['mean_ate'] - 1:+.1%}, at most +5 %)",
            c["mean_ate"] <= (1 + WORSE_AT_MOST) * b["mean_ate"],
        )
    return [f"**{'Adopted' if passed else 'Not adopted'}** (candidate `{candidate}`):", "", *lines]


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--every", type=int, default=1, help="every k-th walk of a held-out ILC floor")
    parser.add_argument("--train-every", type=int, default=1, help="every k-th walk of a training floor")
    parser.add_argument("--fit-only", action="store_true", help="fit only; score nothing held out")
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    started = time.monotonic()
    loaded = load_model(CHECKPOINT)
    window_s = loaded.window / float(loaded.imu_rate_hz)
    recipe = json.loads(CHECKPOINT.with_suffix(".json").read_text())["train_config"]
    root = args.data_root

    dense_train = records_of(loaded, root, dense_walks(root, recipe["data"]), True, "dense training walks")
    ilc_train = records_of(
        loaded, root, ilc_walks(root, ILC_TRAIN_FLOORS, args.train_every), False, "ILC F1-F3"
    )
    dense_items = [(k, *dense_stretches(r)) for k, r in dense_train]
    ilc_items = [(k, *ilc_stretches(r)) for k, r in ilc_train]
    heads: dict[str, Head | None] = {"network alone": None}
    fits: dict[str, dict] = {}
    for arm, (kind, with_ilc) in ARMS.items():
        f, y, g = pooled_stretches(dense_items + (ilc_items if with_ilc else []))
        t0 = time.perf_counter()
        heads[arm] = Head(kind).fit(f, y, g)
        fits[arm] = {
            "seconds": time.perf_counter() - t0,
            "stretches": len(y),
            "ilc_stretches": int(sum(np.isfinite(y_).sum() for _, _, y_ in ilc_items)) if with_ilc else 0,
            "alpha": heads[arm].alpha,
            "cv_rmse": heads[arm].cv_rmse[heads[arm].alpha],
            "fit_rmse": heads[arm].fit_rmse,
        }
        print(f"{arm}: {fits[arm]}", flush=True)
    candidate = min((a for a, (_, ilc) in ARMS.items() if ilc), key=lambda a: fits[a]["cv_rmse"])
    print(f"candidate (lowest cross-validation RMSE with ILC): {candidate}", flush=True)
    # What the heads read the training stretches' speed as (log ratio to the truth), per source.
    bias = {}
    for source, items in (("dense training", dense_items), ("ILC F1-F3", ilc_items)):
        f, y, _ = pooled_stretches(items)
        bias[source] = {arm: float(np.median(np.exp(f["log_speed"] - y))) if h is None else
                        float(np.median(np.exp(h.predict(f) - y))) for arm, h in heads.items()}  # fmt: skip
    if args.fit_only:
        print(json.dumps(bias, indent=1))
        return

    val_relatives = [r for r in recipe["val"] if r not in NEW_VAL]
    sets = {
        "ILC F1-F3 (fitted on)": (ilc_train, True),
        **{
            f"ILC {floor}": (
                records_of(loaded, root, ilc_walks(root, (floor,), args.every), False, floor),
                True,
            )
            for floor in ILC_HELD_OUT
        },
        "new OxIOD, NEW_VAL": (records_of(loaded, root, dense_walks(root, NEW_VAL), True, "NEW_VAL"), False),
        "new OxIOD, floor walks": (
            records_of(loaded, root, dense_walks(root, FLOOR_DRIFT), True, "FLOOR_DRIFT"),
            False,
        ),
    }
    for dataset, prefix in (("OxIOD", "oxiod/"), ("RIDI", "ridi/"), ("Inria", "inria")):
        relatives = [r for r in val_relatives if r.startswith(prefix)]
        sets[f"{dataset} validation"] = (
            records_of(loaded, root, dense_walks(root, relatives), True, dataset),
            False,
        )
    rows = {name: group_rows(recs, heads, sparse, window_s) for name, (recs, sparse) in sets.items()}
    rows["new OxIOD, all"] = {
        arm: rows["new OxIOD, NEW_VAL"][arm] + rows["new OxIOD, floor walks"][arm] for arm in heads
    }
    results = {name: {arm: summary(r) for arm, r in by_arm.items()} for name, by_arm in rows.items()}
    held_out = {
        **{f"ILC {floor}": (sets[f"ILC {floor}"][0], ilc_stretches) for floor in ILC_HELD_OUT},
        "new OxIOD, all": (
            sets["new OxIOD, NEW_VAL"][0] + sets["new OxIOD, floor walks"][0],
            dense_stretches,
        ),
    }
    sensitivity = {
        name: stride_sensitivity([(k, *stretches(r)) for k, r in recs], heads)
        for name, (recs, stretches) in held_out.items()
    }
    CACHE.mkdir(parents=True, exist_ok=True)
    (CACHE / "rows.json").write_text(
        json.dumps({"rows": rows, "fits": fits, "bias": bias, "sensitivity": sensitivity})
    )
    minutes = (time.monotonic() - started) / 60
    lines = report_lines(args, results, fits, bias, sensitivity, candidate, minutes)
    if args.out is not None and args.out.exists():  # the reading, written by hand, stays
        text = args.out.read_text(encoding="utf-8")
        if READING in text:
            lines += ["", READING + text.split(READING, 1)[1].rstrip("\n")]
    write_report(args.out, lines)


def report_lines(
    args, results: dict, fits: dict, bias: dict, sensitivity: dict, candidate: str, minutes: float
) -> list[str]:
    lines = [
        "# A stride-aware speed head on the default's frozen network (issue 54, item 3)",
        "",
        f"Made by `nice -n 10 python -m experiments.probe_stride_head --every {args.every} --out {args.out}` "
        f"({minutes:.0f} min this run, two shared cores; model outputs cached under `{CACHE}`). "
        "Its docstring: "
        "method, arms and the rule, written before any held-out number was read. Phone only, "
        f"`{CHECKPOINT.name}` frozen.",
        "",
        "## The heads (fitted on training walkers only)",
        "",
        "| arm | stretches (of them ILC segments) | ridge penalty | cross-validation RMSE (log speed) "
        "| fit RMSE | fit cost (s) | median read / true speed: dense training | ILC F1-F3 |",
        "|---|--:|--:|--:|--:|--:|--:|--:|",
        f"| network alone | — | — | — | — | — | {bias['dense training']['network alone']:.3f} "
        f"| {bias['ILC F1-F3']['network alone']:.3f} |",
    ]
    for arm, fit in fits.items():
        lines.append(
            f"| {arm} | {fit['stretches']} ({fit['ilc_stretches']}) | {fit['alpha']:g} "
            f"| {fit['cv_rmse']:.3f} "
            f"| {fit['fit_rmse']:.3f} | {fit['seconds']:.2f} | {bias['dense training'][arm]:.3f} "
            f"| {bias['ILC F1-F3'][arm]:.3f} |"
        )
    lines += [
        "",
        f"Candidate (lowest cross-validation RMSE among the arms fitted with ILC): `{candidate}`.",
        "",
        "## By group",
        "",
        "Path ratio: ILC, the predicted path between the first and last waypoint over the waypoints' "
        "polyline; "
        "dense, the distance ratio (predicted path over the walked distance). Speed ratio (ILC only): the "
        "predicted speeds integrated over the marks' span over the polyline (the path ratio with a perfect "
        "direction). ATE: ILC at the waypoints after one 2-D rotation + translation; dense, RoNIN "
        "convention.",
        "",
        "| group | arm | walks | median path ratio | in 0.85-1.15 | median speed ratio | in 0.85-1.15 "
        "| mean ATE (m) |",
        "|---|---|--:|--:|--:|--:|--:|--:|",
    ]
    for group, by_arm in results.items():
        for arm, s in by_arm.items():
            speed = (
                "— | —"
                if s["median_speed_ratio"] is None
                else f"{s['median_speed_ratio']:.3f} | {s['speed_in_band']} of {s['walks']}"
            )
            lines.append(
                f"| {group} | {arm} | {s['walks']} | {s['median_ratio']:.3f} "
                f"| {s['in_band']} of {s['with_ratio']} "
                f"| {speed} | {s['mean_ate']:.3f} |"
            )
    lines += [
        "",
        "## Does a long stride read long? (held-out walking stretches; not part of the rule)",
        "",
        "Slope: of log read speed on log true speed over the stretches (4 s, or one ILC segment between two "
        "marks); 1 reads a stride twice as long as twice as fast, 0 reads every stride alike.",
        "",
        "| group | arm | stretches | median read / true speed | slope |",
        "|---|---|--:|--:|--:|",
    ]
    for group, by_arm in sensitivity.items():
        for arm, s in by_arm.items():
            lines.append(
                f"| {group} | {arm} | {s['stretches']} | {s['median_read_over_true']:.3f} "
                f"| {s['slope']:.2f} |"
            )
    lines += ["", "## Against the rule", "", *judge(results, candidate)]
    return lines


if __name__ == "__main__":
    main()
