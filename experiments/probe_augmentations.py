"""Which training augmentations (``ftin.train.augment``) help on walkers the model has never seen?

    nice -n 10 .venv/bin/python -m experiments.probe_augmentations --phase arms
    nice -n 10 .venv/bin/python -m experiments.probe_augmentations --phase best
    nice -n 10 .venv/bin/python -m experiments.probe_augmentations --phase seeds --arms ARM ...
    .venv/bin/python -m experiments.probe_augmentations --phase summary
    nice -n 10 .venv/bin/python -m experiments.probe_augmentations --fold 0 --stride 50 \
        --phase seeds --arms yaw_only pace --seeds 0 1
    .venv/bin/python -m experiments.probe_augmentations --fold 0 --epochs 10 --phone-only \
        --phase seeds --arms mirror mirror_tilt --seeds 0

A short-budget probe, not a campaign: RoNIN ResNet, 1 s windows at 100 Hz every 0.2 s, batch 128,
Adam 1e-3, ``EPOCHS`` epochs (390 steps, about 4 min of one thread), ground-truth orientation, yaw
augmentation always; one arm per augmentation (``ARMS``), all of them together, and the yaw-only
baseline. Walker-held-out split (no test recording of ``ftin.protocol`` is read):
- train: OxIOD handheld/data1 imu2, imu4 and the trolley training recordings; RIDI walkers dan and
  hao (the protocol's training part);
- validation walkers: OxIOD user2 (imu4, imu5), RIDI hang and ma (every recording of theirs outside
  the test part). The best epoch is picked on them too (the same rule for every arm).
With ``--fold K`` the split is the walking dataset's walker fold K instead (``ftin.protocol``: OxIOD,
RIDI and Inria, whose pockets, swinging and running the first split lacks; the test parts unread),
``--stride`` sets the training windows' spacing (fewer windows per epoch at the same epochs);
``--phone-only`` scores the validation walkers phone only as well (``auto`` orientation, as a phone
export gives them), for what orientation errors cost each arm.
Each run lands in ``runs/probes/augment[-f<K>]/<arm>-s<seed>/`` with ``result.json``: per validation
walker the mean ATE (``ftin.evaluate.score``, RoNIN's convention), the mean path ratio and the mean
error of the predicted window velocities (m/s); per carry mode (Inria's motion, else the reader's
carry) the same and the speed ratio (mean predicted / mean true speed over the prediction spans).
Phase ``arms`` trains every arm with seed 0 and the baseline with seeds 0 and 1 (``ORDER``); phase
``best`` adds seed 1 of the arm with the lowest mean ATE at seed 0;
phase ``seeds`` runs ``--arms`` (default: the baseline) with ``--seeds`` (default 2 3), for arms
whose seeds disagree; ``summary`` writes the table (``--out``). Finished runs are skipped, so phases
can be re-run.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from experiments.common import argument_parser, parse
from ftin import protocol
from ftin.checkpoint import load_model
from ftin.data.loading import load_phone_only, load_sequences
from ftin.evaluate import score
from ftin.files import DEFAULT_DATA_ROOT
from ftin.infer import predict_trajectory
from ftin.train.config import TrainConfig
from ftin.train.loop import train

RUNS = Path("runs/probes/augment")
EPOCHS = 6
VAL_WALKERS = {protocol.OXIOD: ("user2",), protocol.RIDI: ("hang", "ma")}


def walker_split(fold: int | None = None) -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
    """``(dataset, recording)`` pairs for training and validation. Without a fold: the protocol's
    training part without the validation walkers, and every recording of theirs outside the test
    part; with one: the walking dataset's walker fold (``protocol.fold_parts``)."""
    train, val = [], []
    if fold is not None:
        for dataset in protocol.COMBINED[protocol.WALKING]:
            parts = protocol.fold_parts(dataset, fold)
            train += [(dataset, r) for r in parts["train"]]
            val += [(dataset, r) for r in parts["val"]]
        return train, val
    for dataset, held in VAL_WALKERS.items():
        parts = protocol.SPLITS[dataset]
        train += [(dataset, r) for r in parts["train"] if protocol.walker(dataset, r) not in held]
        val += [(dataset, r) for r in (*parts["train"], *parts["val"]) if protocol.walker(dataset, r) in held]
    return train, val


