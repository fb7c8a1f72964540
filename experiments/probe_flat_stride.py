"""The stride head only where the flat lock fires? (issue 54, item 3; ``flat_lock.md``, ``stride_head.md``)

Question: with the body lock firing for a phone held flat in front (``ftin.body_heading``,
``held_flat``), the held-out ILC floors read the direction right and 0.80-0.82 of their path: what is
left is the speed (0.79 of true). The stride head of ``probe_stride_head`` read that speed 0.97-0.99
of true on floors it never saw, but was not adopted because, applied to every walk, it made OxIOD
validation's hand-held walk worse. Applied **only where the flat lock fires** (the carry and gait the
ILC segments teach it), on top of the flat lock, does it bring the path to its length without
touching the dense walks?

The arm (fixed before any number below was read): ``probe_stride_head``'s ``speed + stride`` head
(ridge on the five stride features and the network's log speed, penalty by grouped cross-validation,
fitted on the default's training walkers and ILC waypoint segments; ``probe_stride_head``'s docstring,
steps 2-5). Not its ``network + stride`` candidate: the brief's product is the stride features plus the
network's speed, and the backbone's 512 channels would make every prediction keep its feature taps and
ship a 16 x 512 projection; on the earlier probe's (already read) rows the two read the held-out speed
within 0.025 of each other. Applied per window over the ``CONTEXT_S`` around it (speed scaled, direction
kept), and only on a walk where ``ftin.body_heading.lock_to_phone`` locks with ``held_flat``; every
other walk is left exactly as today's default reads it.

Arms: ``flat lock`` (today's default: ``lock_to_phone`` as shipped), ``flat lock + head``.

Evidence. ILC B1 and F4 have already been read by both component probes, so the **primary evidence
is leave-one-floor-out over F1, F2, F3**: the head is fitted on the default's training walkers plus two
of the three floors (every walk) and scored on the third (every 2nd trace, the walks
``probe_flat_lock`` cached), each floor once. Secondary (already read, reported as such): B1 and F4
(every 2nd trace) with the head fitted on the training walkers plus F1-F3, the head the product would
ship. Dense sets (phone only, ``auto``, RoNIN-convention ATE as ``ftin.evaluate.score`` scores it):
OxIOD, RIDI and Inria validation, the new OxIOD validation walkers and phones (``NEW_VAL``), the ten
long floor walks (``FLOOR_DRIFT``), with the shipped head; per set the walks the head touched (locked
with ``held_flat`` and at least one window scaled).

**The rule.** Adopted when all of these hold:
1. on each left-out floor (F1, F2, F3) the median path ratio is closer to 1 than the flat lock alone's,
   and more walks lie in 0.85-1.15;
2. on B1 and on F4 (secondary) the same;
3. no dense set's mean ATE (OxIOD, RIDI, Inria validation, ``NEW_VAL``, ``FLOOR_DRIFT``) is worse by
   more than 5 %;
4. Inria validation's Texting walks (mean ATE) not worse by more than 5 %.
Nothing is tuned after a number is read; a failed clause is reported as failed, and then nothing ships.

(Added after the first run, changing no number the rule reads: the median scale column, the touched
dense walks' 4-s stretches and the heads' coefficients, all descriptive.) Caches: the network's
outputs of ``probe_stride_head`` (``/tmp/stride_head``) and of ``probe_flat_lock``
(``runs/probes/flat_lock``), each rebuilt by its own code where a walk is missing (minutes); the
windows of the two are checked to agree walk by walk.

    nice -n 10 python -m experiments.probe_flat_stride --out docs/results/probes/flat_stride.md
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from experiments.common import argument_parser, parse, write_report
from experiments.probe_flat_lock import MOTIONS, library_lock, record_of, scores_of, set_paths
from experiments.probe_stride_head import (
    CHECKPOINT,
    STRIDE,
    Head,
    dense_stretches,
    dense_walks,
    ilc_row,
    ilc_stretches,
    ilc_walks,
    pooled_stretches,
    records_of,
    scaled_velocity,
)
from ftin.checkpoint import load_model
from ftin.files import DEFAULT_DATA_ROOT

FLOORS = ("F1", "F2", "F3")  # leave-one-floor-out
SECONDARY = ("ilc-B1", "ilc-F4")  # already read by both component probes
DENSE = ("oxiod-val", "ridi-val", "inria-val", "oxiod-new-val", "oxiod-floor")
EVERY = 2  # ILC traces scored: the ones probe_flat_lock cached
ARM = "speed"  # probe_stride_head's ``speed + stride``
BAND = (0.85, 1.15)
WORSE_AT_MOST = 0.05
COLUMNS = (
    *("group", "arm", "walks", "median path ratio", "in 0.85-1.15", "median speed ratio", "in 0.85-1.15"),
    *("mean ATE (m)", "median ATE (m)", "locked held flat", "touched by the head", "median scale"),
)
TOUCHED_COLUMNS = (
    *("group", "walk", "ATE flat lock -> + head", "ratio", "median scale", "true speed (m/s)", "step (m)"),
    *("steps / min", "network / true", "head / true"),
)
READING = "## Reading"  # the hand-written section from here on survives a rerun


def fit_head(dense_items: list, ilc_items: dict[str, list], floors) -> Head:
    """The head on the default's training walkers plus the ILC segments of ``floors`` (every walk)."""
    items = dense_items + [item for floor in floors for item in ilc_items[floor]]
    return Head(ARM).fit(*pooled_stretches(items))


