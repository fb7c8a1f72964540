"""Does the gait's own axis know the walking direction where the network does not? (issue 50, item 2)

Question: EqNIO's canonical yaw frame (ICLR 2025) gives the network its input turned into a frame that
the input itself defines, so the network learns the direction relative to the motion, not to the world.
Before a training arm, the frame's premise can be read without training: does a yaw axis read from a
window's own specific force lie along the true walking direction (up to its sign) on the damped carries
where the default's direction is off (the Inria AR, swinging and running-in-hand walks: 36-87 deg), and
does giving the default's velocity that axis (its sign and speed kept) lower the heading error?

Axes (per window of the default, in the world frame the network reads, gravity along z; an analysis span
of ``SPANS`` seconds centred on the window):
- ``pca``: the principal axis of the horizontal specific force (mean removed): the fore-aft sway of
  walking is larger than the lateral one in a hand-held carry;
- ``vertical``: the principal axis of the horizontal force's cross-covariance with the vertical force
  over lags up to 0.3 s: the fore-aft force beats with the vertical bounce at the step rate, the
  lateral sway at half of it (uDirect, Hoseinitabatabaei et al. 2011, reads the fore-aft axis so).
Arms (the default's velocity, as the app returns it, then): ``network`` (unchanged), ``<axis>-<span>``
(the velocity turned onto the axis, the side nearer the network's kept, its speed kept) and
``<axis>-<span>-gated`` (only where the network is within ``GATE_DEG`` of the axis line).

Walks, phone only (``auto``, as the app runs): the choice reads every 4th of the default's training
walks (OxIOD, RIDI, Inria); the held-out groups (the dense validation walks of the stride judge: OxIOD,
RIDI, every 4th Inria; the new OxIOD walkers and phones; the long floor walks) are read for the network
and the chosen arm only. Measures: the issue's heading error (10-s windows, start-aligned; median per
walk, then the median of walks), mean ATE, and per window the axis's angle to the true mean velocity
mod 180 deg against the network's (windows where the truth moves 0.5 m/s or more).

The rule, written before any walk was read: the arm with the lowest median heading error on the training
walks is chosen (none, if no arm beats ``network`` there by 1 deg). It is **adopted** into inference when,
held out, Inria validation's median heading error is lower by 2 deg or more, the new walkers' and the long
floor walks' is not higher by more than 1 deg, and no dense validation set's nor the new walkers' mean ATE
is worse by more than 5 %. Apart from the rule (it changes nothing), the axis's window error on the walks
where the network is off by more than 15 deg says whether an EqNIO-style frame is worth a training arm:
worth it when the axis line is 10 deg or more nearer the truth than the network there.

    nice -n 10 python -m experiments.probe_gait_axis --out docs/results/probes/gait_axis.md
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from experiments.common import argument_parser, parse, write_report
from experiments.judge_stride_retrain import DEFAULT, NEW_WALKERS, new_walk_groups
from experiments.probe_ilc_direction import look_spread, looks
from experiments.probe_new_oxiod_walks import NEW_WALKS, group_of
from experiments.probe_sparse_truth import dense_validation
from ftin import protocol
from ftin.checkpoint import load_model
from ftin.data.gaps import holes_of
from ftin.data.loading import load_phone_only
from ftin.data.types import Trajectory
from ftin.evaluate import score
from ftin.files import DEFAULT_DATA_ROOT
from ftin.infer import Prediction, integrate_spans, outside_holes, predict_trajectory

RUNS = Path("runs/probes/gait_axis")
SPANS = (1.0, 2.0)  # s
AXES = ("pca", "vertical")
LAG_S = 0.3
GATE_DEG = 30.0
MOVING_M_S = 0.5
CHOICE_GAIN_DEG = 1.0
INRIA_GAIN_DEG = 2.0
HELD_LOSS_DEG = 1.0
WORSE_AT_MOST = 0.05
NETWORK_OFF_DEG = 15.0
FRAME_WORTH_DEG = 10.0


def arm_names() -> list[str]:
    return ["network"] + [f"{a}-{s:g}{g}" for a in AXES for s in SPANS for g in ("", "-gated")]


def gait_axis(force: np.ndarray, centres: np.ndarray, half: int, kind: str, lag: int) -> np.ndarray:
    """``(M, 2)`` unit yaw axes (sign arbitrary) of the spans ``centre ± half`` of ``force`` (N, 3)."""
    axes = np.zeros((len(centres), 2))
    for i, c in enumerate(centres):
        a = force[max(0, c - half) : c + half]
        h, z = a[:, :2] - a[:, :2].mean(axis=0), a[:, 2] - a[:, 2].mean()
        if kind == "pca":
            m = h.T @ h
        else:  # cross-covariance with the vertical force over lags -lag..lag
            n = len(a)
            cross = np.stack([h[max(0, -k) : n - max(0, k)].T @ z[max(0, k) : n - max(0, -k)]
                              for k in range(-lag, lag + 1)])  # fmt: skip
            m = cross.T @ cross
        axes[i] = np.linalg.eigh(m)[1][:, -1]
    return axes


def onto_axis(velocity: np.ndarray, axes: np.ndarray, gated: bool) -> np.ndarray:
    """The horizontal velocity turned onto each axis, the side nearer the network's, its speed kept."""
    v = velocity.copy()
    h = velocity[:, :2]
    speed = np.linalg.norm(h, axis=1)
    side = np.sign(np.sum(h * axes, axis=1))
    side[side == 0] = 1.0
    turned = axes * (side * speed)[:, None]
    if gated:
        cosine = np.abs(np.sum(h * axes, axis=1)) / np.maximum(speed, 1e-9)
        keep = cosine < np.cos(np.radians(GATE_DEG))
        turned[keep] = h[keep]
    v[:, :2] = turned
    return v