TRAIN, VAL = walker_split()
ARMS: dict[str, dict[str, float | None]] = {
    "yaw_only": {},
    "shift": {"shift": None},
    "bias": {"acc_bias": None, "gyro_bias": None},
    "tilt": {"tilt": None},
    "noise": {"acc_noise": None, "gyro_noise": None},
    "vertical": {"vertical": None},
    "orientation": {"orientation": None},
    "mirror": {"mirror": None},
    "pace": {"pace": None},
    # the default's recipe (stage two: RoNIN ResNet + mirror) with an orientation error on top, for what
    # a phone alone costs it (``--phone-only``; docs/results/probes/phone_cost.md: on OxIOD the tilt)
    "mirror_tilt": {"mirror": None, "tilt": None},
    "mirror_orientation": {"mirror": None, "orientation": None},
    "speed_loss": {},  # no augmentation beyond yaw: the loss changes (ARM_OPTIONS)
    "sim_walks": {},  # no augmentation beyond yaw: simulated walks join the training data (ARM_DATA)
    "all": {
        "shift": None,
        "acc_bias": None,
        "gyro_bias": None,
        "tilt": None,
        "acc_noise": None,
        "gyro_noise": None,
        "vertical": None,
        "orientation": None,
    },
}
# Training options an arm changes besides its augmentations.
ARM_OPTIONS: dict[str, dict[str, Any]] = {
    "speed_loss": {"speed_weight": 1.0},
    # the real walks are read with their reference already (``load_sequences``); the simulated ones
    # carry their true orientation as the device's, which no "ground_truth" choice accepts
    "sim_walks": {"orientation": None},
}
# Training data an arm adds: ``ftin sim --out runs/probes/sim-walks --count 24 --seed 1000`` (seeds
# disjoint from the bundled samples': handheld, pocket and trolley at 0.8-1.6 m/s).
ARM_DATA: dict[str, Path] = {"sim_walks": Path("runs/probes/sim-walks")}
BASELINE = "yaw_only"
ORDER = (
    "vertical",
    "all",
    "orientation",
    "tilt",
    "bias",
    "noise",
    "shift",
    "mirror",
    "pace",
)  # likeliest first


def paths(split: list[tuple[str, str]], root: Path) -> list[Path]:
    return [root / protocol.DATA_FOLDERS[dataset] / rel for dataset, rel in split]


def walker_labels(split: list[tuple[str, str]]) -> list[str]:
    """``oxiod user2``, ``ridi hang``: a result's walker keys, one per recording."""
    return [f"{dataset} {protocol.walker(dataset, rel)}" for dataset, rel in split]


def span_velocities(prediction) -> tuple[np.ndarray, np.ndarray]:
    """``(predicted, true)`` horizontal mean velocities over the prediction spans, ``(M, 2)`` each."""
    seq = prediction.prepared.seq
    t0, t1 = prediction.span_t_s[:, 0], prediction.span_t_s[:, 1]
    p = seq.gt.p_world_m[:, :2]
    true = np.stack([(np.interp(t1, seq.t_s, p[:, k]) - np.interp(t0, seq.t_s, p[:, k])) for k in (0, 1)], 1)
    return prediction.velocity_m_s[:, :2], true / (t1 - t0)[:, None]


def carry_of(seq) -> str:
    """Inria's motion (AR, Swinging, RunningPocket, ...), else the reader's carry mode."""
    return str(seq.meta.get("motion") or seq.meta.get("carry") or "unknown")


