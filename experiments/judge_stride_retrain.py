"""The stride retrain judged against the shipped default (issues 54 and 50): the rule, then the tables.

Question: does the network the ``stride-retrain`` campaign trains (``ftin/protocol/stride_retrain.py``:
the default's recipe and walkers plus ILC floors F1-F3 as sparse truth) replace the shipped default?

The rule, written before any candidate was read (it is ``stride_retrain``'s docstring made exact):
the candidate replaces ``checkpoints/ronin_resnet-walking`` when

1. on **each** held-out ILC floor (B1, F4; every 4th walk, scored at the waypoints by
   ``ftin.evaluate_sparse``) its median path ratio is closer to 1 than the default's, and
2. no dense validation set (the default's own validation walks: OxIOD, RIDI, every 4th Inria walk,
   phone only as the app reads them) has a mean ATE worse than the default's by more than 5 %.

With ``--rule footing`` (written on 2026-12-07 before the job it judges had trained an epoch): the
control job (campaign ``stride-retrain-control``: FTIN on the default's recipe without ILC, after neither
ILC arm was adopted) replaces ``checkpoints/ftin-walking`` when

1. no dense validation set (as above) has a mean ATE worse than ftin-walking's by more than 5 %, and
2. on the new OxIOD walkers and phones not trained on (held out from both) its mean ATE is lower.

With ``--rule footing-oxiod12`` (written on 2026-12-07 at 10:20, after seed 0 of the control was read and
before seed 1 trained; campaign ``stride-retrain-control-s1``): seed 0 failed ``footing`` on OxIOD
validation alone, two walks of which one, a trolley walk, the shipped default reads at 0.33 m and every other
network at 0.5-0.7 m; so OxIOD is read on twelve walks. The candidate replaces ``checkpoints/ftin-walking``
when

1. on RIDI and Inria validation its mean ATE is not worse than ftin-walking's by more than 5 %,
2. on OxIOD's two validation walks and ten held-out new walkers and phones together (twelve walks) its mean
   ATE is not worse than ftin-walking's by more than 5 %, and
3. on the ten new OxIOD walkers and phones its mean ATE is lower.

Reported beside the rule and choosing nothing: the issue's done-when figures on the held-out groups
(path ratio in 0.85-1.15 per group: the ILC floors, the new OxIOD walkers and phones, the long floor
walks with Tango truth) and the heading error over 10-s windows (``ftin.metrics.heading``) where the
truth has a path. A read before the campaign ends is a look at the job's best-validation weights so far:
it is reported as such and chooses neither the epoch nor the recipe (the campaign stops by its own
validation loss).

    nice -n 10 python -m experiments.judge_stride_retrain \
        --candidate runs/stride-retrain/stride-retrain/ronin_resnet-sparse-s0/ronin_resnet-walking \
        --out docs/results/probes/stride_retrain_judge.md

Each checkpoint's rows are cached in
``runs/probes/stride_retrain_judge/<weights key>-<library key>-<ROWS_VERSION>.json``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from experiments.common import argument_parser, parse, weights_key, write_report
from experiments.probe_new_oxiod_walks import NEW_WALKS, walk_row
from experiments.probe_sparse_truth import dense_validation, ilc_paths
from ftin import protocol
from ftin.campaign.folder import code_digest
from ftin.checkpoint import LoadedModel, load_model
from ftin.data.discovery import read_sequence
from ftin.data.loading import load_phone_only
from ftin.evaluate_sparse import evaluate_waypoints
from ftin.files import DEFAULT_DATA_ROOT
from ftin.protocol.stride_retrain import ILC_HELD_OUT

DEFAULT = Path("checkpoints/ronin_resnet-walking")
RUNS = Path("runs/probes/stride_retrain_judge")
EVERY = 4
WORSE_AT_MOST = 0.05
BAND = (0.85, 1.15)
ROWS_VERSION = "h2"  # the rows' own form in the cache key: h2, the heading read start-aligned (issue 50)
DENSE_SETS = ("OxIOD", "RIDI", "Inria")
NEW_WALKERS = "new OxIOD walkers and phones, not trained on"  # a group of ``new_walk_groups``


def rows_of(loaded: LoadedModel, data_root: Path) -> dict:
    """Every walk the rule and the report read, predicted once by ``loaded``."""
    rows: dict = {"floors": {}, "dense": [], "new": []}
    for floor in ILC_HELD_OUT:
        seqs = [read_sequence(p) for p in ilc_paths(data_root, (floor,), EVERY)]
        rows["floors"][floor] = [
            {"walk": r.name, "ratio": r.metrics.path_ratio, "ate": r.metrics.ate_m}
            for r in evaluate_waypoints(loaded, seqs).sequences
        ]
    for group, rel, seq in dense_validation(data_root):
        rows["dense"].append({**walk_row(loaded, rel, seq), "set": group})
    paths = [data_root / protocol.DATA_FOLDERS[protocol.OXIOD] / rel for rel in NEW_WALKS]
    for rel, seq in zip(NEW_WALKS, load_phone_only(paths, "new OxIOD walks"), strict=True):
        rows["new"].append(walk_row(loaded, rel, seq))
    return rows


def cached_rows(checkpoint: Path, data_root: Path) -> dict:
    loaded = load_model(checkpoint)
    # the library's content keys the cache too: inference changes (a body lock, a calibration) move the
    # rows as much as the weights do
    cache = RUNS / f"{weights_key(loaded)}-{code_digest()}-{ROWS_VERSION}.json"
    if cache.exists():
        return json.loads(cache.read_text())
    started = time.monotonic()
    rows = rows_of(loaded, data_root)
    rows["minutes"] = (time.monotonic() - started) / 60
    RUNS.mkdir(parents=True, exist_ok=True)
    cache.write_text(json.dumps(rows))
    return rows


def band_cell(ratios: list[float]) -> str:
    inside = sum(BAND[0] <= x <= BAND[1] for x in ratios)
    return f"{np.median(ratios):.3f} ({inside} of {len(ratios)}, {inside / len(ratios):.0%})"


def trained_on() -> set[str]:
    """The walks the default (and the candidate, whose dense parts are the same) trained on, as the
    rows name them (relative to oxiod/, without ``.csv.xz``)."""
    data = json.loads(DEFAULT.with_suffix(".json").read_text())["train_config"]["data"]
    return {d.split("oxiod/", 1)[-1].removesuffix(".csv.xz") for d in data if "oxiod/" in d}


def new_walk_groups(rows: list[dict]) -> dict[str, list[dict]]:
    """The new OxIOD walks as the issue groups them, without those the networks trained on: the long floor
    walks (in no part) apart from the other walkers and phones (the validation part)."""
    seen = trained_on()
    unseen = [r for r in rows if r["walk"] not in seen]
    floor = [r for r in unseen if r["group"] == "floor1 (Tango)"]
    return {
        NEW_WALKERS: [r for r in unseen if r not in floor],
        "long floor walks": floor,
    }


def floor_ratio(rows: dict, floor: str) -> float:
    """The median path ratio over a held-out ILC floor's walks."""
    return float(np.median([w["ratio"] for w in rows["floors"][floor] if w["ratio"] is not None]))


