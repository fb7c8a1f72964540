"""The generalisation campaign's stage two: stage one's choices, then every shipped checkpoint retrained.

Stage one's choices (docs/results/protocol.md: each takes the arm with the lower mean paired
validation ATE over every walker of both folds, phone only) are read from the paired comparisons of
``ftin campaign crossval`` (``stage_two_choices``); ``stage_two_jobs`` retrains every shipped
checkpoint with them. ``arm_of`` names a walker-fold job's arm, as the comparisons do.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

from ftin.protocol.datasets import OXIOD, PHONE_ONLY, RIDI, WALKING
from ftin.protocol.jobs import FTIN_VARIANTS, RECIPES, SEEDS, Job, generalisation_jobs, model_options, sim_job

STAGE_TWO_SEEDS = (0, 1, 2, 3, 4)  # FTIN, +TDL and RoNIN ResNet (the five)
STAGE_TWO_MULTI_SEED = ("ftin", "resnet_tdl", "ronin_resnet")
FTIN_FAMILY = ("ftin", "resnet_fdl", "resnet_tdl")  # take FTIN's augmentations; every other model ResNet's
STAGE_TWO_AUGMENT_ARMS = ("aug", "mirror", "pace")  # each chosen against yaw only; the chosen combined


@dataclass(frozen=True)
class StageTwoChoices:
    ftin_variant: str  # FTIN's TDL sequence
    recipe: str  # a key of RECIPES, for every model (the same budget for all)
    augment: dict[str, dict[str, float | None]]  # "ftin" / "ronin_resnet" -> augmentations beyond yaw
    why: dict[str, str]  # each choice in words, with its figure


def stage_two_choices(comparisons: Sequence[Mapping[str, Any]]) -> StageTwoChoices:
    """The choices from crossval's paired comparisons (``crossval.json["comparisons"]``): the phone-only
    rows over every dataset. ``ValueError`` naming a question stage one has not answered yet."""
    rows = {
        (row["a"], row["b"]): row
        for row in comparisons
        if row["orientation"] == PHONE_ONLY and row["dataset"] == "all"
    }

    def row(a: str, b: str) -> Mapping[str, Any]:
        if (a, b) not in rows:
            raise ValueError(f"stage one has not compared {a} with {b} yet (no phone-only row in crossval)")
        return rows[a, b]

    def said(a: str, b: str) -> str:
        return comparison_words(row(a, b))

    why: dict[str, str] = {}
    tdl = row("ftin-mixed-yaw", "ftin-ordered-yaw")
    variant = "mixed" if tdl["lower_mean"] == "a" else "ordered"
    why["ftin_variant"] = f"{variant} ({said('ftin-mixed-yaw', 'ftin-ordered-yaw')})"
    arms = {arm_of(job.name): job for job in generalisation_jobs()}
    augment: dict[str, dict[str, float | None]] = {}
    for family, prefix in (("ftin", "ftin-ordered"), ("ronin_resnet", "ronin_resnet")):
        chosen: dict[str, float | None] = {}
        for arm in STAGE_TWO_AUGMENT_ARMS:
            if row(f"{prefix}-{arm}", f"{prefix}-yaw")["lower_mean"] == "a":
                chosen.update(arms[f"{prefix}-{arm}"].options["augment"])
        augment[family] = chosen
        words = "; ".join(said(f"{prefix}-{arm}", f"{prefix}-yaw") for arm in STAGE_TWO_AUGMENT_ARMS)
        why[f"augment_{family}"] = f"{', '.join(chosen) or 'yaw only'} ({words})"
    paper = [row(f"{p}-paper", f"{p}-yaw") for p in ("ftin-ordered", "ronin_resnet")]
    pooled = sum(r["mean_m"] * r["pairs"] for r in paper) / sum(r["pairs"] for r in paper)
    recipe = "paper" if pooled < 0 else "ours"
    why["recipe"] = f"{recipe} (the paper's recipe against ours, both architectures: mean d {pooled:+.3f} m)"
    return StageTwoChoices(variant, recipe, augment, why)


def comparison_words(row: Mapping[str, Any]) -> str:
    """One paired comparison of crossval in words, with its figure."""
    return (
        f"{row['a']} vs {row['b']}: mean d {row['mean_m']:+.3f} m over {row['pairs']} pairs, "
        f"{row['walkers']} walkers"
    )


_ARM_JOB_NAME = re.compile(r"[^/]+/(?P<arm>.+)-s(?P<seed>\d+)")


def arm_of(job_name: str) -> str:
    """A walker-fold job's arm: ``walking-f0/ftin-ordered-yaw-s1`` -> ``ftin-ordered-yaw``."""
    match = _ARM_JOB_NAME.fullmatch(job_name)
    if match is None:
        raise ValueError(f"job {job_name!r}: not a walker-fold job name (<dataset>-f<fold>/<arm>-s<seed>)")
    return match["arm"]


def stage_two_jobs(choices: StageTwoChoices) -> list[Job]:
    """Every shipped checkpoint retrained with stage one's choices, the default's candidates first: the
    walking checkpoints of FTIN and RoNIN ResNet (every walking dataset), then FTIN, +TDL and RoNIN
    ResNet with ``STAGE_TWO_SEEDS`` on OxIOD and RIDI, +FDL with ``SEEDS``, the other baselines with
    one seed, and the simulator model."""
    jobs: list[Job] = []

    def add(model: str, dataset: str, seed: int) -> None:
        options = {**model_options(model, dataset), **RECIPES[choices.recipe]}
        augment = choices.augment["ftin" if model in FTIN_FAMILY else "ronin_resnet"]
        if augment:
            options["augment"] = dict(augment)
        variant = choices.ftin_variant if model == "ftin" else None
        if variant:
            options["model_kwargs"] = {**options.get("model_kwargs", {}), **FTIN_VARIANTS[variant]}
        jobs.append(
            Job(
                f"{dataset}/{model}{f'-{variant}' if variant else ''}-s{seed}",
                model,
                dataset,
                seed,
                variant,
                options,
            )
        )

    for model in ("ftin", "ronin_resnet"):
        add(model, WALKING, 0)
    for seed in STAGE_TWO_SEEDS:
        for dataset in (OXIOD, RIDI):
            for model in STAGE_TWO_MULTI_SEED:
                add(model, dataset, seed)
            if seed in SEEDS:
                add("resnet_fdl", dataset, seed)
            if seed == 0:
                for model in ("ronin_lstm", "ronin_tcn", "rnin", "imunet", "tlio"):
                    add(model, dataset, seed)
    sim = sim_job(choices.ftin_variant)
    sim_options = {**sim.options, **RECIPES[choices.recipe]}
    if choices.augment["ftin"]:
        sim_options["augment"] = dict(choices.augment["ftin"])
    jobs.append(replace(sim, options=sim_options))
    return jobs
