"""A finished run as plain arrays and JSON, and back: what ``run_archive`` writes to disk.

Decisions:
- Never pickle. Arrays go into ``.npz`` files (``numpy.savez``, read with ``allow_pickle=False``),
  everything else into one JSON document stored beside them in the same file (``__meta__``, UTF-8
  bytes as a ``uint8`` array), so that one file is one atomic write.
- What is stored is what serves every endpoint of a run after a restart: the input sequence as the
  run kept it (arrays and ``meta``), the prediction's arrays and fields, the model's input (the scene's
  spectra), the model name and choice, the alignment asked for. What is cheap and derived is
  recomputed on load: the score against the ground truth (``ftin.evaluate.score``, with the same
  alignment), and from it the plausibility figures and the verdict (``Run``'s cached properties).
  The model never runs again.
- The sequence is stored on its own (``encode_sequence``), keyed by a hash of its content: the runs
  of one compare-all share one copy of the recording.
- ``meta`` values that are not JSON: numpy arrays go to the ``.npz``; the dataclasses readers put
  there (``GpsTrack``, ``Trajectory``) are written field by field and rebuilt only from this module's
  allow-list, never from a type name read from disk; anything else is dropped with a warning.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import logging
from dataclasses import dataclass
from typing import Any, BinaryIO

import numpy as np

from app.services.features import ModelInput
from app.services.model_choice import ModelChoice
from ftin.data import ImuSequence, Trajectory
from ftin.data.location import GpsTrack
from ftin.evaluate import score
from ftin.files import to_json_safe
from ftin.infer import Prediction
from ftin.profiles import AppliedProfile

log = logging.getLogger(__name__)

FORMAT = 1  # bumped when the layout changes; a file of another format is not read
META_KEY = "__meta__"
_DATACLASSES: dict[str, type] = {"GpsTrack": GpsTrack, "Trajectory": Trajectory}  # the allow-list


class UnreadableRunError(ValueError):
    """A stored file that cannot be turned back into a run (damaged, another format)."""


# --- npz files ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class NpzContent:
    """One ``.npz`` file to be: the arrays and the JSON ``meta`` beside them. Written straight to a
    file (``write``), never held whole in memory: an hour's run is tens of MB."""

    meta: dict[str, Any]
    arrays: dict[str, np.ndarray]

    def write(self, handle: BinaryIO) -> None:
        text = json.dumps(to_json_safe({"format": FORMAT, **self.meta}), allow_nan=False)
        np.savez(handle, **{META_KEY: np.frombuffer(text.encode("utf-8"), dtype=np.uint8)}, **self.arrays)

    def to_bytes(self) -> bytes:
        buffer = io.BytesIO()
        self.write(buffer)
        return buffer.getvalue()


