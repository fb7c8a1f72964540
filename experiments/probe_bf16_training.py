"""Does training in bf16 autocast (``TrainConfig.precision``) leave validation as fp32 training leaves it,
and how much faster is a step on this CPU? (issue 54: train in bf16 where the CPU does it natively.)

Method: two fine-tunes of ``checkpoints/ronin_resnet-walking`` through the real training loop
(``ftin.train.train``), identical but for ``precision`` (fp32 / bf16): its recipe as its JSON records it
(rate, window, stride, batch 128, ``mirror``, orientation ``ground_truth``), Adam at ``--lr``, seed 0, one
torch thread, ``--steps`` optimizer steps on the recipe's OxIOD and RIDI training walks (a subset: the
machine is shared), no validation during training. Then each run's final weights are scored in fp32 on
the recipe's OxIOD and RIDI validation walks (windows at the recipe's stride, the velocity MSE the loop
validates with, and the mean window speed over the true one), beside the starting checkpoint.

The bar, written before either run was read: bf16 training is used where the CPU has native bf16 when
its validation MSE is within 2 % of the fp32 run's (both started from the same weights, same batches).

    nice -n 10 python -m experiments.probe_bf16_training --steps 20 --out docs/results/probes/bf16_training.md
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import torch

from experiments.common import argument_parser, parse, write_report
from experiments.probe_damped_bounce import final_weights
from ftin.checkpoint import LoadedModel, load_model
from ftin.data.loading import load_sequences
from ftin.data.prepare import prepare
from ftin.data.windows import WindowDataset
from ftin.files import DEFAULT_DATA_ROOT
from ftin.precision import cpu_bf16
from ftin.train.config import LossKind, TrainConfig
from ftin.train.loop import train

START = Path("checkpoints/ronin_resnet-walking")
RUNS = Path("runs/probes/bf16_training")
BAR = 0.02


def recipe() -> tuple[TrainConfig, dict]:
    shipped = json.loads(START.with_suffix(".json").read_text())
    return TrainConfig.from_json(shipped["train_config"]), shipped


def validation(loaded: LoadedModel, windows: WindowDataset) -> tuple[float, float]:
    """fp32 velocity MSE over every validation window, and the mean predicted over true speed."""
    loaded.model.eval()
    sq, n, speed_pred, speed_true = 0.0, 0, 0.0, 0.0
    with torch.inference_mode():
        for first in range(0, len(windows), 256):
            x, v = windows.get_batch(np.arange(first, min(first + 256, len(windows))))
            out = loaded.model(loaded.normalization.apply(x)).velocity.float()
            target = v.reshape(len(v), -1)
            sq += float(((out - target) ** 2).sum())
            n += target.numel()
            speed_pred += float(out.norm(dim=1).sum())
            speed_true += float(target.norm(dim=1).sum())
    return sq / n, speed_pred / speed_true


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--lr", type=float, default=1e-4)
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    config, shipped = recipe()
    subset = [r for r in config.data if r.startswith(("oxiod/", "ridi/"))]
    val = [r for r in shipped["train_config"]["val"] if r.startswith(("oxiod/", "ridi/"))]
    train_seqs = load_sequences([args.data_root / r for r in subset], "training walks", config.orientation)
    val_seqs = load_sequences([args.data_root / r for r in val], "validation walks", config.orientation)
    prepared = [prepare(s, 100.0, orientation=config.orientation).seq for s in val_seqs]
    windows = WindowDataset(prepared, 100, config.stride, 2, augment_yaw=False)
    rows = {"start (untrained)": (*validation(load_model(START), windows), None)}
    for precision in ("fp32", "bf16"):
        folder = RUNS / precision
        run = config.with_(
            model_kwargs=shipped["model_kwargs"], loss=LossKind.MSE, data=tuple(subset), val=(),
            val_fraction=0.0, out_dir=str(folder), name="model", init_from=str(START), lr=args.lr,
            max_steps=args.steps, max_minutes=None, max_epochs=1000, early_stop_patience=None, seed=0,
            weights_dtype="float32", precision=precision,
        )  # fmt: skip
        started = time.monotonic()
        train(run, train_seqs, progress=False)
        seconds = (time.monotonic() - started) / args.steps
        rows[precision] = (*validation(final_weights(folder), windows), seconds)
        print(precision, rows[precision], flush=True)
    native, evidence = cpu_bf16()
    fp32, bf16 = rows["fp32"][0], rows["bf16"][0]
    lines = [
        "# Training in bf16 autocast against fp32 (the real loop, a fine-tune of the default)",
        "",
        f"Made by `nice -n 10 python -m experiments.probe_bf16_training --steps {args.steps} --out "
        f"docs/results/probes/bf16_training.md`; its docstring: method and the bar. CPU: native bf16 "
        f"{native} ({evidence}); one torch thread on two cores shared with seven other engineers' work, so "
        f"the seconds per step are noisy. {len(subset)} training walks (OxIOD, RIDI), {len(val)} validation "
        f"walks, {len(windows)} validation windows.",
        "",
        "| weights | validation MSE (fp32) | predicted / true speed | s per step (incl. data) |",
        "|---|--:|--:|--:|",
        *(
            f"| {name} | {mse:.5f} | {speed:.3f} | {'—' if sec is None else f'{sec:.2f}'} |"
            for name, (mse, speed, sec) in rows.items()
        ),
        "",
        f"bf16 against fp32: validation MSE {bf16 / fp32 - 1:+.2%} (bar {BAR:.0%}: "
        f"{'within' if abs(bf16 / fp32 - 1) <= BAR else 'outside'}); step time "
        f"{rows['bf16'][2] / rows['fp32'][2]:.2f}x fp32's.",
    ]
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
