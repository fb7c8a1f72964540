"""What do checkpoints read walking speed from? The speed-cue probe (``ftin.analysis.speed_cues``).

    .venv/bin/python -m experiments.probe_speed_cues \
        --checkpoint checkpoints/ftin-pedestrian --checkpoint checkpoints/ronin_resnet-oxiod \
        --out docs/results/probes/speed_cues.md

Windows: the validation recordings of ``ftin.protocol`` (OxIOD and RIDI, ground-truth orientation,
never the test part; with ``--fold K`` those of walker fold K, for the generalisation campaign's
fold-K runs, which never trained on them, and Inria's too), each at the checkpoint's rate, every
``--stride`` samples, kept where the walker moves. For every checkpoint and dataset, the change of
the mean predicted speed when the zero-mean part of one acceleration component is scaled (x0, x0.5,
x1.5), and when the window is time-warped so the step frequency changes (x0.8, x1.25) at unchanged
amplitudes.
"""

from __future__ import annotations

from pathlib import Path

from experiments.common import add_checkpoint_options, argument_parser, parse, write_report
from ftin.analysis.speed_cues import speed_cue_probe, window_predictor
from ftin.checkpoint import load_model
from ftin.data.loading import load_sequences
from ftin.data.prepare import prepare
from ftin.protocol import INRIA, OXIOD, RIDI, split_paths

LABELS = {"vertical": "vertical bounce", "cross_track": "cross-track swing", "along_track": "along-track"}


def main() -> None:
    parser = argument_parser(__doc__)
    add_checkpoint_options(parser, stride=20, checkpoint_help="checkpoint (repeatable)")
    parser.add_argument("--title", default="Speed-cue probe")
    parser.add_argument("--fold", type=int, default=None, help="walker fold's validation walkers")
    args = parse(parser)
    names = (OXIOD, RIDI) if args.fold is None else (OXIOD, RIDI, INRIA)
    datasets = {
        name: load_sequences(split_paths(args.data_root, name, "val", args.fold), orientation="ground_truth")
        for name in names
    }
    columns, results = [], {}
    stems = [Path(p).name.removesuffix(".safetensors") for p in args.checkpoint]
    for path, stem in zip(args.checkpoint, stems, strict=True):
        loaded = load_model(path)
        label = stem if stems.count(stem) == 1 else f"{Path(path).parent.name}/{stem}"  # same stems
        predict = window_predictor(loaded)
        for name, sequences in datasets.items():
            prepared = [prepare(s, loaded.imu_rate_hz) for s in sequences]
            column = f"{label} on {name}"
            columns.append(column)
            results[column] = speed_cue_probe(predict, prepared, loaded.window, args.stride)
            print(f"{column}: {results[column][0].windows} windows", flush=True)
    first = results[columns[0]]
    where = f"fold {args.fold}'s validation walkers" if args.fold is not None else "validation recordings"
    lines = [
        f"# {args.title}",
        "",
        "Change of the mean predicted speed (%) over moving windows (true speed >= 0.3 m/s) of the "
        + where
        + " ("
        + "; ".join(f"{name}: " + ", ".join(s.name for s in seqs) for name, seqs in datasets.items())
        + "), world frame, ground-truth "
        "orientation. Amplitude rows scale only the zero-mean part of one acceleration component; "
        "cadence rows resample the window from a span x0.8 / x1.25 as long, so the step frequency "
        "changes by that factor while amplitudes stay (a model reading speed from rhythm at a fixed "
        "stride length would move by -20 % / +25 %). Made by `python -m experiments.probe_speed_cues`.",
        "",
        "| cue | factor | " + " | ".join(columns) + " |",
        "|---|---|" + "---|" * len(columns),
    ]
    for i, row in enumerate(first):
        label = LABELS.get(row.probe, "cadence (time warp)")
        cells = " | ".join(f"{results[c][i].speed_change_pct:+.1f}" for c in columns)
        lines.append(f"| {label} | x{row.factor:g} | {cells} |")
    lines.append("| windows | | " + " | ".join(str(results[c][0].windows) for c in columns) + " |")
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