def evaluate_run(checkpoint: Path, val_sequences, labels: list[str]) -> dict[str, Any]:
    loaded = load_model(checkpoint)
    rows = []
    for seq, walker in zip(val_sequences, labels, strict=True):
        prediction = predict_trajectory(loaded, seq)
        metrics = score(prediction).metrics
        predicted, true = span_velocities(prediction)
        rows.append(
            {
                "name": seq.name,
                "walker": walker,
                "carry": carry_of(seq),
                "ate": metrics.ate,
                "path_ratio": metrics.path_length_ratio,
                "velocity_error": float(np.linalg.norm(predicted - true, axis=1).mean()),
                "predicted_speed": float(np.linalg.norm(predicted, axis=1).mean()),
                "true_speed": float(np.linalg.norm(true, axis=1).mean()),
            }
        )
    keys = ("ate", "path_ratio", "velocity_error")
    walkers: dict[str, dict[str, float]] = {}
    for name in sorted({r["walker"] for r in rows}):
        mine = [r for r in rows if r["walker"] == name]
        walkers[name] = {k: float(np.mean([r[k] for r in mine])) for k in keys}
    modes: dict[str, dict[str, float]] = {}
    for mode in sorted({r["carry"] for r in rows}):
        mine = [r for r in rows if r["carry"] == mode]
        modes[mode] = {k: float(np.mean([r[k] for r in mine])) for k in keys}
        speeds = [(r["predicted_speed"], r["true_speed"]) for r in mine]
        modes[mode]["speed_ratio"] = float(np.mean([p for p, _ in speeds]) / np.mean([t for _, t in speeds]))
        modes[mode]["recordings"] = len(mine)
    mean_ate = float(np.mean([w["ate"] for w in walkers.values()]))
    return {"sequences": rows, "walkers": walkers, "modes": modes, "mean_walker_ate": mean_ate}


def run_arm(arm: str, seed: int, train_seqs, val_seqs, stride: int = 20, phone_seqs=None) -> dict[str, Any]:
    folder = RUNS / f"{arm}-s{seed}"
    result_path = folder / "result.json"
    if result_path.exists():
        return json.loads(result_path.read_text())
    if folder.exists():  # an interrupted run: start it again
        shutil.rmtree(folder)
    extra = [ARM_DATA[arm]] if arm in ARM_DATA else []
    if extra:
        train_seqs = [*train_seqs, *load_sequences(extra, orientation="ground_truth")]
    config = TrainConfig(
        model="ronin_resnet",
        data=tuple(str(p) for p in [*paths(TRAIN, DEFAULT_DATA_ROOT), *extra]),
        val=tuple(str(p) for p in paths(VAL, DEFAULT_DATA_ROOT)),
        out_dir=str(folder),
        name="model",
        imu_rate_hz=100.0,
        window=100,
        stride=stride,
        batch_size=128,
        lr=1e-3,
        plateau_factor=0.3,
        plateau_patience=3,
        max_epochs=EPOCHS,
        seed=seed,
        augment_yaw=True,
        augment=ARMS[arm],
        **{"orientation": "ground_truth", **ARM_OPTIONS.get(arm, {})},
    )
    trained = train(config, train_seqs, val_seqs, progress=False)
    if not trained.finished:  # stopped by a signal: no result, so a re-run trains it again
        raise SystemExit(f"{arm} s{seed}: stopped ({trained.stop_reason}) before its {EPOCHS} epochs")
    result = {
        "arm": arm,
        "seed": seed,
        "augment": ARMS[arm],
        "steps": trained.steps,
        "epochs": trained.epochs_done,
        "best_val_mse": trained.best_val_loss,
        "train_seconds": trained.history[-1]["elapsed_s"] if trained.history else None,
        "stride": stride,
        **evaluate_run(trained.checkpoint, val_seqs, walker_labels(VAL)),
    }
    if phone_seqs is not None:  # the same walkers as a phone export gives them (``auto`` orientation)
        result["phone_only"] = evaluate_run(trained.checkpoint, phone_seqs, walker_labels(VAL))
    result_path.write_text(json.dumps(result, indent=2) + "\n")
    print(f"{arm} s{seed}: mean walker ATE {result['mean_walker_ate']:.3f} m", flush=True)
    return result


