"""Should the body lock fire for a phone held flat in front? (issue 54 / 50; ``ilc_direction.md``)

On the ILC mall walks (phone held flat in front, 50 Hz) the network's direction does not follow the
phone; the phone's heading plus the gait's forward offset (``ftin.body_heading``'s lock, forced on)
read the held-out floors far better, but the shipped lock does not fire there: the walks are shorter
than ``MIN_WALK_S`` (60 s) and their steadiness (0.42-0.78) is above ``LOCK_BELOW`` (0.35). The
candidate: lock where the phone is held flat in front (gravity along the device z, steadily).

The gate (written before any number below was read). A walk is **held flat** when the device z axis
of its phone-only orientation (``auto``, as the app runs) lies within ``tilt`` degrees of the vertical
(either face up or down) on at least ``share`` of its samples and it lasts at least ``min_s`` seconds.
A held-flat walk whose median steadiness (``ftin.body_heading.steadiness``) is under ``below`` is
locked exactly as the shipped lock locks (every window keeps the network's speed and takes the
phone's heading plus the walk's gait forward offset). The shipped rule (steadiness < 0.35 over a walk
of a minute or more) stays as it is, beside it.

Choosing the gate's parameters: on the tuning sets only, from the grid ``tilt`` 15, 25, 35 deg,
``share`` 0.8, 0.9, 0.95, ``min_s`` 10, 20 s, ``below`` 0.8, 0.9, any (1.01). A grid point qualifies
when, against today's default (the shipped lock), no tuning dense set's mean ATE is worse by more than
5 % and none of the Inria training walker's AR, Swinging and Texting walks (each motion's mean) either.
Of those, the one with the lowest median ATE at the waypoints over the pooled ILC tuning walks; ties
within 0.02 m go to the one locking the fewest dense tuning walks, then to the stricter gate (smaller
``tilt``, larger ``share``, longer ``min_s``, lower ``below``). No qualifying point: not adopted.

Sets (phone only, ``auto``; the default checkpoint, ``checkpoints/ronin_resnet-walking``):
- tuning: OxIOD, RIDI and Inria training parts (Inria: Thibaud), stage three's new training walks
  (``NEW_TRAIN``), ILC floors F1, F2, F3 (every ``--every``-th trace, 2);
- held out (read once, after the choice): OxIOD, RIDI and Inria validation parts (Inria: Guillaume,
  the held-out walker), the new OxIOD validation walkers and phones (``NEW_VAL``), the ten long floor
  walks with Tango truth (``FLOOR_DRIFT``), ILC floors B1 and F4 (every ``--every``-th trace, 2).

Adopted when, on the held-out sets, the chosen gate against today's default:
1. no dense set's mean ATE (RoNIN convention as ``ftin.evaluate.score`` scores a phone-only walk) is
   worse by more than 5 % (OxIOD, RIDI, Inria validation, the new validation walks, the floor walks);
2. Inria validation AR, Swinging and Texting walks (each motion's mean ATE) not worse by more than 5 %;
3. on ILC B1 and on F4 each, the median path ratio is closer to 1 and the median ATE at the waypoints
   lower (``ftin.metrics.waypoints``);
4. the heading error (``ftin.metrics.heading``: start-aligned, 10-s windows; the median over walks of
   each walk's median, as issue 50's tables) not worse by more than 1 deg on the floor walks, Inria
   validation, OxIOD validation and the new validation walks.
Failing any clause: not adopted, and the library stays as it is.

Method: each walk is read phone only and the network run once (``predict_trajectory``,
``body_lock=False``); its window velocities, spans, the prepared orientation and world-frame
acceleration are cached (``runs/probes/flat_lock``); each arm only re-locks and re-integrates
(``ftin.infer.integrate_spans``) and is scored. Arms: ``default`` (the shipped lock), ``locked`` (the
lock forced on: what a firing gate gives); a gate's result per walk is one or the other. (Added after
the run, changing no number: ``default`` is the rule before this probe, steadiness < 0.35 over a
minute, computed here so that a rerun after the library took the gate reads the same; the report
counts the walks the library's gate locks as the chosen gate does.)

A side measurement, not part of the rule (``--phase radius``, after the library took the gate): the
95 % end radius of ``ftin.uncertainty`` on the ILC floors its held-out probe reads
(``experiments.probe_uncertainty_heldout``: B1 and F4, every 3rd trace, start-aligned), with and
without the flat lock: the lock makes the windows' directions agree, and that probe's speed-scale
spread grows with their disagreement (``direction_coherence``).

    nice -n 10 python -m experiments.probe_flat_lock --phase tune
    nice -n 10 python -m experiments.probe_flat_lock --phase check --out docs/results/probes/flat_lock.md
"""

