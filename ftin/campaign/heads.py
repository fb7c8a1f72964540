"""Ship a variance head trained on a frozen, already shipped checkpoint (stage three,
``ftin.protocol.stage_three``) without rewriting what the checkpoint already says.

``ftin campaign ship`` publishes a job as a whole new checkpoint: its card, its record, and a default
chosen on its validation scores. A head job trained only ``log_std_head`` on top of a shipped network
(``TrainConfig.train_only``), so its velocities, Table 1 row, model card and the app's default are the
shipped checkpoint's, bit for bit. ``ship_head`` therefore replaces the weights (the same tensors plus
the head; checked equal before anything is written), and adds to the card JSON and markdown one
``variance_head`` section saying how the head was trained, leaving every other field as it was.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

from safetensors import safe_open

from ftin.campaign.folder import read_json
from ftin.files import atomic_write_text

HEAD_PREFIX = "log_std_head."
SECTION_TITLE = "## Variance head (stage three)"


class HeadShipError(ValueError):
    """The head run cannot be shipped onto the checkpoint; the message says why."""


def _tensors(path: Path) -> dict[str, Any]:
    with safe_open(str(path), "pt") as f:
        return {k: f.get_tensor(k) for k in f.keys()}  # noqa: SIM118 (safe_open has no __iter__)


def check_same_network(shipped: Path, headed: Path) -> list[str]:
    """The head's tensor names, after checking that every other tensor of ``headed`` equals the
    shipped one's (the frozen network) and that the shipped file has no head yet."""
    ours, theirs = _tensors(shipped), _tensors(headed)
    head = sorted(k for k in theirs if k.startswith(HEAD_PREFIX))
    if not head:
        raise HeadShipError(f"{headed}: no {HEAD_PREFIX}* tensors: not a variance-head run")
    if any(k.startswith(HEAD_PREFIX) for k in ours):
        raise HeadShipError(f"{shipped}: already has a variance head")
    rest = set(theirs) - set(head)
    if rest != set(ours):
        raise HeadShipError(f"{headed}: its network's tensors differ in name from {shipped.name}'s")
    changed = [k for k in sorted(rest) if not bool((theirs[k] == ours[k]).all())]
    if changed:
        raise HeadShipError(f"{headed}: {len(changed)} frozen tensors changed (first: {changed[0]})")
    return head


def head_section(run_card: dict[str, Any], job: str) -> dict[str, Any]:
    """What the card says of the head: how and on what it was trained."""
    config = run_card.get("train_config", {})
    return {
        "job": job,
        "trained": config.get("train_only", []),
        "loss": config.get("loss"),
        "augment": config.get("augment"),
        "orientation": config.get("orientation"),
        "epochs": run_card.get("epochs"),
        "steps": run_card.get("steps"),
        "best_val_nll": run_card.get("metrics", {}).get("monitored_loss"),
        "training_recordings": len(run_card.get("split", {}).get("train", []) or config.get("data", [])),
        "validation_recordings": len(run_card.get("split", {}).get("val", []) or config.get("val", [])),
        "note": "the network is the shipped one, frozen: velocities unchanged; sigma = exp(log_std) per "
        "axis, scaled at use by log_std_scale of ftin/uncertainty/calibration.json",
    }


def ship_head(run_folder: Path, checkpoints: Path, stem: str, job: str) -> list[Path]:
    """Put ``run_folder``'s headed ``stem`` in place of ``checkpoints/stem`` (module docstring)."""
    headed, shipped = run_folder / f"{stem}.safetensors", checkpoints / f"{stem}.safetensors"
    check_same_network(shipped, headed)
    run_card = read_json(run_folder / f"{stem}.json")
    card_path, md_path = checkpoints / f"{stem}.json", checkpoints / f"{stem}.md"
    card = read_json(card_path)
    card["model_kwargs"] = run_card["model_kwargs"]
    card["weights_sha256"] = run_card["weights_sha256"]
    card["weights_dtype"] = run_card["weights_dtype"]
    card["variance_head"] = head_section(run_card, job)
    shutil.copy2(headed, shipped)
    atomic_write_text(card_path, json.dumps(card, indent=2) + "\n")
    text = md_path.read_text(encoding="utf-8") if md_path.exists() else ""
    text = text.split(f"\n{SECTION_TITLE}\n")[0].rstrip("\n") + "\n\n" + _markdown(card["variance_head"])
    atomic_write_text(md_path, text)
    return [shipped, card_path, md_path]


def ship_heads(campaign: Any, checkpoints: Path, on_event: Any = print) -> list[Path]:
    """``ship_head`` for every finished job of ``campaign`` that trained a head alone (``train_only``)."""
    written: list[Path] = []
    for job in campaign.jobs():
        if not job.options.get("train_only"):
            continue
        if not campaign.is_done(job):
            on_event(f"not shipped: {job.name} has not finished")
            continue
        folder, stem = campaign.runs / job.name, job.checkpoint_stem
        card = read_json(checkpoints / f"{stem}.json")
        if card.get("weights_sha256") == read_json(folder / f"{stem}.json").get("weights_sha256"):
            on_event(f"already shipped: {job.name} onto {stem}")
            continue
        written += ship_head(folder, checkpoints, stem, job.name)
        on_event(f"shipped the variance head of {job.name} onto {stem}")
    return written


def _markdown(section: dict[str, Any]) -> str:
    s = section
    return "\n".join(
        [
            SECTION_TITLE,
            "",
            f"A log-std head per horizontal axis, trained on this network frozen (campaign job `{s['job']}`;",
            f"{s['epochs']} epochs, {s['steps']} steps, loss {s['loss']}, augmentation {s['augment']}, "
            f"orientation {s['orientation']}; {s['training_recordings']} training "
            f"and {s['validation_recordings']} validation recordings, best validation NLL "
            f"{s['best_val_nll']:.3f}). The velocities above are unchanged. "
            "[How its sigma is calibrated and used](../docs/metrics.md#how-sure-is-it-position-uncertainty).",
            "",
        ]
    )