def to_npz(meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> bytes:
    """One ``.npz`` file's bytes: the arrays and the JSON ``meta`` beside them."""
    return NpzContent(meta, arrays).to_bytes()


def from_npz(data: bytes | Any) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """``to_npz``'s meta and arrays (``data``: bytes or a path); ``UnreadableRunError`` when damaged."""
    try:
        source = io.BytesIO(data) if isinstance(data, bytes) else data
        with np.load(source, allow_pickle=False) as npz:
            arrays = {name: npz[name] for name in npz.files}
        meta = json.loads(bytes(arrays.pop(META_KEY)).decode("utf-8"))
    except Exception as exc:  # zip, CRC, header, JSON or key errors: all mean "damaged"
        raise UnreadableRunError(f"{type(exc).__name__}: {exc}") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise UnreadableRunError(f"not a run file of format {FORMAT}")
    return meta, arrays


def read_meta(path: Any) -> dict[str, Any]:
    """Only the JSON part of a stored file (the index is rebuilt from it without reading arrays)."""
    try:
        with np.load(path, allow_pickle=False) as npz:
            meta = json.loads(bytes(npz[META_KEY]).decode("utf-8"))
    except Exception as exc:
        raise UnreadableRunError(f"{type(exc).__name__}: {exc}") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise UnreadableRunError(f"not a run file of format {FORMAT}")
    return meta


# --- values: JSON with arrays beside it ----------------------------------------------------------


class _Writer:
    def __init__(self) -> None:
        self.arrays: dict[str, np.ndarray] = {}

    def array(self, key: str, value: Any) -> str | None:
        if value is None:
            return None
        array = np.asarray(value)
        if array.dtype.kind not in "biufc":  # object or string arrays would need pickle
            raise TypeError(f"{key}: cannot store an array of dtype {array.dtype}")
        self.arrays[key] = array
        return key

    def value(self, key: str, value: Any) -> Any:
        """``value`` as JSON, its arrays and allowed dataclasses stored beside it under ``key``."""
        if isinstance(value, np.ndarray):
            return {"__array__": self.array(key, value)}
        if dataclasses.is_dataclass(value) and type(value).__name__ in _DATACLASSES:
            fields = {
                f.name: self.value(f"{key}.{f.name}", getattr(value, f.name))
                for f in dataclasses.fields(value)
            }
            return {"__dataclass__": type(value).__name__, "fields": fields}
        if isinstance(value, dict):
            return {str(k): self.value(f"{key}.{k}", v) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [self.value(f"{key}.{i}", v) for i, v in enumerate(value)]
        try:
            return to_json_safe(value)
        except TypeError:
            log.warning("run archive: %s (%s) is not stored", key, type(value).__name__)
            return None


def _read(value: Any, arrays: dict[str, np.ndarray]) -> Any:
    if isinstance(value, dict):
        if "__array__" in value:
            return arrays[value["__array__"]]
        if "__dataclass__" in value:
            kind = _DATACLASSES[value["__dataclass__"]]  # KeyError: not on the allow-list
            return kind(**{k: _read(v, arrays) for k, v in value["fields"].items()})
        return {k: _read(v, arrays) for k, v in value.items()}
    if isinstance(value, list):
        return [_read(v, arrays) for v in value]
    return value


def _trajectory(w: _Writer, key: str, traj: Trajectory | None) -> dict[str, Any] | None:
    if traj is None:
        return None
    return {
        name: w.array(f"{key}.{name}", getattr(traj, name))
        for name in ("t_s", "p_world_m", "q_world_body_wxyz", "tracked")
    }


def _trajectory_back(keys: dict[str, Any] | None, arrays: dict[str, np.ndarray]) -> Trajectory | None:
    if keys is None:
        return None
    return Trajectory(**{name: None if key is None else arrays[key] for name, key in keys.items()})


# --- the sequence ---------------------------------------------------------------------------------

_SEQ_ARRAYS = ("t_s", "gyro_rad_s", "acc_m_s2", "q_world_device_wxyz", "mag_uT")


def encode_sequence(seq: ImuSequence) -> tuple[str, NpzContent]:
    """The sequence's content hash (its file's name) and its ``.npz`` file."""
    w = _Writer()
    meta = {
        "name": seq.name,
        "arrays": {name: w.array(f"seq.{name}", getattr(seq, name)) for name in _SEQ_ARRAYS},
        "gt": _trajectory(w, "seq.gt", seq.gt),
        "meta": w.value("seq.meta", seq.meta),
    }
    digest = hashlib.sha256(json.dumps(to_json_safe(meta), sort_keys=True).encode())
    for key in sorted(w.arrays):
        array = np.ascontiguousarray(w.arrays[key])
        digest.update(f"{key}:{array.dtype.str}:{array.shape}".encode())
        digest.update(array)  # its bytes in C order, as ``tobytes`` gives them, without a copy
    return digest.hexdigest()[:32], NpzContent(meta, w.arrays)


def decode_sequence(data: bytes | Any) -> ImuSequence:
    meta, arrays = from_npz(data)
    try:
        fields = {name: None if key is None else arrays[key] for name, key in meta["arrays"].items()}
        return ImuSequence(
            name=meta["name"],
            gt=_trajectory_back(meta["gt"], arrays),
            meta=_read(meta["meta"], arrays),
            **fields,
        )
    except Exception as exc:
        raise UnreadableRunError(f"sequence: {type(exc).__name__}: {exc}") from None


# --- the run --------------------------------------------------------------------------------------

_PRED_ARRAYS = ("window_t_s", "velocity_m_s", "span_t_s", "imu_world", "starts")
_PRED_FIELDS = (
    "orientation_source", "frame", "warnings", "notes", "truth_frame", "window_s",
    "orientation_filter", "orientation_choice",
)  # fmt: skip


def encode_run(run: Any, record: dict[str, Any]) -> NpzContent:
    """A ``app.services.runs.Run``'s own file (its sequence is stored apart, see ``encode_sequence``);
    ``record`` (its index row) is kept inside too, so that a lost index can be rebuilt from the files."""
    w = _Writer()
    pred: Prediction = run.prediction
    mi: ModelInput | None = run.model_input
    shared = mi is not None and mi.imu_world is pred.imu_world and mi.starts is pred.starts
    meta = {
        "record": record,
        "align": run.align,
        "scored": run.score is not None,
        "model_choice": None if run.model_choice is None else run.model_choice.to_json(),
        "profile": None if run.profile is None else run.profile.to_json(),
        "prediction": {
            "trajectory": _trajectory(w, "pred.trajectory", pred.trajectory),
            "truth": _trajectory(w, "pred.truth", pred.truth),
            "arrays": {name: w.array(f"pred.{name}", getattr(pred, name)) for name in _PRED_ARRAYS},
            **{name: w.value(f"pred.{name}", getattr(pred, name)) for name in _PRED_FIELDS},
            # a variance head's per-window sigma: the restored run's uncertainty is the one it had
            "log_std": w.array("pred.log_std", (pred.features or {}).get("log_std")),
        },
        "model_input": None
        if mi is None
        else {
            "window": int(mi.window),
            "turn_stride": mi.turn_stride,
            "shared": shared,
            "imu_world": None if shared else w.array("mi.imu_world", mi.imu_world),
            "starts": None if shared else w.array("mi.starts", mi.starts),
        },
    }
    return NpzContent(meta, w.arrays)


def decode_run(data: bytes | Any, sequence: ImuSequence, run_type: type) -> Any:
    """The run ``encode_run`` wrote, over its ``sequence``; the score recomputed as it was made."""
    meta, arrays = from_npz(data)
    try:
        p = meta["prediction"]
        pred = Prediction(
            trajectory=_trajectory_back(p["trajectory"], arrays),
            truth=_trajectory_back(p["truth"], arrays),
            features=None if p.get("log_std") is None else {"log_std": arrays[p["log_std"]]},
            **{name: None if key is None else arrays[key] for name, key in p["arrays"].items()},
            **{name: _read(p[name], arrays) for name in _PRED_FIELDS},
        )
        mi = meta["model_input"]
        model_input = None
        if mi is not None:
            imu, starts = (
                (pred.imu_world, pred.starts)
                if mi["shared"]
                else (arrays[mi["imu_world"]], arrays[mi["starts"]])
            )
            model_input = ModelInput(imu, starts, int(mi["window"]), mi.get("turn_stride"))
        choice = meta["model_choice"]
        r = meta["record"]
        return run_type(
            run_id=r["run_id"],
            model_name=r["model"],
            sequence=sequence,
            prediction=pred,
            source=r["source"],
            sequence_id=r["sequence_id"],
            model_input=model_input,
            score=score(pred, meta["align"]) if meta["scored"] else None,
            created_s=float(r["created_s"]),
            model_choice=None if choice is None else _model_choice(choice),
            align=meta["align"],
            group=r["group_id"],
            profile=None if meta.get("profile") is None else AppliedProfile.from_json(meta["profile"]),
        )
    except Exception as exc:
        raise UnreadableRunError(f"run: {type(exc).__name__}: {exc}") from None


def _model_choice(saved: dict[str, Any]) -> ModelChoice:
    """The stored choice; keys its ``to_json`` adds beyond the dataclass's fields are words derived
    from them, so only the fields are read back."""
    names = {f.name for f in dataclasses.fields(ModelChoice)}
    return ModelChoice(**{k: v for k, v in saved.items() if k in names})