def finished() -> list[dict[str, Any]]:
    return [json.loads(p.read_text()) for p in sorted(RUNS.glob("*/result.json"))]


def best_arm(results: list[dict[str, Any]]) -> str:
    seed0 = [r for r in results if r["seed"] == 0 and r["arm"] != BASELINE]
    return min(seed0, key=lambda r: r["mean_walker_ate"])["arm"]


def mean_velocity_error(result: dict[str, Any]) -> float:
    return float(np.mean([w["velocity_error"] for w in result["walkers"].values()]))


def summary(results: list[dict[str, Any]]) -> str:
    walkers = sorted({w for r in results for w in r["walkers"]})
    base = [r["mean_walker_ate"] for r in results if r["arm"] == BASELINE]
    base_mean = float(np.mean(base)) if base else float("nan")
    head = "| arm | seed | " + " | ".join(f"{w} ATE / ratio / vel err" for w in walkers)
    lines = [head + " | mean ATE | vs yaw only | mean vel err |", "|" + "---|" * (len(walkers) + 5)]
    for r in sorted(results, key=lambda r: (list(ARMS).index(r["arm"]), r["seed"])):
        cells = [
            "{ate:.2f} / {path_ratio:.2f} / {velocity_error:.3f}".format(**r["walkers"][w]) for w in walkers
        ]
        change = 100.0 * (r["mean_walker_ate"] / base_mean - 1.0)
        lines.append(
            f"| {r['arm']} | {r['seed']} | "
            + " | ".join(cells)
            + f" | {r['mean_walker_ate']:.3f} | {change:+.1f} % | {mean_velocity_error(r):.3f} |"
        )
    means = []
    for arm in ARMS:
        ates = [r["mean_walker_ate"] for r in results if r["arm"] == arm]
        if len(ates) > 1:
            each = ", ".join(f"{a:.3f}" for a in ates)
            vel = np.mean([mean_velocity_error(r) for r in results if r["arm"] == arm])
            means.append(
                f"- {arm}: {len(ates)} seeds, mean walker ATE {np.mean(ates):.3f} m (seeds {each}), "
                f"mean velocity error {vel:.3f} m/s"
            )
    text = "\n".join(lines) + ("\n\nArms with several seeds:\n" + "\n".join(means) if means else "") + "\n"
    return text + carry_summary(results) + phone_only_summary(results)


def phone_only_summary(results: list[dict[str, Any]]) -> str:
    """Runs scored phone only too (``--phone-only``): per walker, ATE with ground-truth orientation /
    phone only, and the mean over walkers of the phone-only ATE over the ground-truth one."""
    results = [r for r in results if "phone_only" in r]
    if not results:
        return ""
    walkers = sorted({w for r in results for w in r["walkers"]})
    lines = [
        "",
        "Phone only (`auto` orientation from the phone's own sensors): per walker, ATE (m) with the",
        "ground-truth orientation / phone only; last columns the means over walkers and their ratio:",
        "",
        "| arm | seed | " + " | ".join(walkers) + " | mean ATE truth / phone | phone / truth |",
        "|---|---|" + "--:|" * (len(walkers) + 2),
    ]
    for r in sorted(results, key=lambda r: (list(ARMS).index(r["arm"]), r["seed"])):
        truth = [r["walkers"][w]["ate"] for w in walkers]
        phone = [r["phone_only"]["walkers"][w]["ate"] for w in walkers]
        cells = [f"{t:.2f} / {p:.2f}" for t, p in zip(truth, phone, strict=True)]
        lines.append(
            f"| {r['arm']} | {r['seed']} | "
            + " | ".join(cells)
            + f" | {np.mean(truth):.3f} / {np.mean(phone):.3f} | {np.mean(phone) / np.mean(truth):.2f}x |"
        )
    return "\n".join(lines) + "\n"


