"""Model cards: a short Markdown page beside each shipped checkpoint, rendered from its own JSON.

``python -m ftin.train.model_card CHECKPOINT.json [EVALUATION.json]`` prints the card; the
evaluation JSON is what ``ftin evaluate --json`` writes (validation metrics per sequence).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from ftin.metrics import HEADLINE_METRIC, Better, get_metric, list_metrics
from ftin.train.augment import resolve_augment

_INRIA = (
    "the Inria smartphone attitude benchmark (Michel, Genevès, Fourati, Layaïda, 'On Attitude Estimation "
    "with Smartphones', PerCom 2017; CeCILL licence)"
)
_CITATION = {
    "oxiod": "OxIOD (Chen et al., 'OxIOD: The Dataset for Deep Inertial Odometry', 2018), research use",
    "ridi": "RIDI (Yan, Shan, Furukawa, 'RIDI: Robust IMU Double Integration', ECCV 2018), research use",
    "pedestrian": "OxIOD (Chen et al., 2018) and RIDI (Yan et al., ECCV 2018) together, research use",
    "sim": "FTIN Studio's own pedestrian simulator (ftin/sim)",
    "inria_attitude": _INRIA,
    "walking": "OxIOD (Chen et al., 2018), RIDI (Yan et al., ECCV 2018) and " + _INRIA + " together",
}


def _dataset_of(meta: dict[str, Any]) -> str:
    """The citation key of the datasets the card records (``ftin.train.provenance``)."""
    datasets = (meta.get("training_data") or {}).get("datasets") or []
    if sorted(datasets) == ["oxiod", "ridi"]:
        return "pedestrian"
    if sorted(datasets) == ["inria_attitude", "oxiod", "ridi"]:
        return "walking"
    return datasets[0] if len(datasets) == 1 else " and ".join(datasets) or "unknown"


def render_model_card(meta: dict[str, Any], evaluation: dict[str, Any] | None = None) -> str:
    """The card for one checkpoint's JSON ``meta`` (and optionally its validation evaluation)."""
    config = meta.get("train_config", {})
    split = meta.get("split", {})
    dataset = _dataset_of(meta)
    lines = [
        f"# {config.get('name', meta['model_name'])}",
        "",
        f"- **Model:** `{meta['model_name']}` with `{json.dumps(meta.get('model_kwargs', {}))}`",
        f"- **Data:** {_CITATION.get(dataset, dataset)}",
        f"- **Training sequences ({len(split.get('train', []))}):** {', '.join(split.get('train', []))}",
        f"- **Validation sequences ({len(split.get('val', []))}):** {', '.join(split.get('val', []))}",
        f"- **Input:** {meta['window']} samples at {meta['imu_rate_hz']:g} Hz (stride {meta['stride']}), "
        f"gravity-aligned world frame, normalisation `{meta['normalization']['kind']}`, "
        f"output {meta['out_dim']}-D velocity",
        f"- **Hyper-parameters:** Adam lr {config.get('lr')}, batch {config.get('batch_size')}, "
        f"plateau factor {config.get('plateau_factor')} / patience {config.get('plateau_patience')}, "
        f"random yaw augmentation {config.get('augment_yaw')}{_more_augmentations(config)}, "
        f"seed {config.get('seed')}, "
        f"budget {config.get('max_minutes')} min on CPU",
        # The checkpoint kept is the best one, so these count up to it, not to the end of the run.
        f"- **Best checkpoint:** epoch {meta['epochs']}, {meta['steps']} steps, "
        f"{meta['wall_time_s'] / 60:.1f} min into the run, {meta.get('processes', 1)} process(es)",
        f"- **Best validation velocity MSE:** {meta['metrics'].get('val_mse', float('nan')):.4f} (m/s)²",
        f"- **Weights:** {config.get('weights_dtype', 'float32')} safetensors, upcast to float32 at load",
    ]
    if evaluation is not None:
        shown = list_metrics(in_tables=True)
        lines += [
            "",
            f"## Validation trajectories ({evaluation['description']})",
            "",
            "| sequence | " + " | ".join(m.header for m in shown) + " |",
            "|---|" + "---|" * len(shown),
        ]
        for row in evaluation["sequences"]:
            lines.append(f"| {row['name']} | " + " | ".join(m.format(row.get(m.name)) for m in shown) + " |")
        mean = evaluation["mean"]
        lines.append("| **mean** | " + " | ".join(f"**{m.format(mean.get(m.name))}**" for m in shown) + " |")
    return "\n".join(lines) + "\n"