from __future__ import annotations

import argparse
import itertools
import json
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from experiments.common import argument_parser, parse, weights_key, write_report
from ftin import protocol
from ftin.body_heading import (
    LOCK_BELOW,
    MIN_WALK_S,
    gait_forward,
    lock_to_phone,
    phone_heading,
    span_heading,
    steadiness,
)
from ftin.checkpoint import load_model
from ftin.data.discovery import read_sequence
from ftin.data.loading import load_phone_only
from ftin.data.orientation_option import apply_phone_only
from ftin.data.types import Trajectory, Waypoints
from ftin.evaluate import score
from ftin.files import DEFAULT_DATA_ROOT
from ftin.infer import Prediction, integrate_spans, predict_trajectory
from ftin.metrics.heading import heading_error_of
from ftin.metrics.waypoints import score_waypoints

CHECKPOINT = Path("checkpoints/ronin_resnet-walking")
CACHE = Path("runs/probes/flat_lock")
TUNING = ("oxiod-train", "ridi-train", "inria-train", "oxiod-new-train", "ilc-F1", "ilc-F2", "ilc-F3")
HELD_OUT = ("oxiod-val", "ridi-val", "inria-val", "oxiod-new-val", "oxiod-floor", "ilc-B1", "ilc-F4")
HEADING_SETS = ("oxiod-floor", "inria-val", "oxiod-val", "oxiod-new-val")  # clause 4
MOTIONS = ("AR", "Swinging", "Texting")  # clause 2 (Inria)
GRID = {
    "tilt": (15.0, 25.0, 35.0),
    "share": (0.8, 0.9, 0.95),
    "min_s": (10.0, 20.0),
    "below": (0.8, 0.9, 1.01),
}
BAND = (0.85, 1.15)  # the stride issue's path-ratio band
ARMS = ("default", "locked")


def set_paths(root: Path, name: str, every: int) -> list[Path]:
    if name.startswith("ilc-"):
        return sorted((root / "ilc" / "site1" / name.split("-", 1)[1]).glob("*.txt.xz"))[::every]
    if name == "oxiod-floor":
        return [root / rel for rel in protocol.FLOOR_DRIFT]
    if name.startswith("oxiod-new-"):
        return [root / rel for rel in (protocol.NEW_TRAIN if name.endswith("train") else protocol.NEW_VAL)]
    dataset, part = name.split("-", 1)
    return protocol.split_paths(root, dataset, part)


def phone_only(path: Path):
    """The walk as a phone alone gives it (``auto``); ILC traces carry no attitude to hide."""
    if path.name.endswith(".txt.xz"):
        return apply_phone_only(read_sequence(path))
    return load_phone_only([path])[0]


def record_of(model, path: Path, key: str) -> dict:
    """The network's output and what a lock reads, once per walk (cached under runs/, never committed)."""
    file = CACHE / weights_key(model) / (key.replace("/", "__").replace(" ", "_") + ".npz")
    if file.exists():
        return dict(np.load(file, allow_pickle=False))
    seq = phone_only(path)
    prediction = predict_trajectory(model, seq, body_lock=False)
    t = prediction.trajectory.t_s
    prepared = prediction.prepared
    record = {
        "t_s": t,
        "span": np.searchsorted(t, prediction.span_t_s),
        "velocity": prediction.velocity_m_s,
        "q": prepared.seq.q_world_device_wxyz,
        "acc": np.asarray(prepared.imu_world[:, 3:6], dtype=np.float64),
        "rate_hz": np.array(prepared.rate_hz),
    }
    if prediction.truth is not None:
        record |= {
            "truth_t": prediction.truth.t_s,
            "truth_p": prediction.truth.p_world_m,
            "truth_frame": np.array(prediction.truth_frame or ""),
        }
        if prediction.truth.tracked is not None:
            record["truth_tracked"] = np.asarray(prediction.truth.tracked, dtype=bool)
    if seq.waypoints is not None:
        record |= {"wp_t": seq.waypoints.t_s, "wp_xy": seq.waypoints.xy_map_m}
    file.parent.mkdir(parents=True, exist_ok=True)
    np.savez(file, **record)
    return record