def walk_rows(model, root: Path, name: str, head: Head) -> list[dict]:
    """Each walk of set ``name`` under both arms: the flat lock as shipped, and with the head where it
    locked with ``held_flat``."""
    ilc = name.startswith("ilc-")
    paths = set_paths(root, name, EVERY)
    keyed = [(path.relative_to(root).as_posix(), path) for path in paths]
    strides = records_of(model, root, keyed, not ilc, name)
    rows = []
    for (key, path), (_, stride) in zip(keyed, strides, strict=True):
        record = record_of(model, path, key)
        span_t = record["t_s"][record["span"]]
        if span_t.shape != stride["span_t_s"].shape or not np.allclose(span_t, stride["span_t_s"]):
            raise RuntimeError(f"{key}: the two probes' caches hold different windows")
        lock = library_lock(record)
        locked = np.asarray(lock.velocity_m_s, dtype=np.float64)
        headed = locked
        if lock.locked and lock.held_flat:
            headed = scaled_velocity({**stride, "velocity": locked}, head)
        row = {
            "walk": key,
            "motion": next((m for m in MOTIONS if f"_{m}" in path.name), None),
            "held_flat": bool(lock.locked and lock.held_flat),
            "touched": not np.allclose(headed, locked),
            "scale": _median_scale(locked, headed),
        }
        for arm, velocity in (("flat lock", locked), ("flat lock + head", headed)):
            scored = scores_of(model, record, velocity)
            speed = ilc_row(stride, velocity)["speed_ratio"] if ilc else None
            row[arm] = {"ate": scored["ate"], "ratio": scored["ratio"], "speed_ratio": speed}
        if row["touched"] and not ilc:
            row["stretches"] = stretch_reading(stride, head)
        rows.append(row)
    return rows


def stretch_reading(stride: dict, head: Head) -> dict:
    """A dense walk's walking 4-s stretches (descriptive): true speed, step length, and how the network
    and the head read it."""
    f, y = dense_stretches(stride)
    ok = np.isfinite(y)
    cadence = np.exp(f["stride"][ok, 0])  # steps per minute
    return {
        "speed": float(np.median(np.exp(y[ok]))),
        "step": float(np.median(np.exp(y[ok]) * 60.0 / cadence)),
        "cadence": float(np.median(cadence)),
        "network": float(np.median(np.exp(f["log_speed"][ok] - y[ok]))),
        "head": float(np.median(np.exp(head.predict(f)[ok] - y[ok]))),
    }


def _median_scale(locked: np.ndarray, headed: np.ndarray) -> float | None:
    """The median speed scale over the windows the head changed (None: none changed)."""
    before, after = np.linalg.norm(locked[:, :2], axis=1), np.linalg.norm(headed[:, :2], axis=1)
    changed = ~np.isclose(before, after) & (before > 0)
    return float(np.median(after[changed] / before[changed])) if changed.any() else None


