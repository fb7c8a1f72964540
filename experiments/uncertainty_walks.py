"""The walks the uncertainty probe reads (``experiments.probe_uncertainty``), each predicted once by
the default model, phone only, and kept as a small npz (times, predicted and true positions, the
model's per-window velocities and the truth's over the same spans, the yaw of estimate and reference)
so that fitting the few constants of ``ftin.uncertainty`` can be rerun without the network.

The walks: the validation part of OxIOD, RIDI and Inria (``ftin.protocol.split_paths(root, d,
"val")``: walkers no shipped model trained on) and the 30 OxIOD walks added later
(``experiments.probe_new_oxiod_walks.NEW_WALKS``), which nothing is fitted on.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from experiments.probe_new_oxiod_walks import NEW_WALKS
from ftin import protocol
from ftin.checkpoint import LoadedModel
from ftin.data.loading import load_phone_only
from ftin.infer import predict_trajectory

FIT_SETS = (protocol.OXIOD, protocol.RIDI, protocol.INRIA)
NEW_SET = "oxiod_new"


def walk_paths(data_root: Path) -> dict[str, list[Path]]:
    """The recordings of each set, by set name (the three validation parts, then the new walks)."""
    sets = {d: protocol.split_paths(data_root, d, "val") for d in FIT_SETS}
    sets[NEW_SET] = [data_root / protocol.DATA_FOLDERS[protocol.OXIOD] / rel for rel in NEW_WALKS]
    return sets


def walk_record(model: LoadedModel, seq, dataset: str) -> dict[str, np.ndarray]:
    """One walk predicted (phone only) and reduced to what the fit reads."""
    prediction = predict_trajectory(model, seq, keep_prepared=False)
    truth = prediction.truth
    t = prediction.trajectory.t_s
    span = prediction.span_t_s
    a, b = np.searchsorted(t, span[:, 0]), np.searchsorted(t, span[:, 1])
    dt = np.maximum(t[b] - t[a], 1e-9)
    v_true = (truth.p_world_m[b, :2] - truth.p_world_m[a, :2]) / dt[:, None]
    tracked = np.ones(len(a), bool) if truth.tracked is None else truth.tracked[a] & truth.tracked[b]
    return {
        "dataset": np.array(dataset),
        "name": np.array(seq.name),
        "carry": np.array(str(seq.meta.get("carry", "unknown"))),
        "orientation_filter": np.array(str(prediction.orientation_filter)),
        "t_s": t,
        "p_pred": prediction.trajectory.p_world_m[:, :2],
        "p_true": truth.p_world_m[:, :2],
        "span_t_s": span,
        "v_pred": prediction.velocity_m_s[:, :2],
        "v_true": v_true,
        "tracked": tracked,
        "window_s": np.array(prediction.window_s),
    }


def cached_walks(model: LoadedModel, data_root: Path, cache: Path) -> list[dict[str, np.ndarray]]:
    """Every walk of ``walk_paths`` as ``walk_record``, read from ``cache`` where already there."""
    records = []
    for dataset, paths in walk_paths(data_root).items():
        for path in paths:
            key = re.sub(r"[^A-Za-z0-9_.-]+", "_", str(path.relative_to(data_root)))
            file = cache / f"{key}.npz"
            if not file.exists():
                (seq,) = load_phone_only([path])
                cache.mkdir(parents=True, exist_ok=True)
                np.savez(file, **walk_record(model, seq, dataset))
                print(f"{dataset} {path.name}: predicted")
            with np.load(file) as data:
                records.append({k: data[k] for k in data.files})
    return records
