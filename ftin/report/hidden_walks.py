"""The generalisation issue's acceptance check: a model on recordings no choice has seen, phone only
(``ftin campaign hidden-walks``).

Every recording of the protocol's test parts (OxIOD, RIDI: walkers huayi and shali appear nowhere
else; Inria: the iPhone 4S, a phone no training or validation walk comes from) is oriented as a phone
alone would be (``ftin.data.loading.load_phone_only``: ``auto`` from gyroscope, accelerometer and
magnetometer; the truth turned into the estimate's world at the start, as the campaign's phone-only
rows) and scored by ``ftin.evaluate.score`` (RoNIN convention, no alignment). Per recording: carry
mode, ATE, ATE of standing still, the distance ratio (the issue's measure: the path as predicted over
the walked distance, the true path smoothed over 1 s) and, beside it, the campaign's path ratio (both
paths smoothed over the model's 1 s window, ``ftin.metrics.definitions``). The issue's thresholds:
distance ratio 0.8-1.2 on every walking recording (0.7-1.3 running, ``protocol.path_ratio_bounds``);
mean ATE at or below 0.5x standing still on OxIOD and RIDI, below standing still on Inria
(``STILL_LIMIT``). ``write_files`` writes ``<checkpoint name>.md`` and ``.json``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from ftin import protocol
from ftin.checkpoint import LoadedModel
from ftin.data.loading import load_phone_only
from ftin.evaluate import score
from ftin.infer import predict_trajectory

DATASETS = (protocol.OXIOD, protocol.RIDI, protocol.INRIA)
LABELS = {protocol.OXIOD: "OxIOD", protocol.RIDI: "RIDI", protocol.INRIA: "Inria (iPhone 4S)"}
STILL_LIMIT = {protocol.OXIOD: 0.5, protocol.RIDI: 0.5, protocol.INRIA: 1.0}  # mean ATE / stand still


def hidden_walks(model: LoadedModel, data: Path, **options: Any) -> dict[str, dict[str, Any]]:
    """Every dataset's summary and per-recording rows, by dataset (``DATASETS``), under ``data``;
    ``options`` go to ``predict_trajectory`` (the app's way by default)."""
    torch.set_num_threads(1)  # as a campaign worker scores its job
    results = {}
    for dataset in DATASETS:
        rows = score_dataset(model, data, dataset, **options)
        results[dataset] = {"summary": summary(dataset, rows), "rows": rows}
    return results


def score_dataset(model: LoadedModel, data: Path, dataset: str, **options: Any) -> list[dict[str, Any]]:
    """One row per recording of the dataset's test part, oriented and scored phone only."""
    rows = []
    paths = protocol.split_paths(data, dataset, "test")
    for seq in tqdm(load_phone_only(paths, f"{dataset} test"), desc=LABELS[dataset], unit="walk"):
        prediction = predict_trajectory(model, seq, keep_prepared=False, **options)
        scored = score(prediction)
        carry = str(seq.meta.get("carry", "unknown"))
        if "motion" in seq.meta:  # Inria: the motion says more (running, phoning, texting) and Dist
            carry = f"{carry} ({seq.meta['motion']}{', Dist' if seq.meta['magnetic_disturbance'] else ''})"
        ratio = scored.metrics.values.get("distance_ratio")
        low, high = protocol.path_ratio_bounds(carry)
        rows.append(
            {
                "name": seq.name,
                "walker": protocol.walker(dataset, seq.name),
                "carry": carry,
                "orientation": (prediction.orientation_choice or {}).get("source"),
                "ate_m": scored.metrics.values["ate"],
                "stand_still_ate_m": scored.stand_still.values["ate"],
                "distance_ratio": ratio,
                "path_ratio": scored.metrics.values.get("path_length_ratio"),
                "ratio_ok": ratio is not None and low <= ratio <= high,
                # how fast the walk is (its smoothed true path over its duration): an AR walk shuffles
                # at 0.1-0.2 m/s, where a fraction of a step is a large share of the distance
                "true_speed_m_s": scored.metrics.values.get("true_path_m", float("nan")) / seq.duration_s,
            }
        )
    return rows


def summary(dataset: str, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The dataset's mean ATE against standing still's, and how many distance ratios are in bounds."""
    ate = float(np.mean([r["ate_m"] for r in rows]))
    still = float(np.mean([r["stand_still_ate_m"] for r in rows]))
    return {
        "recordings": len(rows),
        "mean_ate_m": ate,
        "mean_stand_still_ate_m": still,
        "ate_over_stand_still": ate / still,
        "stand_still_ok": ate / still <= STILL_LIMIT[dataset],
        "ratio_ok": sum(r["ratio_ok"] for r in rows),
    }


def markdown(name: str, results: dict[str, dict[str, Any]]) -> str:
    """The check of checkpoint ``name`` as Markdown: one summary row per dataset, then every recording."""
    lines = [
        f"# `{name}` on hidden recordings, phone only\n",
        "Made by `ftin campaign hidden-walks` (`ftin.report.hidden_walks`: recordings, scoring, "
        "thresholds). ATE in m, RoNIN convention (no alignment; the truth turned into the estimate's "
        "world over the first 2 s through the phone's attitude, which the estimate never reads); distance "
        "ratio: the path as predicted over the walked distance (the true path smoothed over 1 s), the "
        "issue's measure; path ratio: both paths smoothed over 1 s, as the campaign's records.\n",
        "| dataset | walks | mean ATE | stand still | ratio (limit) | distance ratio in bounds |",
        "|---|--:|--:|--:|--:|--:|",
    ]
    for dataset, part in results.items():
        s = part["summary"]
        mark = "✔" if s["stand_still_ok"] else "✘"
        cells = [
            LABELS[dataset],
            str(s["recordings"]),
            f"{s['mean_ate_m']:.2f}",
            f"{s['mean_stand_still_ate_m']:.2f}",
            f"{s['ate_over_stand_still']:.2f} (≤ {STILL_LIMIT[dataset]}) {mark}",
            f"{s['ratio_ok']} of {s['recordings']}",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    header = (
        "| dataset | recording | carry | orientation | speed (m/s) | ATE | stand still | distance ratio "
        "| path ratio |"
    )
    lines += ["", header, "|---|---|---|---|--:|--:|--:|--:|--:|"]
    for dataset, part in results.items():
        for r in part["rows"]:
            ratio = "—" if r["distance_ratio"] is None else f"{r['distance_ratio']:.2f}"
            ratio += "" if r["ratio_ok"] else " ✘"
            path = "—" if r["path_ratio"] is None else f"{r['path_ratio']:.2f}"
            lines.append(
                f"| {LABELS[dataset]} | {r['name']} | {r['carry']} | {r['orientation']} "
                f"| {r['true_speed_m_s']:.2f} | {r['ate_m']:.2f} "
                f"| {r['stand_still_ate_m']:.2f} | {ratio} | {path} |"
            )
    return "\n".join(lines) + "\n"


def write_files(name: str, results: dict[str, dict[str, Any]], out: Path) -> list[Path]:
    """``<out>/<name>.md`` (first) and ``.json``: the check of checkpoint ``name``."""
    out.mkdir(parents=True, exist_ok=True)
    md, raw = out / f"{name}.md", out / f"{name}.json"
    raw.write_text(json.dumps(results, indent=1) + "\n")
    md.write_text(markdown(name, results))
    return [md, raw]