def summary(rows: list[dict], arm: str) -> dict:
    ratios = [r[arm]["ratio"] for r in rows if r[arm]["ratio"] is not None]
    speeds = [r[arm]["speed_ratio"] for r in rows if r[arm]["speed_ratio"] is not None]
    ate = [r[arm]["ate"] for r in rows if r[arm]["ate"] is not None]
    scales = [r["scale"] for r in rows if r["scale"] is not None]
    return {
        "walks": len(rows),
        "ratio": float(np.median(ratios)) if ratios else float("nan"),
        "in_band": sum(BAND[0] <= x <= BAND[1] for x in ratios),
        "with_ratio": len(ratios),
        "speed": float(np.median(speeds)) if speeds else None,
        "speed_in_band": sum(BAND[0] <= x <= BAND[1] for x in speeds),
        "mean_ate": float(np.mean(ate)) if ate else float("nan"),
        "median_ate": float(np.median(ate)) if ate else float("nan"),
        "held_flat": sum(r["held_flat"] for r in rows),
        "touched": sum(r["touched"] for r in rows),
        "scale": float(np.median(scales)) if scales else None,
    }


def judge(groups: dict[str, list[dict]]) -> tuple[bool, list[str]]:
    """The docstring's rule, clause by clause."""
    lines, passed = [], True
    for name, rows in groups.items():
        b, a = summary(rows, "flat lock"), summary(rows, "flat lock + head")
        if name.startswith("ILC"):
            ok = abs(a["ratio"] - 1) < abs(b["ratio"] - 1) and a["in_band"] > b["in_band"]
            text = (
                f"{name}: median path ratio {b['ratio']:.3f} -> {a['ratio']:.3f}, in 0.85-1.15 "
                f"{b['in_band']} -> {a['in_band']} of {a['with_ratio']}"
            )
        else:
            ok = a["mean_ate"] <= (1 + WORSE_AT_MOST) * b["mean_ate"]
            text = (
                f"{name}: mean ATE {b['mean_ate']:.3f} -> {a['mean_ate']:.3f} m "
                f"({a['mean_ate'] / b['mean_ate'] - 1:+.1%}, at most +5 %; {a['touched']} of "
                f"{a['walks']} walks touched)"
            )
        passed &= ok
        lines.append(f"- {'pass' if ok else '**fail**'}: {text}")
    return passed, [f"**{'Adopted' if passed else 'Not adopted'}** by the rule:", "", *lines]


def header(columns: tuple[str, ...], left: int) -> list[str]:
    """A markdown table's two header lines, the first ``left`` columns left-aligned, the rest numbers."""
    return ["| " + " | ".join(columns) + " |", "|" + "---|" * left + "--:|" * (len(columns) - left)]


def table(groups: dict[str, list[dict]]) -> list[str]:
    """Per group, the flat lock alone and with the head (``COLUMNS``)."""
    lines = header(COLUMNS, 2)
    for name, rows in groups.items():
        for arm in ("flat lock", "flat lock + head"):
            lines.append(
                "| " + " | ".join([name, arm, *_cells(summary(rows, arm), arm == "flat lock")]) + " |"
            )
    return lines


def _cells(s: dict, alone: bool) -> list[str]:
    """One row of ``table`` after its group and arm; the head's columns blank for the lock alone."""
    speed = ["—", "—"] if s["speed"] is None else [f"{s['speed']:.3f}", str(s["speed_in_band"])]
    scale = "—" if alone or s["scale"] is None else f"{s['scale']:.3f}"
    return [
        str(s["walks"]),
        f"{s['ratio']:.3f}",
        f"{s['in_band']} of {s['with_ratio']}",
        *speed,
        f"{s['mean_ate']:.3f}",
        f"{s['median_ate']:.3f}",
        str(s["held_flat"]),
        "—" if alone else str(s["touched"]),
        scale,
    ]