def tilt_deg(q_wxyz: np.ndarray) -> np.ndarray:
    """Per sample, the angle (deg) of the device z axis from the vertical, face up or down."""
    up = Rotation.from_quat(np.asarray(q_wxyz, dtype=np.float64)[:, [1, 2, 3, 0]]).apply([0.0, 0.0, 1.0])[
        :, 2
    ]
    return np.degrees(np.arccos(np.clip(np.abs(up), 0.0, 1.0)))


def forced_lock(record: dict) -> tuple[np.ndarray, float]:
    """The lock forced on (as ``ftin.body_heading.lock_to_phone`` locks), and the walk's median steadiness."""
    t, span, velocity = record["t_s"], record["span"], record["velocity"]
    yaw = phone_heading(record["q"])
    heading = span_heading(yaw, span[:, 0], span[:, 1])
    t_mid = 0.5 * (t[span[:, 0]] + t[span[:, 1]])
    steady = float(np.median(steadiness(velocity[:, :2], heading, t_mid)))
    speed = np.linalg.norm(velocity[:, :2], axis=1)
    forward = gait_forward(record["acc"], yaw, float(record["rate_hz"]), t, t_mid)
    offset = np.angle(np.sum(speed * np.exp(1j * forward)))
    locked = velocity.copy()
    locked[:, 0], locked[:, 1] = speed * np.cos(heading + offset), speed * np.sin(heading + offset)
    return locked, steady


def library_lock(record: dict):
    """``ftin.body_heading.lock_to_phone`` as the library runs it today (the gate shipped)."""
    t, span = record["t_s"], record["span"]
    rate = float(record["rate_hz"])
    return lock_to_phone(t, record["q"], record["acc"], rate, span[:, 0], span[:, 1], record["velocity"])


def scores_of(model, record: dict, velocity: np.ndarray) -> dict:
    """One arm of one walk scored: dense truth (ATE, standing still, distance ratio, heading error) or
    waypoints (ATE at the marks, path ratio)."""
    t, span = record["t_s"], record["span"]
    start = record["truth_p"][0] if "truth_p" in record else np.zeros(3)
    trajectory = Trajectory(t, integrate_spans(t, span[:, 0], span[:, 1], velocity, start), record["q"])
    if "wp_t" in record:
        metrics = score_waypoints(trajectory, Waypoints(record["wp_t"], record["wp_xy"]))
        return {"ate": metrics.ate_m, "ratio": metrics.path_ratio}
    tracked = record.get("truth_tracked")
    truth = Trajectory(record["truth_t"], record["truth_p"], tracked=tracked)
    prediction = Prediction(
        trajectory=trajectory,
        window_t_s=0.5 * (t[span[:, 0]] + t[span[:, 1]]),
        velocity_m_s=velocity,
        orientation_source="estimated",
        frame="ground_truth",
        warnings=[],
        features=None,
        span_t_s=np.column_stack([t[span[:, 0]], t[span[:, 1]]]),
        truth=truth,
        truth_frame=str(record["truth_frame"]) or None,
        window_s=model.window / float(model.imu_rate_hz),
    )
    result = score(prediction)
    started = score(prediction, "start")
    heading = heading_error_of(trajectory, started.truth_in_estimate_frame(truth))
    return {
        "ate": result.metrics.values["ate"],
        "still": result.stand_still.values["ate"],
        "ratio": result.metrics.values.get("distance_ratio"),
        "heading": None if heading is None else heading.median_deg,
        "heading_late": None if heading is None else heading.median_after_2min_deg,
    }


def walk_row(model, name: str, path: Path, root: Path) -> dict:
    key = path.relative_to(root).as_posix()
    record = record_of(model, path, key)
    locked, steady = forced_lock(record)
    duration = float(record["t_s"][-1] - record["t_s"][0])
    shipped = duration >= MIN_WALK_S and steady < LOCK_BELOW  # the rule before this probe
    tilt = tilt_deg(record["q"])
    motion = next((m for m in MOTIONS if f"_{m}" in path.name), None) if "inria" in name else None
    return {
        "set": name,
        "walk": key,
        "motion": motion,
        "duration_s": duration,
        "steady": steady,
        "tilt_median_deg": float(np.median(tilt)),
        "flat_share": {f"{a:g}": float(np.mean(tilt <= a)) for a in GRID["tilt"]},
        "shipped_locks": bool(shipped),
        "library_locks": bool(library_lock(record).locked),
        "default": scores_of(model, record, locked if shipped else record["velocity"]),
        "locked": scores_of(model, record, locked),
    }