def set_ates(rows: dict, group: str) -> list[float]:
    """The ATE of each walk of a dense validation set (``DENSE_SETS``)."""
    return [w["ate"] for w in rows["dense"] if w["set"] == group]


def new_walker_ates(rows: dict) -> list[float]:
    """The ATE of each new OxIOD walker's and phone's walk not trained on."""
    return [w["ate"] for w in new_walk_groups(rows["new"])[NEW_WALKERS]]


def verdict(default: dict, candidate: dict, rule: str = "ilc") -> tuple[bool, list[str]]:
    if rule == "footing-oxiod12":
        return _footing_oxiod12(default, candidate)
    reasons, adopted = [], True
    if rule == "footing":
        before, after = (np.mean(new_walker_ates(r)) for r in (default, candidate))
        adopted = after < before
        reasons.append(
            f"{NEW_WALKERS}: mean ATE {before:.3f} -> {after:.3f} m ({'lower' if adopted else 'not lower'})"
        )
    for floor in ILC_HELD_OUT if rule == "ilc" else ():
        before, after = floor_ratio(default, floor), floor_ratio(candidate, floor)
        closer = abs(after - 1) < abs(before - 1)
        adopted &= closer
        reasons.append(
            f"ILC {floor}: median path ratio {before:.3f} -> {after:.3f} "
            f"({'closer' if closer else 'not closer'} to 1)"
        )
    for group in DENSE_SETS:
        before, after = np.mean(set_ates(default, group)), np.mean(set_ates(candidate, group))
        ok = after <= before * (1 + WORSE_AT_MOST)
        adopted &= ok
        reasons.append(
            f"{group} validation: mean ATE {before:.3f} -> {after:.3f} m ({after / before - 1:+.1%})"
        )
    return adopted, reasons


