"""Does a loss on the segments between waypoints teach the default a long stride? (issue 54, item 2)

Question: the default reads the ILC mall walks short (``ilc_baseline.md``). Sparse truth carries no
velocity per window, but each segment between two waypoints has a length and each pair of segments a
turn, neither of which needs the map's heading. Does fine-tuning on them, mixed with the dense-truth
training walks, lengthen walks on floors it never saw without hurting the dense validation sets?

Method (a fine-tune of minutes, not a campaign): every arm starts from ``checkpoints/ronin_resnet-walking``
and trains for ``--steps`` optimizer steps (a step budget: the two cores are shared, so minutes would
buy each arm a different number of steps), Adam at ``--lr``, seed 0, one torch thread, bf16 autocast
(this CPU has avx512_bf16 / amx_bf16; the forward and backward in bf16, the weights and the loss in fp32),
train mode; the weights at the end of the budget are scored (no choice on any walk). Each step is one
forward over a batch that joins

- ``--dense`` windows of the default's own training walks (its JSON's ``train_config.data``; oriented by
  the reference as it trained, random yaw, the MSE of the velocity), and
- ``--chunks`` chunks of ILC training walks (floors ``TRAIN_FLOORS``): a chunk is two consecutive
  segments of 2 m or more between three waypoints; windows centred every ``SPARSE_STEP_S`` along each
  segment, oriented by ``auto`` (VQF: the files hold no attitude), one random yaw per chunk; the
  predicted displacement of a segment is the mean window velocity times its duration. Loss per segment
  ``(log |d_pred| - log L)^2``, per chunk ``TURN_WEIGHT * (1 - cos(turn_pred - turn_true))``.

With ``--freeze-bn`` the batch-norm layers keep the shipped statistics (eval mode) while the rest trains:
the second round, run after the first (whose fine-tunes, batch norm moving on batches of 32 dense windows
plus ILC chunks, hurt every set) with ``--tag=-frozen-bn``.

Arms: ``reference`` (untouched), ``dense`` (the dense windows alone: what fine-tuning itself does) and
``sparse+dense``. Held out: ILC floors ``VAL_FLOORS`` (every ``--every``-th walk), scored at the waypoints
(``ftin.evaluate_sparse``); the dense validation walks of the default's JSON (OxIOD, RIDI, every 4th Inria
walk), phone only, scored as ``probe_new_oxiod_walks.walk_row`` scores (ATE, RoNIN convention).

The rule, written before any arm was read: ``sparse+dense`` is adopted for the retrain's recipe when on
each held-out floor its median path ratio is closer to 1 than both ``reference``'s and ``dense``'s, and no
dense validation set's mean ATE is worse than ``reference``'s by more than 5 %.

    nice -n 10 python -m experiments.probe_sparse_truth --steps 150 --out docs/results/probes/sparse_truth.md

Each arm's result is cached in ``runs/probes/sparse_truth/<arm>.json`` (delete it to run the arm again).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch

from experiments.common import argument_parser, parse, write_report
from experiments.probe_new_oxiod_walks import walk_row
from ftin.checkpoint import LoadedModel, load_model, save_checkpoint
from ftin.data.discovery import read_sequence
from ftin.data.loading import load_phone_only, load_sequences
from ftin.data.prepare import prepare
from ftin.data.types import ImuSequence
from ftin.data.windows import WindowDataset
from ftin.evaluate_sparse import evaluate_waypoints
from ftin.files import DEFAULT_DATA_ROOT
from ftin.train.augment import WindowAugmenter
from ftin.train.sparse_truth import segment_loss  # the loss the campaign trains with

START = Path("checkpoints/ronin_resnet-walking")
RUNS = Path("runs/probes/sparse_truth")
TRAIN_FLOORS = ("F1", "F2", "F3")
VAL_FLOORS = ("B1", "F4")
MIN_SEGMENT_M = 2.0
SPARSE_STEP_S = 0.5
WORSE_AT_MOST = 0.05
ARMS = ("reference", "dense", "sparse+dense")


def ilc_paths(data_root: Path, floors: tuple[str, ...], every: int = 1) -> list[Path]:
    return [p for f in floors for p in sorted((data_root / "ilc" / "site1" / f).glob("*.txt.xz"))[::every]]


class SparseChunks:
    """Chunks of two segments of the ILC training walks, with their windows' starts (class docstring of
    the module: what a chunk is)."""

    def __init__(self, sequences: list[ImuSequence], rate_hz: float, window: int) -> None:
        self.window = window
        self.imu: list[np.ndarray] = []
        self.chunks: list[tuple[int, list[np.ndarray], np.ndarray]] = []  # walk, starts per segment, marks
        for seq in sequences:
            prepared = prepare(seq, rate_hz, window, window)  # auto orientation: VQF
            imu, t = prepared.imu_world.astype(np.float32), prepared.seq.t_s
            marks = seq.waypoints.within(t[0] + 0.5, t[-1] - 0.5)
            if len(marks) < 3:
                continue
            walk = len(self.imu)
            self.imu.append(imu)
            for k in range(len(marks) - 2):
                xy, tk = marks.xy_map_m[k : k + 3], marks.t_s[k : k + 3]
                if min(np.linalg.norm(np.diff(xy, axis=0), axis=1)) < MIN_SEGMENT_M:
                    continue
                starts = []
                for a, b in ((tk[0], tk[1]), (tk[1], tk[2])):
                    centres = np.arange(a + SPARSE_STEP_S / 2, b, SPARSE_STEP_S)
                    first = np.searchsorted(t, centres) - window // 2
                    starts.append(np.clip(first, 0, len(imu) - window))
                self.chunks.append((walk, starts, np.concatenate([xy, tk[:, None]], axis=1)))

    def batch(
        self, rng: np.random.Generator, count: int
    ) -> tuple[torch.Tensor, list[tuple[int, int, np.ndarray]]]:
        """``(x (W, 6, L), layout)``: the windows of ``count`` random chunks, each turned by one random yaw,
        and per chunk (windows of segment 1, of segment 2, its marks (3, 3): x, y, t)."""
        xs, layout = [], []
        for i in rng.integers(0, len(self.chunks), count):
            walk, starts, marks = self.chunks[i]
            rows = np.concatenate(starts)[:, None] + np.arange(self.window)[None, :]
            x = self.imu[walk][rows].transpose(0, 2, 1).copy()  # (W, 6, L)
            yaw = rng.uniform(-math.pi, math.pi)
            c, s = math.cos(yaw), math.sin(yaw)
            for j in (0, 3):  # gyro and specific force: turn x, y about the vertical
                x0, x1 = x[:, j].copy(), x[:, j + 1].copy()
                x[:, j], x[:, j + 1] = c * x0 - s * x1, s * x0 + c * x1
            xs.append(x)
            layout.append((len(starts[0]), len(starts[1]), marks))
        return torch.from_numpy(np.concatenate(xs)), layout


def default_training_windows(data_root: Path, augment: dict | None = None) -> WindowDataset:
    """The default's own training walks as it trained on them (its JSON's data, orientation, window
    stride 20), random yaw, seed 0, and ``augment`` (its recipe's when None)."""
    recipe = json.loads(START.with_suffix(".json").read_text())["train_config"]
    seqs = load_sequences([data_root / r for r in recipe["data"]], "dense", recipe["orientation"])
    prepared = [prepare(s, 100.0, orientation=recipe["orientation"]).seq for s in seqs]
    augmenter = WindowAugmenter(recipe["augment"] if augment is None else augment, 20, 0)
    return WindowDataset(prepared, 100, 20, 2, augment_yaw=True, seed=0, augmenter=augmenter)


def fine_tune(
    arm: str, dense: WindowDataset, sparse: SparseChunks | None, args: Any, sparse_weight: float = 1.0
) -> tuple[LoadedModel, dict[str, Any]]:
    """The default fine-tuned for ``args.steps`` steps (module docstring); ``sparse_weight`` scales the
    segment term (1 in this probe's own arms)."""
    loaded = load_model(START)
    model = loaded.model
    model.train()
    if args.freeze_bn:  # keep the shipped normalisation statistics: small mixed batches must not move them
        for module in model.modules():
            if isinstance(module, torch.nn.modules.batchnorm._BatchNorm):
                module.eval()
    optimizer = torch.optim.Adam(model.parameters(), lr=args.lr)
    rng = np.random.default_rng(0)
    torch.manual_seed(0)
    started, steps, history = time.monotonic(), 0, []
    while steps < args.steps:
        x_dense, v_dense = dense.get_batch(rng.integers(0, len(dense), args.dense))
        x, layout = x_dense, None
        if sparse is not None:
            x_sparse, layout = sparse.batch(rng, args.chunks)
            x = torch.cat([x_dense, x_sparse])
        with torch.autocast("cpu", dtype=torch.bfloat16):
            out = model(x)
        velocity = out.velocity.float()
        dense_loss = ((velocity[: len(x_dense)] - v_dense.reshape(len(x_dense), -1)) ** 2).mean()
        loss = dense_loss
        sparse_value = None
        if layout is not None:
            term = segment_loss(velocity[len(x_dense) :], layout)
            loss = loss + sparse_weight * term
            sparse_value = float(term.detach())
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        steps += 1
        history.append([float(dense_loss.detach()), sparse_value])
    model.eval()
    first, last = history[: max(1, len(history) // 5)], history[-max(1, len(history) // 5) :]

    def mean_of(rows: list, k: int) -> float | None:
        values = [r[k] for r in rows if r[k] is not None]
        return float(np.mean(values)) if values else None

    info = {
        "steps": steps,
        "minutes": (time.monotonic() - started) / 60,
        "dense_loss_first_fifth": mean_of(first, 0),
        "dense_loss_last_fifth": mean_of(last, 0),
        "sparse_loss_first_fifth": mean_of(first, 1),
        "sparse_loss_last_fifth": mean_of(last, 1),
    }
    return loaded, info


def fine_tune_arguments(parser: Any, steps: int) -> None:
    """The fine-tune's budget on a probe's command line (the probes built on ``fine_tune``)."""
    parser.add_argument("--steps", type=int, default=steps, help="optimizer steps per fine-tuned arm")
    parser.add_argument("--lr", type=float, default=1e-4)
    parser.add_argument("--dense", type=int, default=64, help="dense windows per step")


def fine_tuned_once(stem: Path, train: Callable[[], tuple[LoadedModel, dict[str, Any]]]) -> dict[str, Any]:
    """The training record of the network saved at ``stem``: ``train`` runs only when no record is there
    (the network is saved beside it as ``<stem>.safetensors`` and ``.json``)."""
    record = Path(f"{stem}.training.json")
    if not record.exists():
        print(f"{stem.name}: fine-tuning", flush=True)
        loaded, info = train()
        save_checkpoint(stem, loaded.model, loaded.meta)
        record.write_text(json.dumps(info))
    return json.loads(record.read_text())


def score(
    loaded: LoadedModel, floors: dict[str, list[ImuSequence]], dense_val: list[tuple[str, str, ImuSequence]]
):
    rows = {"floors": {}, "dense": []}
    for floor, seqs in floors.items():
        report = evaluate_waypoints(loaded, seqs)
        rows["floors"][floor] = [
            {
                "walk": r.name,
                "ratio": r.metrics.path_ratio,
                "ate": r.metrics.ate_m,
                "segment": r.metrics.median_segment_ratio,
            }
            for r in report.sequences
        ]
        print(f"  {floor}: median path ratio {report.summary()['median_path_ratio']:.3f}", flush=True)
    for group, rel, seq in dense_val:
        row = walk_row(loaded, rel, seq)
        row["set"] = group
        rows["dense"].append(row)
    return rows


def dense_validation(data_root: Path) -> list[tuple[str, str, ImuSequence]]:
    val = json.loads(START.with_suffix(".json").read_text())["train_config"]["val"]
    inria = [r for r in val if r.startswith("inria")][::4]
    chosen = [
        *(("OxIOD", r) for r in val[:2]),
        *(("RIDI", r) for r in val if r.startswith("ridi")),
        *(("Inria", r) for r in inria),
    ]
    seqs = load_phone_only([data_root / r for _, r in chosen], "dense validation walks")
    return [(g, r, s) for (g, r), s in zip(chosen, seqs, strict=True)]


def summary_lines(results: dict[str, dict]) -> list[str]:
    lines = [
        "| arm | steps | minutes | dense loss first -> last fifth | sparse loss first -> last fifth "
        + "".join(f"| {f} path ratio median (in 0.85-1.15) " for f in VAL_FLOORS)
        + "| OxIOD ATE | RIDI ATE | Inria ATE |",
        "|---|--:|--:|---|---|" + "--:|" * (len(VAL_FLOORS) + 3),
    ]
    ref = results["reference"]
    for arm, r in results.items():
        info = r.get("training", {})

        def pair(a: str, b: str, info: dict = info) -> str:
            x, y = info.get(a), info.get(b)
            return "—" if x is None else f"{x:.3f} -> {y:.3f}"

        cells = [arm, str(info.get("steps", 0)), f"{info.get('minutes', 0):.1f}"]
        cells.append(pair("dense_loss_first_fifth", "dense_loss_last_fifth"))
        cells.append(pair("sparse_loss_first_fifth", "sparse_loss_last_fifth"))
        for floor in VAL_FLOORS:
            ratios = [w["ratio"] for w in r["rows"]["floors"][floor] if w["ratio"] is not None]
            inside = sum(0.85 <= x <= 1.15 for x in ratios)
            cells.append(f"{np.median(ratios):.3f} ({inside} of {len(ratios)})")
        for group in ("OxIOD", "RIDI", "Inria"):
            ate = np.mean([w["ate"] for w in r["rows"]["dense"] if w["set"] == group])
            base = np.mean([w["ate"] for w in ref["rows"]["dense"] if w["set"] == group])
            cells.append(f"{ate:.3f} ({ate / base - 1:+.1%})")
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def main() -> None:
    parser = argument_parser(__doc__)
    parser.add_argument("--steps", type=int, default=150, help="optimizer steps per arm (a busy machine)")
    parser.add_argument("--lr", type=float, default=1e-4)
    parser.add_argument("--dense", type=int, default=32, help="dense windows per step")
    parser.add_argument("--chunks", type=int, default=2, help="ILC chunks per step")
    parser.add_argument("--every", type=int, default=4, help="every k-th walk of a held-out floor")
    parser.add_argument("--freeze-bn", action="store_true", help="batch norm statistics as shipped")
    parser.add_argument(
        "--tag", default="", help="suffix of the fine-tuned arms' cache files (a second round)"
    )
    parser.add_argument("--data-root", type=Path, default=DEFAULT_DATA_ROOT)
    parser.add_argument("--out", type=Path, default=None)
    args = parse(parser)
    started = time.monotonic()
    floors = {f: [read_sequence(p) for p in ilc_paths(args.data_root, (f,), args.every)] for f in VAL_FLOORS}
    dense_val = dense_validation(args.data_root)
    RUNS.mkdir(parents=True, exist_ok=True)
    results: dict[str, dict] = {}
    dense = sparse = None
    for arm in ARMS:
        cache = RUNS / f"{arm.replace('+', '-')}{'' if arm == 'reference' else args.tag}.json"
        if cache.exists():
            results[arm] = json.loads(cache.read_text())
            continue
        print(f"{arm}:", flush=True)
        if arm == "reference":
            loaded, info = load_model(START), {}
        else:
            if dense is None:
                dense = default_training_windows(args.data_root)
            if arm == "sparse+dense" and sparse is None:
                sparse = SparseChunks(
                    [read_sequence(p) for p in ilc_paths(args.data_root, TRAIN_FLOORS)], 100.0, 100
                )
                print(f"  {len(sparse.chunks)} ILC chunks from {len(sparse.imu)} walks", flush=True)
            loaded, info = fine_tune(arm, dense, sparse if arm == "sparse+dense" else None, args)
            print(f"  trained: {info}", flush=True)
        results[arm] = {"training": info, "rows": score(loaded, floors, dense_val)}
        cache.write_text(json.dumps(results[arm]))
    minutes = (time.monotonic() - started) / 60
    lines = [
        "# A loss on the segments between waypoints (ILC), mixed with dense truth: a fine-tune of minutes",
        "",
        f"Made by `nice -n 10 python -m experiments.probe_sparse_truth --steps {args.steps} --lr {args.lr:g} "
        f"--dense {args.dense}{' --freeze-bn' if args.freeze_bn else ''}"
        f"{f' --tag={args.tag}' if args.tag else ''} --out {args.out}` ({minutes:.0f} min in all this run, "
        "two shared cores). Its "
        "docstring: method and the rule, written before any arm was read. Held-out floors "
        f"{', '.join(VAL_FLOORS)} "
        f"(every {args.every}th walk); dense validation phone only, change against `reference` in brackets.",
        "",
        *summary_lines(results),
    ]
    write_report(args.out, lines)


if __name__ == "__main__":
    main()
