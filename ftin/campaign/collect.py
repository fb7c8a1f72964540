"""From a campaign folder to what is committed: one record per finished job and a manifest
(``ftin table --campaign`` reads them), and the shipped checkpoints with their model cards.

A record is ``{"training": done.json, "history": history.json, "evaluation": eval.json}`` in
``<results>/<job name with / as __>.json``. Per checkpoint name (``<model>-<dataset>``) the seed with
the best validation MSE is the candidate; it ships if it passes ``protocol.validation_gate``, else
an earlier checkpoint of that name is withdrawn (a model that has not learned to walk is not hosted).
FTIN's candidates are the variant validation chose. Walker-fold jobs are recorded but never shipped
(``ftin campaign crossval`` compares them). Among the shipped pedestrian
checkpoints the manifest names the app's default (``protocol.choose_default``), which ``ship``
writes to ``default.json``.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable, Collection
from pathlib import Path
from typing import Any

from ftin import protocol
from ftin.campaign.folder import DONE_FILE, EVAL_FILE, Campaign, read_json, record_name, write_json
from ftin.files import atomic_write_text
from ftin.train.model_card import render_campaign_card
from ftin.train.provenance import convert_card
from ftin.train.state import HISTORY_FILE

MANIFEST = "manifest.json"
DEFAULT_FILE = "default.json"  # in the checkpoint folder: the app's default model and why (app.services)
CARD_SUFFIXES = (".safetensors", ".json", ".md")


def job_record(campaign: Campaign, job: protocol.Job) -> dict[str, Any]:
    folder = campaign.job_dir(job)
    return {
        "training": read_json(folder / DONE_FILE),
        "history": read_json(folder / HISTORY_FILE),
        "evaluation": read_json(folder / EVAL_FILE),
    }


def collect(campaign: Campaign, results: Path, only: Collection[str] = ()) -> dict[str, Any]:
    """Write every finished job's record and ``manifest.json`` to ``results``; the manifest.
    ``only``: checkpoint names whose candidates alone are considered (groups finished early)."""
    results.mkdir(parents=True, exist_ok=True)
    variant = campaign.choose_variant()
    done = [job for job in campaign.jobs() if campaign.is_done(job)]
    best: dict[str, tuple[float, protocol.Job, dict[str, Any]]] = {}
    for job in done:
        if only and job.checkpoint_stem not in only:
            continue
        record = job_record(campaign, job)
        write_json(results / record_name(job.name), record)
        if job.fold is not None:
            continue  # a walker fold trained without its validation walkers: compared, never shipped
        if job.model == "ftin" and variant is not None and job.variant != variant:
            continue
        val = record["training"]["best_val_mse"]
        stem = job.checkpoint_stem
        if stem not in best or val < best[stem][0]:
            best[stem] = (val, job, record)
    manifest: dict[str, Any] = {
        "campaign_commit": campaign.state["commit"],
        "ftin_variant": variant,
        "shipped": {},
        "not_shipped": {},
    }
    candidates: dict[str, dict[str, Any]] = {}
    for stem, (val, job, record) in sorted(best.items()):
        gate = protocol.validation_gate(record)
        key = "not_shipped" if gate["refused"] else "shipped"
        manifest[key][stem] = {"job": job.name, **({} if gate["refused"] else {"val_mse": val}), **gate}
        if not gate["refused"] and job.dataset in protocol.DEFAULT_CANDIDATE_DATASETS:
            candidates[stem] = record
    default = protocol.choose_default(candidates)
    if default is not None:
        manifest["default"] = default
    write_json(results / MANIFEST, manifest)
    return manifest


def ship(
    campaign: Campaign, results: Path, checkpoints: Path, on_event: Callable[[str], None] = print
) -> list[Path]:
    """Copy every checkpoint ``manifest.json`` ships into ``checkpoints`` with its model card, and
    withdraw the refused names; the files written."""
    path = results / MANIFEST
    if not path.exists():
        raise ValueError(f"{results}: no {MANIFEST}; run `ftin campaign collect` first")
    manifest = read_json(path)
    checkpoints.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for stem in manifest["not_shipped"]:
        for suffix in CARD_SUFFIXES:
            if (old := checkpoints / (stem + suffix)).exists():
                old.unlink()
                on_event(f"withdrawn: {old} (its campaign run failed the validation gate)")
    for stem, entry in manifest["shipped"].items():
        folder = campaign.runs / entry["job"]
        shutil.copy2(folder / (stem + ".safetensors"), checkpoints / (stem + ".safetensors"))
        # The card as published: recordings relative to the data folder, no path of this machine.
        card_json = convert_card(read_json(folder / (stem + ".json")))
        atomic_write_text(checkpoints / (stem + ".json"), json.dumps(card_json, indent=2) + "\n")
        written += [checkpoints / (stem + ".safetensors"), checkpoints / (stem + ".json")]
        record = read_json(results / record_name(entry["job"]))
        seeds = [
            seed
            for p in sorted(results.glob("*__*.json"))
            if _same_model((seed := read_json(p))["training"], record["training"])
        ]
        card = render_campaign_card(card_json, record, seeds, manifest.get("ftin_variant"))
        (checkpoints / (stem + ".md")).write_text(card)
        written.append(checkpoints / (stem + ".md"))
    if "default" in manifest:  # the app's default for requests that name no model, and why
        default = {key: manifest["default"][key] for key in ("model", "why", "source", "scores")}
        write_json(checkpoints / DEFAULT_FILE, default)
        written.append(checkpoints / DEFAULT_FILE)
    return written


def _same_model(a: dict[str, Any], b: dict[str, Any]) -> bool:
    keys = ("model", "dataset", "variant", "fold")
    return all(a.get(k) == b.get(k) for k in keys)