def with_velocity(prediction: Prediction, velocity: np.ndarray) -> Prediction:
    """``prediction`` integrated again from ``velocity`` over the same spans."""
    t = prediction.trajectory.t_s
    a, b = (np.searchsorted(t, prediction.span_t_s[:, k]) for k in (0, 1))
    holes = holes_of(prediction.prepared.seq)
    start = prediction.trajectory.p_world_m[0]
    p = integrate_spans(t, *outside_holes(t, a, b, velocity, holes), start)
    trajectory = Trajectory(t, p, prediction.trajectory.q_world_body_wxyz)
    return dataclasses.replace(prediction, velocity_m_s=velocity, trajectory=trajectory)


def angle_deg(u: np.ndarray, v: np.ndarray, line: bool) -> np.ndarray:
    cosine = np.sum(u * v, axis=1) / np.maximum(np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1), 1e-9)
    cosine = np.abs(cosine) if line else cosine
    return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))


def moving_median(values: np.ndarray, moving: np.ndarray) -> float | None:
    return float(np.median(values[moving])) if moving.any() else None


def walk_rows(loaded, rel: str, seq, arms: list[str]) -> dict[str, dict]:
    """Each arm's row of one walk (module docstring: measures)."""
    prediction = predict_trajectory(loaded, seq)
    imu, rate = prediction.imu_world, prediction.prepared.rate_hz
    t = prediction.trajectory.t_s
    a, b = (np.searchsorted(t, prediction.span_t_s[:, k]) for k in (0, 1))
    centres = (a + b) // 2
    gt = prediction.truth.p_world_m
    true_v = (gt[b, :2] - gt[a, :2]) / np.maximum(t[b] - t[a], 1e-9)[:, None]
    moving = np.linalg.norm(true_v, axis=1) >= MOVING_M_S
    network_off = angle_deg(prediction.velocity_m_s[:, :2], true_v, line=False)
    network_line = angle_deg(prediction.velocity_m_s[:, :2], true_v, line=True)
    rows = {}
    for arm in arms:
        if arm == "looks":  # the quarter-turn looks' disagreement: what exact equivariance could change
            rows[arm] = {"spread": look_spread(looks(loaded, imu, prediction.starts))}
            continue
        if arm == "network":
            velocity, axis_error = prediction.velocity_m_s, None
        else:
            kind, span, *gated = arm.split("-")
            axes = gait_axis(imu[:, 3:6], centres, int(float(span) * rate / 2), kind, int(LAG_S * rate))
            velocity = onto_axis(prediction.velocity_m_s, axes, bool(gated))
            axis_error = angle_deg(axes, true_v, line=True)
        again = with_velocity(prediction, velocity)
        values, started = score(again).metrics.values, score(again, "start").metrics.values
        rows[arm] = {
            "walk": rel.removesuffix(".csv.xz").removesuffix(".csv"),
            "group": group_of(rel) if rel.startswith(("multi", "large")) else rel.split("/")[0],
            "ate": values["ate"],
            "ratio": values.get("distance_ratio"),
            "heading": started.get("heading_error_10s_deg"),
            "heading_late": started.get("heading_error_10s_after_2min_deg"),
            "network_off": moving_median(network_off, moving),
            "network_line_off": moving_median(network_line, moving),
            "axis_line_off": None if axis_error is None else moving_median(axis_error, moving),
        }
    return rows