def gate_fires(row: dict, tilt: float, share: float, min_s: float, below: float) -> bool:
    """Whether the candidate gate (module docstring) locks this walk, beside the shipped rule."""
    flat = row["duration_s"] >= min_s and row["flat_share"][f"{tilt:g}"] >= share and row["steady"] < below
    return row["shipped_locks"] or flat


def arm_rows(rows: list[dict], gate: tuple | None) -> list[dict]:
    """Each walk's scores under ``gate`` (None: today's default), with whether a lock fired."""
    out = []
    for r in rows:
        fired = r["shipped_locks"] if gate is None else gate_fires(r, *gate)
        out.append({**r["locked" if fired else "default"], "fired": fired, "row": r})
    return out


def _values(scored: list[dict], key: str) -> list[float]:
    return [s[key] for s in scored if s.get(key) is not None and np.isfinite(s[key])]


def _median(values: list[float]) -> float:
    return float(np.median(values)) if values else float("nan")


def summary(scored: list[dict]) -> dict:
    ratios = _values(scored, "ratio")
    ate = _values(scored, "ate")
    return {
        "walks": len(scored),
        "mean_ate": float(np.mean(ate)) if ate else float("nan"),
        "median_ate": _median(ate),
        "still": float(np.mean(_values(scored, "still"))) if _values(scored, "still") else float("nan"),
        "ratio": _median(ratios),
        "in_band": sum(BAND[0] <= x <= BAND[1] for x in ratios),
        "with_ratio": len(ratios),
        "heading": _median(_values(scored, "heading")),
        "heading_late": _median(_values(scored, "heading_late")),
        "fired": sum(s["fired"] for s in scored),
    }


def change(new: float, old: float) -> float:
    return 100.0 * (new / old - 1.0)


def tuning_ok(rows: dict[str, list[dict]], gate: tuple) -> tuple[bool, float, int]:
    """Whether ``gate`` qualifies on the tuning sets, its pooled ILC median ATE at the waypoints, and
    how many dense tuning walks it locks beyond today's."""
    ok, extra, ilc = True, 0, []
    for name, part in rows.items():
        before, after = arm_rows(part, None), arm_rows(part, gate)
        if name.startswith("ilc-"):
            ilc += _values(after, "ate")
            continue
        extra += sum(a["fired"] and not b["fired"] for a, b in zip(after, before, strict=True))
        groups = [(before, after)]
        if name.startswith("inria"):
            groups += [
                (
                    [b for b in before if b["row"]["motion"] == m],
                    [a for a in after if a["row"]["motion"] == m],
                )
                for m in MOTIONS
            ]
        for b, a in groups:
            if change(summary(a)["mean_ate"], summary(b)["mean_ate"]) > 5.0:
                ok = False
    return ok, _median(ilc), extra


def choose(rows: dict[str, list[dict]]) -> tuple[tuple | None, list[str]]:
    """The gate the rule picks on the tuning sets (module docstring), and the grid's table."""
    found = []
    for tilt, share, min_s, below in itertools.product(*GRID.values()):
        gate = (tilt, share, min_s, below)
        ok, ilc_ate, extra = tuning_ok(rows, gate)
        strict = (tilt, -share, -min_s, below)
        found.append((ok, ilc_ate, extra, strict, gate))
    qualified = [f for f in found if f[0]]
    chosen = None
    if qualified:
        best = min(f[1] for f in qualified)
        near = [f for f in qualified if f[1] <= best + 0.02]
        chosen = min(near, key=lambda f: (f[2], f[3]))[4]
    lines = [
        "| tilt (deg) | share | min walk (s) | steadiness below | qualifies "
        "| ILC tuning median ATE at waypoints (m) | dense tuning walks newly locked |",
        "|--:|--:|--:|--:|---|--:|--:|",
    ]
    for ok, ilc_ate, extra, _, gate in sorted(found, key=lambda f: (not f[0], f[1])):
        mark = " (chosen)" if gate == chosen else ""
        lines.append(
            f"| {gate[0]:g} | {gate[1]:g} | {gate[2]:g} | {'any' if gate[3] > 1 else f'{gate[3]:g}'} "
            f"| {'yes' if ok else 'no'}{mark} | {ilc_ate:.2f} | {extra} |"
        )
    return chosen, lines