def touched_table(groups: dict[str, list[dict]]) -> list[str]:
    """The dense walks the head touched, one by one, with how their 4-s stretches read."""
    lines = header(TOUCHED_COLUMNS, 4)
    for name, rows in groups.items():
        for r in rows:
            if r["touched"] and not name.startswith("ILC"):
                b, a, st = r["flat lock"], r["flat lock + head"], r["stretches"]
                ratio = "-" if b["ratio"] is None else f"{b['ratio']:.2f} -> {a['ratio']:.2f}"
                ate = f"{b['ate']:.2f} -> {a['ate']:.2f}"
                reading = f"{st['speed']:.2f} | {st['step']:.2f} | {st['cadence']:.0f} | {st['network']:.2f}"
                lines.append(f"| {name} | {r['walk']} | {ate} | {ratio} | {r['scale']:.3f} | {reading} "
                             f"| {st['head']:.2f} |")  # fmt: skip
    return lines


def slopes(head: Head) -> str:
    """The head's raw coefficients (log speed per unit of each feature)."""
    return ", ".join(
        f"{n} {w:+.2f}" for n, w in zip([*STRIDE, "log network speed"], head.w / head.sd, strict=True)
    )


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    started = time.monotonic()
    model = load_model(CHECKPOINT)
    root = args.data_root
    recipe = json.loads(CHECKPOINT.with_suffix(".json").read_text())["train_config"]
    dense_train = records_of(model, root, dense_walks(root, recipe["data"]), True, "dense training walks")
    dense_items = [(k, *dense_stretches(r)) for k, r in dense_train]
    ilc_items = {
        floor: [
            (k, *ilc_stretches(r))
            for k, r in records_of(model, root, ilc_walks(root, (floor,), 1), False, floor)
        ]
        for floor in FLOORS
    }
    primary: dict[str, list[dict]] = {}
    fits = {}
    for floor in FLOORS:
        kept = tuple(f for f in FLOORS if f != floor)
        head = fit_head(dense_items, ilc_items, kept)
        fits[f"without {floor}"] = head
        primary[f"ILC {floor} (left out)"] = walk_rows(model, root, f"ilc-{floor}", head)
    shipped = fit_head(dense_items, ilc_items, FLOORS)
    fits["F1-F3 (the product's)"] = shipped
    secondary = {f"ILC {n.split('-')[1]} (secondary)": walk_rows(model, root, n, shipped) for n in SECONDARY}
    dense = {name: walk_rows(model, root, name, shipped) for name in DENSE}
    texting = {"inria-val Texting": [r for r in dense["inria-val"] if r["motion"] == "Texting"]}
    groups = {**primary, **secondary, **dense, **texting}
    adopted, verdict = judge(groups)
    minutes = (time.monotonic() - started) / 60
    lines = [
        "# The stride head only where the flat lock fires (issue 54, item 3)",
        "",
        f"Made by `nice -n 10 python -m experiments.probe_flat_stride --out {args.out}` ({minutes:.0f} min "
        "this run, caches of `probe_stride_head` and `probe_flat_lock`). Its docstring: the arm and the "
        f"rule, committed before any number was read. Phone only, `auto`, `{CHECKPOINT.name}` frozen.",
        "",
        "## The heads (`speed + stride`, ridge)",
        "",
        "| fitted on (beside the training walkers) | ridge penalty | cross-validation RMSE (log speed) "
        "| coefficients (log speed per unit) |",
        "|---|--:|--:|---|",
        *(f"| {k} | {h.alpha:g} | {h.cv_rmse[h.alpha]:.3f} | {slopes(h)} |" for k, h in fits.items()),
        "",
        "## By group",
        "",
        "Path ratio: ILC, the predicted path between the first and last waypoint over the waypoints' "
        "polyline; dense, the distance ratio. Speed ratio (ILC): the predicted speeds over the marks' span "
        "over the polyline. ATE: ILC at the waypoints after one 2-D fit per walk; dense, RoNIN convention. "
        "Left-out floors: the head fitted without that floor (primary evidence); B1/F4: already read by "
        "both component probes (secondary).",
        "",
        *table(groups),
        "",
        "Dense walks the head touched:",
        "",
        *touched_table(dense),
        "",
        "## Against the rule",
        "",
        *verdict,
    ]
    if args.out is not None and args.out.exists():
        text = args.out.read_text(encoding="utf-8")
        if READING in text:
            lines += ["", READING + text.split(READING, 1)[1].rstrip("\n")]
    write_report(args.out, lines)
    print("adopted" if adopted else "not adopted", flush=True)


if __name__ == "__main__":
    main()