def cached(name: str, walks: list[tuple[str, object]], arms: list[str], loaded) -> list[dict[str, dict]]:
    path = RUNS / f"{name}.json"
    done = json.loads(path.read_text()) if path.exists() else {}
    for rel, seq in walks:
        missing = [a for a in arms if a not in done.get(rel, {})]
        if missing:
            print(f"{name}: {rel}", flush=True)
            done.setdefault(rel, {}).update(walk_rows(loaded, rel, seq, missing))
            RUNS.mkdir(parents=True, exist_ok=True)
            path.write_text(json.dumps(done))
    return [done[rel] for rel, _ in walks]


def label(walk: str) -> str:
    """A walk's short name: an OxIOD walk by its folder and file, any other by its file."""
    parts = walk.split("/")
    return f"{parts[-3]} {parts[-1]}" if len(parts) >= 4 and parts[-2] == "syn" else parts[-1]


def median_of(rows: list[dict], arm: str, key: str) -> float:
    values = [r[arm][key] for r in rows if r[arm][key] is not None]
    return float(np.median(values)) if values else float("nan")


def mean_of(rows: list[dict], arm: str, key: str) -> float:
    return float(np.mean([r[arm][key] for r in rows]))


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    started = time.monotonic()
    loaded = load_model(DEFAULT)
    recipe = json.loads(DEFAULT.with_suffix(".json").read_text())["train_config"]
    train_rel = recipe["data"][::4]
    train = list(
        zip(train_rel, load_phone_only([args.data_root / r for r in train_rel], "training"), strict=True)
    )
    arms = arm_names()
    train_rows = cached("training", train, arms, loaded)
    scores = {arm: median_of(train_rows, arm, "heading") for arm in arms}
    best = min(arms[1:], key=lambda arm: scores[arm])
    chosen = best if scores[best] <= scores["network"] - CHOICE_GAIN_DEG else None
    lines = [
        "# The gait's own yaw axis against the network's direction (a probe, no training)",
        "",
        f"Made by `nice -n 10 python -m experiments.probe_gait_axis --out {args.out}` (its docstring: the "
        "axes, arms and the rule, written before any walk was read). Phone only, the default "
        "(`ronin_resnet-walking`) as the app runs; heading error over 10-s windows start-aligned (median "
        "per walk, median of walks); line error: per window, the angle between the line of the axis (or "
        "the network's velocity) and the true mean velocity, mod 180 deg.",
        "",
        f"## The choice: every 4th training walk ({len(train_rows)})",
        "",
        "| arm | heading (deg) | mean ATE (m) | axis line error (deg) |",
        "|---|--:|--:|--:|",
    ]
    for arm in arms:
        line = "—" if arm == "network" else f"{median_of(train_rows, arm, 'axis_line_off'):.1f}"
        lines.append(f"| {arm} | {scores[arm]:.1f} | {mean_of(train_rows, arm, 'ate'):.2f} | {line} |")
    lines += ["", f"Chosen: **{chosen or 'none'}** (network {scores['network']:.1f} deg).", ""]
    held = ["network", chosen or best]
    groups: dict[str, list[dict]] = {}
    dense = [(f"{g} validation", r, s) for g, r, s in dense_validation(args.data_root)]
    for group, rel, seq in dense:
        groups.setdefault(group, []).extend(
            cached("validation-" + group.split()[0], [(rel, seq)], [*held, "looks"], loaded)
        )
    paths = [args.data_root / protocol.DATA_FOLDERS[protocol.OXIOD] / rel for rel in NEW_WALKS]
    new = cached(
        "new-oxiod",
        list(zip(NEW_WALKS, load_phone_only(paths, "new"), strict=True)),
        [*held, "looks"],
        loaded,
    )
    network_view = [dict(r["network"], walk=r["network"]["walk"].removeprefix("oxiod/")) for r in new]
    by_walk = {r["network"]["walk"]: r for r in new}
    for group, part in new_walk_groups(network_view).items():
        groups[group] = [by_walk[w["walk"]] for w in part]
    which = "the chosen arm" if chosen else f"the best training arm ({best}), unchosen"
    lines += [
        f"## Held out: `network` and {which}",
        "",
        "| group | walks | arm | heading (deg) | after minute 2 | mean ATE (m) | network line error "
        "| axis line error |",
        "|---|--:|---|--:|--:|--:|--:|--:|",
    ]
    arm = held[1]
    for group, rows in groups.items():
        for a in held:
            late = median_of(rows, a, "heading_late")
            axis = "—" if a == "network" else f"{median_of(rows, a, 'axis_line_off'):.1f}"
            lines.append(
                f"| {group} | {len(rows)} | {a} | {median_of(rows, a, 'heading'):.1f} | "
                f"{'—' if np.isnan(late) else f'{late:.1f}'} | {mean_of(rows, a, 'ate'):.2f} | "
                f"{median_of(rows, a, 'network_line_off'):.1f} | {axis} |"
            )
    adopted, reasons = bool(chosen), []
    checks = [("Inria validation", "heading", -INRIA_GAIN_DEG), (NEW_WALKERS, "heading", HELD_LOSS_DEG),
              ("long floor walks", "heading", HELD_LOSS_DEG)]  # fmt: skip
    for group, key, allowed in checks:
        before, after = median_of(groups[group], "network", key), median_of(groups[group], arm, key)
        adopted &= after - before <= allowed
        reasons.append(f"{group}: median heading {before:.1f} -> {after:.1f} deg")
    for group in ("OxIOD validation", "RIDI validation", "Inria validation", NEW_WALKERS):
        before, after = mean_of(groups[group], "network", "ate"), mean_of(groups[group], arm, "ate")
        adopted &= after <= before * (1 + WORSE_AT_MOST)
        reasons.append(f"{group}: mean ATE {before:.3f} -> {after:.3f} m ({after / before - 1:+.1%})")
    everything = [r for rows in groups.values() for r in rows]
    off = [r for r in everything if (r["network"]["network_off"] or 0) > NETWORK_OFF_DEG]
    net_line, axis_line = median_of(off, "network", "network_line_off"), median_of(off, arm, "axis_line_off")
    spreads = ", ".join(f"{label(r['network']['walk'])} {r['looks']['spread']:.0f}" for r in off)
    rest = [r["looks"]["spread"] for r in everything if r not in off]
    lines += [
        "",
        f"**By the rule: {'adopted' if adopted else 'not adopted'}** ({arm}).",
        "",
        *(f"- {r}" for r in reasons),
        "",
        f"Held-out walks where the network's direction is off by more than {NETWORK_OFF_DEG:g} deg (median "
        f"per window): {len(off)} ({', '.join(label(r['network']['walk']) for r in off)}). Line error there: "
        f"network {net_line:.1f}, axis {axis_line:.1f} deg: an EqNIO-style frame is "
        f"**{'worth' if net_line - axis_line >= FRAME_WORTH_DEG else 'not worth'}** a training arm by this "
        "measure.",
        "",
        "The four quarter-turn looks' spread (deg, median over windows) on those walks, where an exactly "
        f"yaw-equivariant network (a learned EqNIO frame) could differ from the default's cycled look: "
        f"{spreads}; on the other held-out walks median {np.median(rest):.1f} (range "
        f"{min(rest):.1f}-{max(rest):.1f}).",
        "",
        f"({(time.monotonic() - started) / 60:.0f} min this run.)",
    ]
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
