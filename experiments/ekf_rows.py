"""Table 1's phone-only rows with the EKF: a checkpoint scored alone and inside the filter on every
dataset's test walks, as ``ftin evaluate --filter`` scores them (issue 36, "scored as Table 1 scores").

Per dataset (OxIOD, RIDI, Inria test parts: ``ftin.protocol.split_paths(root, d, "test")``), phone only
(``auto`` orientation), RoNIN convention with each sequence's default alignment (what Table 1 and
``ftin evaluate`` use), four rows: the model on the ground truth's orientation (Table 1's row), the
model alone on ``auto``, ``--filter ekf``'s answer (the model re-read on the EKF's orientation,
``ftin.filter.levelled``: on ``auto``'s where the walk's mean NIS says the network and the IMU
disagreed), and the EKF's own trajectory; the mean ATE, the ratio to the
ground-truth row, and the tilt of the orientation used against motion capture
(``ftin.evaluate.mean_tilt_error_deg``).

    nice -n 10 python -m experiments.ekf_rows --out docs/results/probes/ekf_rows.md
"""

from __future__ import annotations

import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from experiments.common import argument_parser, parse, weights_key, write_report
from ftin import protocol
from ftin.checkpoint import load_model
from ftin.data.loading import load_sequences
from ftin.evaluate import evaluate_checkpoint, mean_tilt_error_deg, score
from ftin.files import DEFAULT_DATA_ROOT
from ftin.filter.levelled import levelled_prediction
from ftin.filter.run import filter_prediction
from ftin.report.crossval_tables import carry_of

CACHE = Path("runs/probes/ekf_rows")
# (label, orientation, how): "none" is ``ftin evaluate``'s model alone; "ekf" the answer of
# ``--filter ekf`` (the model re-read on the filter's orientation, ``ftin.filter.levelled``), scored as
# ``ftin evaluate`` scores it, with whether the filter's orientation was read; "own" the filter's own
# trajectory (``ftin.filter.run.filter_prediction``), what ``--filter ekf`` answered before.
ROWS = (
    ("ground truth", "ground_truth", "none"),
    ("auto", "auto", "none"),
    ("auto + EKF (`--filter ekf`)", "auto", "levelled"),
    ("the EKF's own path", "auto", "own"),
)


def filter_rows(loaded, paths: list[Path], dataset: str, how: str) -> dict:
    """A filter row per sequence, scored as ``ftin evaluate`` scores (default alignment)."""
    sequences = []
    for seq in load_sequences(paths, f"{dataset} test", "auto"):
        if how == "levelled":
            read = levelled_prediction(loaded, seq, orientation="auto")
            prediction, run, levelled = read.prediction, read.run, read.levelled
        else:
            prediction, run = filter_prediction(loaded, seq, orientation="auto")
            levelled = None
        sequences.append(
            {
                "name": seq.name,
                "ate": score(prediction).metrics.ate,
                "tilt_error_deg": mean_tilt_error_deg(prediction),
                "levelled": levelled,
                "mean_nis": float(np.mean(run.nis)),
            }
        )
    return {"mean": {"ate": float(np.mean([s["ate"] for s in sequences]))}, "sequences": sequences}


def rows_for(checkpoint: Path, data_root: Path, dataset: str) -> list[dict]:
    """Every sequence of ``dataset``'s test part under each row (cached per row)."""
    loaded = load_model(checkpoint)
    paths = protocol.split_paths(data_root, dataset, "test")
    out = []
    weights = weights_key(loaded)
    for label, orientation, how in ROWS:
        cache = CACHE / f"{loaded.name}-{weights}-{dataset}-{orientation}-{how}.json"
        if cache.exists():
            report = json.loads(cache.read_text())
        elif how == "none":
            sequences = load_sequences(paths, f"{dataset} test", orientation)
            report = evaluate_checkpoint(loaded, sequences, orientation=orientation).to_json()
        else:
            report = filter_rows(loaded, paths, dataset, how)
        CACHE.mkdir(parents=True, exist_ok=True)
        cache.write_text(json.dumps(report))
        print(f"{loaded.name} {dataset} {label}: ATE {report['mean']['ate']:.3f}", flush=True)
        for r in report["sequences"]:
            out.append(
                {
                    "checkpoint": loaded.name,
                    "dataset": dataset,
                    "row": label,
                    "sequence": r["name"],
                    "carry": carry_of(dataset, r["name"]),
                    "ate": r["ate"],
                    "tilt": r.get("tilt_error_deg"),
                    "levelled": r.get("levelled"),
                }
            )
    return out