def render_campaign_card(
    meta: dict[str, Any], record: dict[str, Any], seeds: list[dict[str, Any]], variant: str | None = None
) -> str:
    """The card of a checkpoint shipped by the training campaign (``ftin campaign ship``).

    ``record`` is the shipped job's (training summary, history, evaluation); ``seeds`` every seed's
    record of the same model and dataset, for the spread over seeds.
    """
    training, history = record["training"], record["history"]
    config = meta.get("train_config", {})
    split = meta.get("split", {})
    dataset = training["dataset"]
    # FTIN's TDL variant is what its weights were built with; a campaign's variant names it only when the
    # campaign chose it (Table 1), while other campaigns name their arms by it ("pooled", "sparse0.1")
    tdl = meta.get("model_kwargs", {}).get("fdl_output")
    chosen = ", chosen on validation" if variant == tdl else ""
    lines = [
        f"# {config.get('name', meta['model_name'])}",
        "",
        f"- **Model:** `{meta['model_name']}`"
        + (f" (TDL variant `{tdl}`{chosen})" if meta["model_name"] == "ftin" and tdl else "")
        + f" with `{json.dumps(meta.get('model_kwargs', {}))}`",
        f"- **Data:** {_CITATION.get(dataset, dataset)}; split and rules: docs/results/protocol.md",
        f"- **Training recordings ({len(split.get('train', []))}):** {', '.join(split.get('train', []))}",
        f"- **Validation recordings ({len(split.get('val', []))}):** {', '.join(split.get('val', []))}",
        f"- **Input:** {meta['window']} samples at {meta['imu_rate_hz']:g} Hz "
        f"(training stride {meta['stride']}), gravity-aligned world frame rotated by the "
        f"{config.get('orientation') or 'reader default'} orientation, "
        f"output {meta['out_dim']}-D velocity",
        f"- **Training:** Adam lr {config.get('lr')}, batch {config.get('batch_size')}, plateau factor "
        f"{config.get('plateau_factor')} / patience {config.get('plateau_patience')}, early stop after "
        f"{config.get('early_stop_patience')} epochs without a new best, at most {config.get('max_epochs')} "
        f"epochs, yaw augmentation{_more_augmentations(config)}, loss `{config.get('loss')}`, "
        f"seed {training['seed']} (best of "
        f"{len(seeds)} seed(s) on validation)",
        f"- **Run:** stopped by `{training['stop_reason']}` after {training['epochs']} epochs "
        f"({(training['wall_time_s'] or 0) / 60:.0f} min on 1 CPU thread); "
        f"best epoch {training['best_epoch']}; "
        f"learning rate decayed {training['lr_decays']} time(s)"
        + (
            " (the curve flattened)"
            if training["lr_decays"] >= 1
            else " (no decay: the curve may not have flattened)"
        ),
        f"- **Best validation MSE of 1 s velocity:** {training['best_val_mse']:.5f} (m/s)²",
        f"- **Weights:** {config.get('weights_dtype', 'float32')} safetensors, upcast to float32 at load",
        "",
        "## Validation curve",
        "",
        "| epoch | " + " | ".join(str(h["epoch"]) for h in history) + " |",
        "|---|" + "---|" * len(history),
        "| val MSE | " + " | ".join(f"{h['val_mse']:.4f}" for h in history) + " |",
        "| lr | " + " | ".join(f"{h['lr']:.0e}" for h in history) + " |",
    ]
    parts = record["evaluation"]["parts"]
    shown, headline = list_metrics(in_tables=True), get_metric(HEADLINE_METRIC)
    ratio_metric = next(m for m in shown if m.better is Better.ONE)
    for key in sorted(parts, key=lambda k: (k.split("/")[1] != "test", k)):
        rows = parts[key]
        ds, part, orientation = key.split("/")
        lines += [
            "",
            f"## {ds} {part}, {orientation.replace('_', '-')} orientation (RoNIN convention)",
            "",
            "| recording | " + " | ".join(m.header for m in shown) + f" | stand-still {headline.header} |",
            "|---|" + "---|" * (len(shown) + 1),
        ]
        for row in rows:
            cells = [m.format(row.get(m.name)) for m in shown]
            still = headline.format(row["stand_still"].get(headline.name))
            lines.append(f"| {row['name']} | " + " | ".join(cells) + f" | {still} |")
    if len(seeds) > 1:
        lines += [
            "",
            "## Seeds (mean over the test recordings, ground-truth orientation)",
            "",
            f"| seed | best val MSE | test {headline.header} | test {ratio_metric.label.lower()} |",
            "|---|---|---|---|",
        ]
        for other in sorted(seeds, key=lambda r: r["training"]["seed"]):
            test = [
                row
                for k, rows in other["evaluation"]["parts"].items()
                if k.split("/")[1] == "test" and k.endswith("ground_truth")
                for row in rows
            ]
            errors = [r[headline.name] for r in test if r.get(headline.name) is not None]
            ratios = [r[ratio_metric.name] for r in test if r.get(ratio_metric.name) is not None]
            error = sum(errors) / len(errors) if errors else None
            ratio = sum(ratios) / len(ratios) if ratios else None
            lines.append(
                f"| {other['training']['seed']} | {other['training']['best_val_mse']:.5f} | "
                f"{headline.format(error)} | {ratio_metric.format(ratio)} |"
            )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    args = sys.argv[1:] if argv is None else argv
    if not 1 <= len(args) <= 2:
        sys.exit("usage: python -m ftin.train.model_card CHECKPOINT.json [EVALUATION.json]")
    meta = json.loads(Path(args[0]).read_text())
    evaluation = json.loads(Path(args[1]).read_text()) if len(args) == 2 else None
    sys.stdout.write(render_model_card(meta, evaluation))


if __name__ == "__main__":
    main()


def _more_augmentations(config: dict[str, Any]) -> str:
    """`` + tilt 5, vertical 0.3`` for the augmentations beyond yaw (``ftin.train.augment``), else ''."""
    augment = resolve_augment(config.get("augment") or {})
    return "".join(f" + {name} {value:g}" for name, value in augment.items())