def set_table(rows: dict[str, list[dict]], gate: tuple | None) -> list[str]:
    lines = [
        "| set | walks | arm | mean ATE (m; ILC: at the waypoints) | median ATE | ATE / still | path ratio "
        "(median) | in 0.85-1.15 | heading median (deg) | after minute 2 | lock fired |",
        "|---|--:|---|--:|--:|--:|--:|--:|--:|--:|--:|",
    ]
    for name, part in rows.items():
        for label, g in (("default", None), ("flat lock", gate)):
            if label == "flat lock" and g is None:
                continue
            s = summary(arm_rows(part, g))
            still = "-" if not np.isfinite(s["still"]) else f"{s['mean_ate'] / s['still']:.2f}"
            lines.append(
                f"| {name} | {s['walks']} | {label} | {s['mean_ate']:.2f} | {s['median_ate']:.2f} | {still} "
                f"| {s['ratio']:.2f} | {s['in_band']} of {s['with_ratio']} | {_fmt(s['heading'])} "
                f"| {_fmt(s['heading_late'])} | {s['fired']} of {s['walks']} |"
            )
    return lines


def motion_table(rows: dict[str, list[dict]], gate: tuple | None) -> list[str]:
    lines = [
        "| set | motion | walks | default mean ATE | flat lock mean ATE | change | lock fired |",
        "|---|---|--:|--:|--:|--:|--:|",
    ]
    for name, part in rows.items():
        if not name.startswith("inria") or gate is None:
            continue
        for m in MOTIONS:
            mine = [r for r in part if r["motion"] == m]
            b, a = summary(arm_rows(mine, None)), summary(arm_rows(mine, gate))
            lines.append(
                f"| {name} | {m} | {len(mine)} | {b['mean_ate']:.2f} | {a['mean_ate']:.2f} "
                f"| {change(a['mean_ate'], b['mean_ate']):+.1f} % | {a['fired']} of {len(mine)} |"
            )
    return lines


def walk_table(rows: dict[str, list[dict]], gate: tuple | None) -> list[str]:
    """The dense walks whose lock decision the gate changes, and what it did to each."""
    lines = [
        "| set | walk | s | tilt median (deg) | flat share | steadiness | ATE default -> locked "
        "| ratio default -> locked | heading default -> locked |",
        "|---|---|--:|--:|--:|--:|---|---|---|",
    ]
    for name, part in rows.items():
        if name.startswith("ilc-") or gate is None:
            continue
        for r in part:
            if gate_fires(r, *gate) == r["shipped_locks"]:
                continue
            d, k = r["default"], r["locked"]
            lines.append(
                f"| {name} | {r['walk']} | {r['duration_s']:.0f} | {r['tilt_median_deg']:.0f} "
                f"| {r['flat_share'][f'{gate[0]:g}']:.2f} | {r['steady']:.2f} "
                f"| {d['ate']:.2f} -> {k['ate']:.2f} | {_fmt(d['ratio'], 2)} -> {_fmt(k['ratio'], 2)} "
                f"| {_fmt(d['heading'])} -> {_fmt(k['heading'])} |"
            )
    return lines


def flat_table(rows: dict[str, list[dict]]) -> list[str]:
    """How flat and how steady each set's walks are (what the gate reads)."""
    lines = [
        "| set | walks | s (median) | tilt median (deg, median over walks) | share within "
        + ", ".join(f"{a:g}" for a in GRID["tilt"])
        + " deg (median) | steadiness (median) | shipped lock fires |",
        "|---|--:|--:|--:|---|--:|--:|",
    ]
    for name, part in rows.items():
        shares = ", ".join(f"{_median([r['flat_share'][f'{a:g}'] for r in part]):.2f}" for a in GRID["tilt"])
        lines.append(
            f"| {name} | {len(part)} | {_median([r['duration_s'] for r in part]):.0f} "
            f"| {_median([r['tilt_median_deg'] for r in part]):.0f} | {shares} "
            f"| {_median([r['steady'] for r in part]):.2f} | {sum(r['shipped_locks'] for r in part)} |"
        )
    return lines


