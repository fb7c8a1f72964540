"""Probe: do the hidden walks read the same with one look per window as with four turned copies?

    .venv/bin/python -m experiments.probe_hidden_cyclic [--checkpoint checkpoints/ronin_resnet-walking] \
        [--out docs/results/probes/hidden_cyclic.md]

The choice of one look per window, cycling through the quarter turns (``ftin.yaw_average``), was made
on walker-held-out validation (``probe_single_look``). This checks it afterwards, changing nothing, on
the recordings of ``ftin campaign hidden-walks`` (the protocol's test parts, phone only): the default
checkpoint with the four copies and with the cycled turns, per dataset and per recording.
"""

from __future__ import annotations

from pathlib import Path

from experiments.common import argument_parser, parse, write_report
from ftin.checkpoint import load_model
from ftin.files import DEFAULT_DATA_ROOT
from ftin.report.hidden_walks import LABELS, hidden_walks
from ftin.yaw_average import YAW_COPIES

WAYS = {
    f"{YAW_COPIES} turned copies": {"yaw_copies": YAW_COPIES, "cyclic_turns": False},
    "1 look, cycled turns": {"yaw_copies": 1, "cyclic_turns": True},
}


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", type=Path, default=Path("checkpoints/ronin_resnet-walking"))
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=Path("docs/results/probes/hidden_cyclic.md"))
    args = parse(parser)
    model = load_model(args.checkpoint)
    results = {way: hidden_walks(model, args.data, **options) for way, options in WAYS.items()}
    lines = [
        "# The hidden walks with one look per window against four turned copies",
        "",
        f"Made by `python -m experiments.probe_hidden_cyclic --checkpoint {args.checkpoint}` (its "
        "docstring). Phone only, RoNIN convention; per dataset: mean ATE (m), over standing still's, "
        "distance ratios in bounds.",
        "",
        "| dataset | " + " | ".join(WAYS) + " |",
        "|---|" + "--:|" * len(WAYS),
    ]
    first = next(iter(results.values()))
    for dataset in first:
        cells = []
        for way in WAYS:
            s = results[way][dataset]["summary"]
            share = f"{s['ratio_ok']} of {s['recordings']}"
            cells.append(f"{s['mean_ate_m']:.2f} / {s['ate_over_stand_still']:.2f} / {share}")
        lines.append(f"| {LABELS[dataset]} | " + " | ".join(cells) + " |")
    lines += ["", "| recording | " + " | ".join(f"{way}: ATE / distance ratio" for way in WAYS) + " |"]
    lines.append("|---|" + "--:|" * len(WAYS))
    for dataset in first:
        for i, row in enumerate(first[dataset]["rows"]):
            cells = []
            for way in WAYS:
                r = results[way][dataset]["rows"][i]
                ratio = "-" if r["distance_ratio"] is None else f"{r['distance_ratio']:.2f}"
                cells.append(f"{r['ate_m']:.2f} / {ratio}")
            lines.append(f"| {row['name']} | " + " | ".join(cells) + " |")
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