def _footing_oxiod12(default: dict, candidate: dict) -> tuple[bool, list[str]]:
    """``--rule footing-oxiod12`` (module docstring)."""

    def groups(rows: dict) -> dict[str, list[float]]:
        return {
            "RIDI validation": set_ates(rows, "RIDI"),
            "Inria validation": set_ates(rows, "Inria"),
            "OxIOD validation and new walkers (12)": set_ates(rows, "OxIOD") + new_walker_ates(rows),
            NEW_WALKERS: new_walker_ates(rows),
        }

    before, after = groups(default), groups(candidate)
    adopted, reasons = True, []
    for name in before:
        b, a = float(np.mean(before[name])), float(np.mean(after[name]))
        ok = a < b if name == NEW_WALKERS else a <= b * (1 + WORSE_AT_MOST)
        adopted &= ok
        reasons.append(f"{name}: mean ATE {b:.3f} -> {a:.3f} m ({a / b - 1:+.1%}{'' if ok else ', fails'})")
    return adopted, reasons


def heading_cell(part: list[dict]) -> str:
    """Median over the walks of each walk's median heading error (and after minute 2), deg."""
    cells = []
    for key in ("heading", "heading_late"):
        values = [w[key] for w in part if w.get(key) is not None]
        cells.append(f"{np.median(values):.1f}" if values else "-")
    return " / ".join(cells)


def rows_table(networks: dict[str, dict]) -> list[str]:
    """The tables' markdown: one block of ``table`` rows per named network's rows, under one header."""
    header = [
        "| network | group | walks | path ratio median (in 0.85-1.15) | ATE "
        "| heading error, start-aligned: median / after minute 2 (deg) |",
        "|---|---|--:|---|--:|--:|",
    ]
    return header + [line for name, rows in networks.items() for line in table(name, rows)]


def table(name: str, rows: dict) -> list[str]:
    lines = []
    for floor in ILC_HELD_OUT:
        part = rows["floors"][floor]
        ratios = [w["ratio"] for w in part if w["ratio"] is not None]
        ate = np.median([w["ate"] for w in part if w["ate"] is not None])
        lines.append(
            f"| {name} | ILC {floor} (held out) | {len(part)} | {band_cell(ratios)} "
            f"| {ate:.2f} (at the marks) | - |"
        )
    for group, part in new_walk_groups(rows["new"]).items():
        ratios = [w["ratio"] for w in part if w["ratio"] is not None]
        ate = np.mean([w["ate"] for w in part])
        lines.append(
            f"| {name} | {group} | {len(part)} | {band_cell(ratios)} | {ate:.2f} | {heading_cell(part)} |"
        )
    for group in DENSE_SETS:
        part = [w for w in rows["dense"] if w["set"] == group]
        ratios = [w["ratio"] for w in part if w["ratio"] is not None]
        lines.append(
            f"| {name} | {group} validation | {len(part)} | {band_cell(ratios)} "
            f"| {np.mean([w['ate'] for w in part]):.2f} | {heading_cell(part)} |"
        )
    return lines


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--candidate", type=Path, required=True, help="the retrained network (stem or file)")
    parser.add_argument("--default", type=Path, default=DEFAULT, help="what it would replace")
    parser.add_argument("--label", default="candidate", help="the candidate's name in the tables")
    parser.add_argument(
        "--rule",
        choices=("ilc", "footing", "footing-oxiod12"),
        default="ilc",
        help="which rule of the docstring decides",
    )
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    default = cached_rows(args.default, args.data_root)
    candidate = cached_rows(args.candidate, args.data_root)
    adopted, reasons = verdict(default, candidate, args.rule)
    lines = [
        f"# The stride retrain against the shipped {Path(args.default).name}",
        "",
        f"Made by `nice -n 10 python -m experiments.judge_stride_retrain --candidate {args.candidate} "
        f"--default {args.default} --label '{args.label}' --rule {args.rule}` (its docstring: the rule, "
        "written before any candidate was read). Phone only; ATE in m (RoNIN convention; ILC: median ATE "
        "at the waypoints); path ratio median (walks in "
        "0.85-1.15).",
        "",
        *rows_table({f"shipped {Path(args.default).name}": default, args.label: candidate}),
        "",
        f"**By the rule: {'adopted' if adopted else 'not adopted'}.**",
        "",
        *(f"- {r}" for r in reasons),
    ]
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
