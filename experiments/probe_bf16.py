"""Probe: does bf16 autocast keep a checkpoint's accuracy, and is it faster (issue 39, part 2)?

    .venv/bin/python -m experiments.probe_bf16 --checkpoint checkpoints/ronin_resnet-walking \
        --checkpoint checkpoints/ftin-walking [--walks N] [--out docs/results/probes/bf16.md]

Recordings: those that decide nothing else and that the shipped walking checkpoints never trained on
(``experiments.common.hidden_walk_paths``: OxIOD and RIDI validation parts, Inria's walks outside its
test part; the test parts stay unread), phone only (``ftin.data.loading.load_phone_only``); with
``--walks N`` the first N of each dataset (a family check on a budget). Method: every recording runs
through ``ftin.infer.predict_trajectory`` twice, in the same process, one after the other: ``fp32`` and
``bf16`` (``ftin.precision``: autocast around the model's forward only), both with the four turned
copies, and each is scored by ``ftin.evaluate.score`` (RoNIN convention). Per checkpoint and dataset:
mean ATE in both, its change, the mean path ratio in both, the mean and largest velocity difference,
and the seconds each took per hour of recording (the whole prediction: preparation, model, integration),
measured on this machine's CPU with one torch thread. The bar (``ftin.precision.BF16_ATE_BAR``): the
mean ATE of every dataset within 1 % of fp32's. Speed says something only on a CPU with native bf16
(``ftin.precision.cpu_bf16``, printed with the table): elsewhere autocast emulates it.
"""

from __future__ import annotations

import time
from collections import defaultdict
from pathlib import Path

import numpy as np
from tqdm import tqdm

from experiments.common import argument_parser, hidden_walk_paths, parse, write_report
from ftin import protocol
from ftin.checkpoint import load_model
from ftin.data.loading import load_phone_only
from ftin.evaluate import score
from ftin.files import DEFAULT_DATA_ROOT
from ftin.infer import predict_trajectory
from ftin.precision import BF16_ATE_BAR, Precision, cpu_bf16

DATASETS = (protocol.OXIOD, protocol.RIDI, protocol.INRIA)


def measure(loaded, seq, precision: Precision) -> dict:
    started = time.perf_counter()
    prediction = predict_trajectory(loaded, seq, keep_prepared=False, precision=precision)
    seconds = time.perf_counter() - started
    values = score(prediction).metrics.values
    return {
        "ate": values["ate"],
        "ratio": values.get("path_length_ratio", float("nan")),
        "seconds": seconds,
        "velocity": prediction.velocity_m_s,
    }


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--checkpoint", type=Path, action="append", required=True)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--walks", type=int, default=None, help="the first N recordings of each dataset")
    parser.add_argument("--out", type=Path, default=None, help="markdown table (default: print only)")
    args = parse(parser)
    walks = {
        dataset: load_phone_only(hidden_walk_paths(args.data, dataset)[: args.walks], f"{dataset} walks")
        for dataset in DATASETS
    }
    if args.walks is not None:
        walks = {dataset: seqs[: args.walks] for dataset, seqs in walks.items()}
    native, why = cpu_bf16()
    lines = [
        "# bf16 autocast against fp32 (phone only, validation walks)",
        "",
        f"Made by `python -m experiments.probe_bf16 {' '.join(f'--checkpoint {c}' for c in args.checkpoint)}"
        f"{'' if args.walks is None else f' --walks {args.walks}'}` (its docstring: method). CPU: {why}"
        f"{'' if native else ' (bf16 is emulated here: its seconds are no guide to a bf16 CPU)'}. Cells per "
        "dataset: mean ATE (m) fp32 -> bf16 (change), mean path ratio fp32 -> bf16, velocity difference "
        "mean / max (m/s), seconds per hour of recording fp32 / bf16 (one torch thread). "
        f"Bar: every dataset's mean ATE within {BF16_ATE_BAR:.0%} of fp32's.",
        "",
        "| checkpoint | family | dataset (walks) | ATE fp32 -> bf16 | path ratio | velocity diff "
        "| s per hour fp32 / bf16 | bar |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for checkpoint in args.checkpoint:
        loaded = load_model(checkpoint)
        for dataset, seqs in walks.items():
            rows: dict[str, list[dict]] = defaultdict(list)
            hours = sum(seq.duration_s for seq in seqs) / 3600.0
            for seq in tqdm(seqs, desc=f"{loaded.name} {dataset}", unit="walk"):
                for precision in Precision:
                    rows[precision.value].append(measure(loaded, seq, precision))
            fp32, bf16 = rows["fp32"], rows["bf16"]
            ate = [np.mean([r["ate"] for r in rs]) for rs in (fp32, bf16)]
            ratio = [np.nanmean([r["ratio"] for r in rs]) for rs in (fp32, bf16)]
            diffs = [np.abs(a["velocity"] - b["velocity"]) for a, b in zip(fp32, bf16, strict=True)]
            seconds = [sum(r["seconds"] for r in rs) / hours for rs in (fp32, bf16)]
            change = ate[1] / ate[0] - 1.0
            verdict = "within" if abs(change) <= BF16_ATE_BAR else "FAILS"
            lines.append(
                f"| {loaded.name} | {loaded.model_name} | {protocol.DATASET_LABELS[dataset]} ({len(seqs)}) "
                f"| {ate[0]:.3f} -> {ate[1]:.3f} ({change:+.2%}) | {ratio[0]:.3f} -> {ratio[1]:.3f} "
                f"| {np.mean(np.concatenate(diffs)):.4f} / {max(d.max() for d in diffs):.4f} "
                f"| {seconds[0]:.0f} / {seconds[1]:.0f} | {verdict} |"
            )
            print(lines[-1], flush=True)
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