def carry_summary(results: list[dict[str, Any]]) -> str:
    """Per carry mode and arm (mean over seeds): speed ratio, path ratio, velocity error, ATE."""
    results = [r for r in results if "modes" in r]
    if not results:
        return ""
    arms = [arm for arm in ARMS if any(r["arm"] == arm for r in results)]
    modes = sorted({m for r in results for m in r["modes"]})
    lines = [
        "",
        "Per carry mode, mean over seeds: speed ratio (mean predicted / mean true speed) / path ratio / "
        "velocity error (m/s) / ATE (m):",
        "",
        "| carry | recordings | "
        + " | ".join(f"{arm} ({sum(r['arm'] == arm for r in results)})" for arm in arms)
        + " |",
        "|---|--:|" + "---|" * len(arms),
    ]
    for mode in modes:
        cells, count = [], 0
        for arm in arms:
            mine = [r["modes"][mode] for r in results if r["arm"] == arm and mode in r["modes"]]
            count = max(count, *(m["recordings"] for m in mine)) if mine else count
            keys = ("speed_ratio", "path_ratio", "velocity_error", "ate")
            means = [np.mean([m[k] for m in mine]) for k in keys] if mine else None
            cells.append("{:.2f} / {:.2f} / {:.3f} / {:.2f}".format(*means) if means else "-")
        lines.append(f"| {mode} | {count} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    global RUNS, TRAIN, VAL, EPOCHS  # a fold's split and budget replace the module's
    parser = argument_parser(__doc__)
    parser.add_argument("--phase", choices=("arms", "best", "seeds", "summary"), required=True)
    parser.add_argument("--seeds", type=int, nargs="*", default=[2, 3], help="phase seeds: these seeds")
    parser.add_argument(
        "--arms", nargs="*", default=None, help="only these arms (default: all; best: the best)"
    )
    parser.add_argument("--out", type=Path, default=None, help="summary (default: the runs folder's)")
    parser.add_argument("--fold", type=int, default=None, help="the walking dataset's walker fold")
    parser.add_argument("--stride", type=int, default=20, help="training windows every N samples")
    parser.add_argument("--epochs", type=int, default=EPOCHS, help=f"epochs per run (default {EPOCHS})")
    parser.add_argument(
        "--phone-only", action="store_true", help="score the validation walkers phone only as well"
    )
    args = parse(parser)
    EPOCHS = args.epochs
    if args.fold is not None:
        RUNS = Path(f"runs/probes/augment-f{args.fold}" + (f"-e{EPOCHS}" if EPOCHS != 6 else ""))
        TRAIN, VAL = walker_split(args.fold)
    args.out = args.out or RUNS / "summary.md"
    if args.phase == "summary":
        text = summary(finished())
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text)
        print(text)
        return
    train_seqs = load_sequences(paths(TRAIN, DEFAULT_DATA_ROOT), orientation="ground_truth")
    val_seqs = load_sequences(paths(VAL, DEFAULT_DATA_ROOT), orientation="ground_truth")
    phone_seqs = load_phone_only(paths(VAL, DEFAULT_DATA_ROOT)) if args.phone_only else None
    if args.phase == "arms":
        arms = [arm for arm in (args.arms or ORDER) if arm != BASELINE]
        plan = [(BASELINE, 0), *[(arm, 0) for arm in arms], (BASELINE, 1)]
    elif args.phase == "seeds":
        plan = [(arm, seed) for seed in args.seeds for arm in (args.arms or [BASELINE])]
    else:
        plan = [(arm, 1) for arm in (args.arms or [best_arm(finished())])]
    for arm, seed in plan:
        run_arm(arm, seed, train_seqs, val_seqs, args.stride, phone_seqs)


if __name__ == "__main__":
    main()