def verdict(rows: dict[str, list[dict]], gate: tuple | None) -> tuple[bool, list[str]]:
    """The adoption rule (module docstring) on the held-out sets."""
    if gate is None:
        return False, ["No grid point qualified on the tuning sets: **not adopted**."]
    failed, lines = [], []
    for name, part in rows.items():
        b, a = summary(arm_rows(part, None)), summary(arm_rows(part, gate))
        if name.startswith("ilc-"):
            closer = abs(a["ratio"] - 1) < abs(b["ratio"] - 1)
            lower = a["median_ate"] < b["median_ate"]
            lines.append(
                f"- {name}: median path ratio {b['ratio']:.2f} -> {a['ratio']:.2f}, "
                f"median ATE at the waypoints {b['median_ate']:.2f} -> {a['median_ate']:.2f} m "
                f"({a['fired']} of {a['walks']} locked)"
            )
            failed += [] if closer and lower else [f"3 ({name})"]
            continue
        ate = change(a["mean_ate"], b["mean_ate"])
        text = f"- {name}: mean ATE {b['mean_ate']:.2f} -> {a['mean_ate']:.2f} m ({ate:+.1f} %)"
        failed += [f"1 ({name})"] if ate > 5.0 else []
        if name in HEADING_SETS:
            text += f", heading {_fmt(b['heading'])} -> {_fmt(a['heading'])} deg"
            failed += [f"4 ({name})"] if a["heading"] > b["heading"] + 1.0 else []
        lines.append(text + f" ({a['fired'] - b['fired']} more walks locked)")
        if name.startswith("inria"):
            for m in MOTIONS:
                mine = [r for r in part if r["motion"] == m]
                mb, ma = summary(arm_rows(mine, None)), summary(arm_rows(mine, gate))
                failed += [f"2 ({name} {m})"] if change(ma["mean_ate"], mb["mean_ate"]) > 5.0 else []
    adopted = not failed
    head = "**adopted**" if adopted else f"**not adopted** (failed clause {', '.join(failed)})"
    return adopted, [f"Against the rule: {head}.", "", *lines]


def _fmt(x: float | None, digits: int = 1) -> str:
    return "-" if x is None or not np.isfinite(x) else f"{x:.{digits}f}"


def gate_words(gate: tuple | None) -> str:
    if gate is None:
        return "none"
    below = "any steadiness" if gate[3] > 1 else f"steadiness under {gate[3]:g}"
    flat = f"device z within {gate[0]:g} deg of vertical on >= {gate[1]:g} of the walk"
    return f"{flat}, >= {gate[2]:g} s, {below}"


def load_rows(model, names: tuple[str, ...], root: Path, every: int) -> dict[str, list[dict]]:
    rows: dict[str, list[dict]] = {}
    for name in names:
        cache = CACHE / weights_key(model) / f"rows-{name}-every{every}.json"
        if cache.exists():
            rows[name] = json.loads(cache.read_text())
            continue
        started = time.monotonic()
        rows[name] = [walk_row(model, name, path, root) for path in set_paths(root, name, every)]
        cache.write_text(json.dumps(rows[name]))
        print(f"{name}: {len(rows[name])} walks, {time.monotonic() - started:.0f} s", flush=True)
    return rows