def table(rows: list[dict]) -> list[str]:
    by: dict[tuple[str, str, str], list[dict]] = defaultdict(list)
    for r in rows:
        by[(r["checkpoint"], r["dataset"], r["row"])].append(r)
    lines = [
        "| checkpoint | dataset | row | n | mean ATE | / ground-truth row | / `auto` |"
        " tilt vs motion capture |",
        "|---|---|---|--:|--:|--:|--:|--:|",
    ]
    for (ckpt, dataset, row), rs in by.items():
        ate = float(np.mean([r["ate"] for r in rs]))
        truth = float(np.mean([r["ate"] for r in by[(ckpt, dataset, "ground truth")]]))
        auto = float(np.mean([r["ate"] for r in by[(ckpt, dataset, "auto")]]))
        tilts = [r["tilt"] for r in rs if r["tilt"] is not None]
        tilt = f"{np.mean(tilts):.2f}°" if tilts else "-"
        kept = sum(r["levelled"] is False for r in rs)
        label = f"{row}, {kept} of {len(rs)} kept `auto`'s tilt" if rs[0]["levelled"] is not None else row
        lines.append(
            f"| {ckpt} | {dataset} | {label} | {len(rs)} | {ate:.3f} | {ate / truth:.2f}x |"
            f" {ate / auto - 1:+.0%} | {tilt} |"
        )
    return lines


def carry_table(rows: list[dict]) -> list[str]:
    """Per checkpoint, dataset and carry mode: `auto`, `--filter ekf`'s answer and the filter's own path
    (mean ATE, change against `auto`), and the tilt of `auto` and of the answer."""
    by: dict[tuple[str, str, str], dict[str, list[dict]]] = defaultdict(lambda: defaultdict(list))
    for r in rows:
        by[(r["checkpoint"], r["dataset"], r["carry"])][r["row"]].append(r)
    answer, own = ROWS[2][0], ROWS[3][0]
    lines = [
        "| checkpoint | dataset | carry | n | `auto` | `--filter ekf` | the filter's own path |"
        " tilt `auto` / `--filter ekf` |",
        "|---|---|---|--:|--:|--:|--:|--:|",
    ]
    for (ckpt, dataset, carry), rs in sorted(by.items()):
        auto = float(np.mean([r["ate"] for r in rs["auto"]]))
        cells = []
        for label in (answer, own):
            ate = float(np.mean([r["ate"] for r in rs[label]]))
            cells.append(f"{ate:.3f} ({ate / auto - 1:+.0%})")
        tilts = [
            f"{np.mean([r['tilt'] for r in rs[label]]):.2f}°" if rs[label][0]["tilt"] is not None else "-"
            for label in ("auto", answer)
        ]
        lines.append(
            f"| {ckpt} | {dataset} | {carry} | {len(rs['auto'])} | {auto:.3f} | {' | '.join(cells)} |"
            f" {' / '.join(tilts)} |"
        )
    return lines


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", type=Path, action="append", default=None)
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--datasets", nargs="+", default=[protocol.OXIOD, protocol.INRIA, protocol.RIDI])
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    checkpoints = args.checkpoint or [Path("checkpoints/ronin_resnet-walking")]
    rows = [r for c in checkpoints for d in args.datasets for r in rows_for(c, args.data_root, d)]
    lines = [
        "# Table 1's phone-only rows with the EKF",
        "",
        "Made by `python -m experiments.ekf_rows` (its docstring: method). Test walks of each dataset, RoNIN",
        "convention with each recording's default alignment (as Table 1 and `ftin evaluate`); tilt: mean",
        "angle between the gravity direction of the orientation used and motion capture's.",
        "",
        *table(rows),
        "",
        "## By carry mode",
        "",
        "`ftin.report.crossval_tables.carry_of`: Inria's motion, OxIOD's and RIDI's folders.",
        "",
        *carry_table(rows),
    ]
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
