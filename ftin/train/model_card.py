"""Model cards: a short Markdown page beside each shipped checkpoint, rendered from its own JSON.

``python -m ftin.train.model_card CHECKPOINT.json [EVALUATION.json]`` prints the card; the
evaluation JSON is what ``ftin evaluate --json`` writes (validation metrics per sequence).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

_CITATION = {
    "oxiod": "OxIOD (Chen et al., 'OxIOD: The Dataset for Deep Inertial Odometry', 2018), research use",
    "sim": "FTIN Studio's own pedestrian simulator (ftin/sim)",
}


def _dataset_of(meta: dict[str, Any]) -> str:
    paths = " ".join(meta.get("training_data", {}).get("paths", []))
    return "oxiod" if "oxiod" in paths else "sim" if "sim" in paths else "unknown"


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
        f"random yaw augmentation {config.get('augment_yaw')}, seed {config.get('seed')}, "
        f"budget {config.get('max_minutes')} min on CPU",
        # The checkpoint kept is the best one, so these count up to it, not to the end of the run.
        f"- **Best checkpoint:** epoch {meta['epochs']}, {meta['steps']} steps, "
        f"{meta['wall_time_s'] / 60:.1f} min into the run, {meta.get('processes', 1)} process(es)",
        f"- **Best validation velocity MSE:** {meta['metrics'].get('val_mse', float('nan')):.4f} (m/s)²",
        f"- **Weights:** {config.get('weights_dtype', 'float32')} safetensors, upcast to float32 at load",
    ]
    if evaluation is not None:
        lines += [
            "",
            f"## Validation trajectories ({evaluation['description']})",
            "",
            "| sequence | ATE [m] | RTE [m] | PDE |",
            "|---|---|---|---|",
        ]
        for row in evaluation["sequences"]:
            lines.append(f"| {row['name']} | {row['ate']:.3f} | {row['rte']:.3f} | {row['pde']:.3f} |")
        mean = evaluation["mean"]
        lines.append(f"| **mean** | **{mean['ate']:.3f}** | **{mean['rte']:.3f}** | **{mean['pde']:.3f}** |")
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
