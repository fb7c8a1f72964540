"""The walks the uncertainty probe reads (``experiments.probe_uncertainty``), each predicted once by
the default model, phone only, and kept as a small npz (times, predicted and true positions, the
model's per-window velocities and the truth's over the same spans, the yaw of estimate and reference)
so that fitting the few constants of ``ftin.uncertainty`` can be rerun without the network. The
world-frame IMU the model read is kept too (``imu_world``, float32), so another checkpoint of the same
rate and window (a variance head, FTIN) rereads a walk without orienting it again (``reread``).

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
from ftin.infer import integrate_spans, predict_trajectory, run_windows
from ftin.yaw_average import default_copies, uses_cyclic_turns

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
        "imu_world": prediction.imu_world.astype(np.float32),
        "starts": prediction.starts,
        "turn_stride": np.array(prediction.turn_stride or 0),
        **_log_std(prediction.features),
    }


def _log_std(features: dict | None) -> dict[str, np.ndarray]:
    log_std = (features or {}).get("log_std")
    return {} if log_std is None else {"log_std": np.asarray(log_std, dtype=np.float64)[:, :2]}


def reread(record: dict[str, np.ndarray], model: LoadedModel) -> dict[str, np.ndarray]:
    """``record`` as ``model`` reads it: its velocities (and log-std) over the same windows of the same
    world-frame IMU, one look per window turned as inference turns it, integrated from the true start
    (the walks have no gaps to leave out). ``model`` must share the recorded model's rate and window."""
    starts, stride = record["starts"], int(record["turn_stride"])
    window = int(round(float(record["window_s"]) * model.imu_rate_hz))
    if window != model.window:
        raise ValueError(f"{model.name}: window {model.window}, the walks were read with {window}")
    cyclic = uses_cyclic_turns(model.model_name, model.model.streams)
    velocity, taps = run_windows(
        model, record["imu_world"], starts, window, 1, 1024, None, False, default_copies(cyclic),
        turn_stride=stride if cyclic and stride else None,
    )  # fmt: skip
    v = velocity[:, 0, :2]
    t = record["t_s"]
    p = integrate_spans(t, starts, starts + window, v, record["p_true"][0])
    return {**record, "v_pred": v, "p_pred": p[:, :2], **_log_std(taps)}


def _current(file: Path) -> bool:
    """Whether ``file`` holds a walk as ``walk_record`` writes it now (older ones lack the input)."""
    if not file.exists():
        return False
    with np.load(file) as data:
        return "imu_world" in data.files


def cached_walks(model: LoadedModel, data_root: Path, cache: Path) -> list[dict[str, np.ndarray]]:
    """Every walk of ``walk_paths`` as ``walk_record``, read from ``cache`` where already there."""
    records = []
    for dataset, paths in walk_paths(data_root).items():
        for path in paths:
            key = re.sub(r"[^A-Za-z0-9_.-]+", "_", str(path.relative_to(data_root)))
            file = cache / f"{key}.npz"
            if not _current(file):
                (seq,) = load_phone_only([path])
                cache.mkdir(parents=True, exist_ok=True)
                np.savez(file, **walk_record(model, seq, dataset))
                print(f"{dataset} {path.name}: predicted")
            with np.load(file) as data:
                records.append({k: data[k] for k in data.files})
    return records