def radius_lines(model, root: Path) -> list[str]:
    """The side measurement (module docstring): ILC coverage of the 95 % end radius, flat lock off/on."""
    import ftin.body_heading as body_heading  # noqa: PLC0415  (the gate switched off for one arm)
    from experiments.probe_uncertainty_heldout import (  # noqa: PLC0415
        EVERY,
        HELD_FLOORS,
        coverage,
        path_ratio,
        walk_marks,
    )
    from experiments.uncertainty_ilc_walks import cached_ilc_walks  # noqa: PLC0415
    from ftin.uncertainty.calibration import calibration_for  # noqa: PLC0415
    from ftin.uncertainty.propagate import direction_coherence  # noqa: PLC0415

    calibration = calibration_for(CHECKPOINT.name)
    lines = [
        "| floor | walks | flat lock | median path ratio | median direction coherence | true end within r95 "
        "| Spearman(r95, end error) | median r95 (m) |",
        "|---|--:|---|--:|--:|--:|--:|--:|",
    ]
    share = body_heading.FLAT_SHARE
    for arm in ("off", "on"):
        body_heading.FLAT_SHARE = share if arm == "on" else 2.0  # 2.0: no walk is ever that flat
        try:
            cache = CACHE / weights_key(model) / f"radius-{arm}"
            walks = cached_ilc_walks(model, root, cache, HELD_FLOORS, EVERY)
        finally:
            body_heading.FLAT_SHARE = share
        for floor in HELD_FLOORS:
            mine = [w for w in walks if str(w["dataset"]) == f"ilc {floor}"]
            inside, rho = coverage(mine, calibration)
            coherence = []
            for w in mine:
                t = w["t_s"]
                a = np.clip(np.searchsorted(t, w["span_t_s"][:, 0]), 0, len(t) - 1)
                b = np.clip(np.searchsorted(t, w["span_t_s"][:, 1]), 0, len(t) - 1)
                coherence.append(direction_coherence(t, a, b, w["v_pred"]))
            r95 = [walk_marks(w, calibration)["r95"] for w in mine]
            lines.append(
                f"| {floor} | {len(mine)} | {arm} | {_median([path_ratio(w) for w in mine]):.2f} "
                f"| {_median(coherence):.2f} | {inside} of {len(mine)} ({100 * inside / len(mine):.0f} %) "
                f"| {rho:.2f} | {_median(r95):.1f} |"
            )
    return lines


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--phase", choices=("tune", "check", "radius"), required=True)
    parser.add_argument("--every", type=int, default=2, help="every k-th ILC trace of each floor")
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None)
    args: argparse.Namespace = parse(parser)
    model = load_model(CHECKPOINT)
    if args.phase == "radius":
        title = "# The flat lock and the 95 % end radius on the held-out ILC floors (a side measurement)"
        write_report(args.out, [title, "", *radius_lines(model, args.data_root)])
        return
    tuning = load_rows(model, TUNING, args.data_root, args.every)
    gate, grid = choose(tuning)
    lines = [
        "# Should the body lock fire for a phone held flat in front? (a probe)",
        "",
        f"Made by `nice -n 10 python -m experiments.probe_flat_lock --phase {args.phase} "
        f"--every {args.every}` (its docstring: the rule, written before any number; "
        f"`{CHECKPOINT.name}`, phone only, `auto`).",
        "ATE in m: dense sets RoNIN convention as `ftin.evaluate.score` scores a phone-only walk, mean",
        "over walks; ILC at the waypoints after one 2-D fit per walk. Heading: `ftin.metrics.heading`,",
        "start-aligned, the median over walks of each walk's median. Path ratio: distance ratio (dense) or",
        "path over the waypoints' polyline (ILC).",
        "",
        "## What the gate reads",
        "",
        *flat_table(tuning),
        "",
        "## The choice on the tuning sets",
        "",
        f"Chosen gate: {gate_words(gate)}.",
        "",
        *set_table(tuning, gate),
        "",
        *motion_table(tuning, gate),
        "",
        "Dense tuning walks the gate newly locks:",
        "",
        *walk_table(tuning, gate),
        "",
        "The grid (qualifying first, by the ILC median ATE):",
        "",
        *grid,
    ]
    if args.phase == "check":
        held = load_rows(model, HELD_OUT, args.data_root, args.every)
        adopted, words = verdict(held, gate)
        lines += [
            "",
            "## The held-out sets (read once, after the choice)",
            "",
            *flat_table(held),
            "",
            *set_table(held, gate),
            "",
            *motion_table(held, gate),
            "",
            "Dense held-out walks the gate newly locks:",
            "",
            *walk_table(held, gate),
            "",
            *words,
        ]
        every = [r for part in (*tuning.values(), *held.values()) for r in part]
        same = sum(r["library_locks"] == gate_fires(r, *gate) for r in every) if gate else 0
        lines += [
            "",
            f"The library's gate as shipped (`ftin.body_heading.lock_to_phone`) locks the same walks as the "
            f"chosen gate on {same} of {len(every)} walks.",
        ]
        (CACHE / "verdict.json").write_text(json.dumps({"gate": gate, "adopted": adopted}))
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
