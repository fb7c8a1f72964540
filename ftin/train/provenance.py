"""What a checkpoint was trained on, as its JSON records it: ``training_data`` names the datasets and
lists the recordings relative to the data folder, never a path of the training machine.

``{"datasets": ["oxiod"], "recordings": ["oxiod/handheld/data1/syn/imu2.csv", ...], "sequences": [...]}``

Decisions:
- The datasets are the readers' own names (``ImuSequence.meta["dataset"]``: ``oxiod``, ``ridi``,
  ``sim``, ...), each once, in reading order; the app (``app.services.kinds``) and the model cards
  read them instead of guessing from words in paths.
- A recording's path is cut to start at the folder named after its dataset (``.../data/oxiod/x.csv``
  -> ``oxiod/x.csv``; a folder whose words include the name counts: ``sim-data``); a path with no such
  folder keeps only its name: a card never publishes where the data lay on the training machine.
- ``convert_card`` rewrites a card written before this record existed (absolute ``paths``): the
  datasets are read once from the words of its paths, and the training configuration's paths are cut
  the same way (``out_dir`` from its ``runs`` folder). Weights are not touched.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from pathlib import PurePath
from typing import Any

_WORD = re.compile(r"[a-z0-9]+")
# The datasets a legacy card's paths may name (reader formats, ``ftin.data.readers``, and the simulator's
# ``sim``); only for ``convert_card``. Kept as a list, not read from the registry: cards written before
# datasets were recorded no longer change, so a reader added since must not change how they read.
# Labels for people are the readers' (``reader_label``), never kept here.
KNOWN_DATASETS = ("oxiod", "ridi", "ronin", "tlio", "rnin", "imunet", "euroc", "sim")


def training_data_record(
    paths: Iterable[str | PurePath], sequences: Sequence[Any], names: Sequence[str] | None = None
) -> dict[str, Any]:
    """The card's ``training_data`` for ``sequences`` (``ImuSequence``) read from ``paths``; ``names``
    the sequences trained on (default: all of ``sequences``)."""
    datasets = list(dict.fromkeys(str(s.meta.get("dataset") or "unknown") for s in sequences))
    return {
        "datasets": datasets,
        "recordings": [relative_recording(p, datasets) for p in paths],
        "sequences": list(names) if names is not None else [s.name for s in sequences],
    }


def relative_recording(path: str | PurePath, datasets: Sequence[str]) -> str:
    """``path`` from the folder named after one of ``datasets`` on (module docstring), with ``/``."""
    parts = PurePath(str(path).replace("\\", "/")).parts
    names = {d.lower() for d in datasets}
    for i, part in enumerate(parts):
        if names & {part.lower(), *_WORD.findall(part.lower())}:  # a name with "_": inria_attitude
            return "/".join(parts[i:])
    return parts[-1] if parts else ""


def datasets_named_in(paths: Iterable[str]) -> list[str]:
    """The known datasets the words of ``paths`` name, each once, in order (legacy cards only)."""
    found: list[str] = []
    for path in paths:
        words = set(_WORD.findall(str(path).lower()))
        found += [name for name in KNOWN_DATASETS if name in words and name not in found]
    return found


def convert_card(meta: dict[str, Any]) -> dict[str, Any]:
    """A copy of a checkpoint's JSON with ``training_data`` recorded by dataset and relative paths
    and no absolute path in its training configuration (module docstring)."""
    out = dict(meta)
    data = meta.get("training_data")
    if isinstance(data, dict) and "paths" in data:
        paths = [str(p) for p in data.get("paths") or []]
        datasets = datasets_named_in(paths + [str(s) for s in data.get("sequences") or []]) or ["unknown"]
        out["training_data"] = {
            "datasets": datasets,
            "recordings": [relative_recording(p, datasets) for p in paths],
            "sequences": list(data.get("sequences") or []),
        }
    else:
        datasets = list((data or {}).get("datasets") or []) if isinstance(data, dict) else []
    config = dict(meta.get("train_config") or {})
    for key in ("data", "val"):
        if isinstance(config.get(key), list):
            config[key] = [relative_recording(p, datasets) for p in config[key]]
    recorded = (data or {}).get("recordings") if isinstance(data, dict) else None
    if (
        isinstance(recorded, list)
        and isinstance(config.get("data"), list)
        and len(config["data"]) == len(recorded)
    ):
        # The recordings are the training paths cut (training_data_record): take them as cut today,
        # so that a card cut by an older rule (a folder name with "_" went unmatched) reads as new.
        out["training_data"] = {**out["training_data"], "recordings": list(config["data"])}
    if config.get("out_dir"):
        config["out_dir"] = relative_recording(config["out_dir"], ["runs"])
    if meta.get("train_config") is not None:
        out["train_config"] = config
    return out


def absolute_paths_in(value: Any) -> list[str]:
    """Every string in ``value`` (nested lists / dicts) that is an absolute path (a card must hold none)."""
    if isinstance(value, dict):
        return [p for v in value.values() for p in absolute_paths_in(v)]
    if isinstance(value, list):
        return [p for v in value for p in absolute_paths_in(v)]
    if isinstance(value, str) and (value.startswith(("/", "~")) or re.match(r"^[A-Za-z]:[\\/]", value)):
        return [value]
    return []
