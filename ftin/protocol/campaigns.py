"""Every campaign's job list by its ``ftin campaign plan --jobs`` name (``CAMPAIGNS``).

Above the modules that define the lists (``jobs``, ``stage_three``, ``stride_retrain``), so that
naming them all takes no import circle: a new kind of campaign job is a function returning ``Job``s
in its own module and one entry here.
"""

from __future__ import annotations

from collections.abc import Callable

from ftin.files import DEFAULT_CHECKPOINT_DIR, DEFAULT_DATA_ROOT
from ftin.protocol.jobs import Job, campaign_jobs, generalisation_jobs, tilt_question_jobs
from ftin.protocol.stage_three import stage_three_jobs, stage_three_retrain_jobs
from ftin.protocol.stride_retrain import (
    LIGHT_SPARSE_WEIGHT,
    control_head_jobs,
    stride_control_jobs,
    stride_head_jobs,
    stride_retrain_jobs,
)


def _stage_three(_variant: str | None = None) -> list[Job]:
    """Stage three's jobs (``ftin.protocol.stage_three``) on the default data and checkpoints."""
    return stage_three_jobs(DEFAULT_DATA_ROOT, DEFAULT_CHECKPOINT_DIR)


def _stage_three_retrain(_variant: str | None = None) -> list[Job]:
    """Stage three's retrain of the default's network on the pooled walkers (``stage_three``)."""
    return stage_three_retrain_jobs(DEFAULT_DATA_ROOT)


def _stride_retrain(_variant: str | None = None) -> list[Job]:
    """The stride issue's retrain with the ILC floors as sparse truth (``stride_retrain``)."""
    return stride_retrain_jobs(DEFAULT_DATA_ROOT)


def _stride_retrain_light(_variant: str | None = None) -> list[Job]:
    """The same retrain with the segment term at ``LIGHT_SPARSE_WEIGHT`` (``stride_retrain``)."""
    return stride_retrain_jobs(DEFAULT_DATA_ROOT, LIGHT_SPARSE_WEIGHT)


def _stride_retrain_light_head(_variant: str | None = None) -> list[Job]:
    """The variance head refitted on the light arm's frozen networks (``stride_retrain``)."""
    return stride_head_jobs(DEFAULT_DATA_ROOT)


def _stride_retrain_control(_variant: str | None = None) -> list[Job]:
    """FTIN on the default's recipe without ILC, the final recipe (``stride_retrain``)."""
    return stride_control_jobs(DEFAULT_DATA_ROOT)


def _stride_retrain_control_s1(_variant: str | None = None) -> list[Job]:
    """The control's second seed (``stride_retrain``)."""
    return stride_control_jobs(DEFAULT_DATA_ROOT, seed=1)


def _stride_retrain_control_head(_variant: str | None = None) -> list[Job]:
    """The variance head refitted on the control's frozen FTIN (``stride_retrain``)."""
    return control_head_jobs(DEFAULT_DATA_ROOT)


def _stride_retrain_control_s1_head(_variant: str | None = None) -> list[Job]:
    """The variance head refitted on the control's second seed (``stride_retrain``)."""
    return control_head_jobs(DEFAULT_DATA_ROOT, seed=1)


CAMPAIGNS: dict[str, Callable[[str | None], list[Job]]] = {  # by name (``plan --jobs``)
    "table1": campaign_jobs,
    "generalisation": generalisation_jobs,
    "tilt": tilt_question_jobs,
    "stage-three": _stage_three,
    "stage-three-retrain": _stage_three_retrain,
    "stride-retrain": _stride_retrain,
    "stride-retrain-light": _stride_retrain_light,
    "stride-retrain-light-head": _stride_retrain_light_head,
    "stride-retrain-control": _stride_retrain_control,
    "stride-retrain-control-s1": _stride_retrain_control_s1,
    "stride-retrain-control-head": _stride_retrain_control_head,
    "stride-retrain-control-s1-head": _stride_retrain_control_s1_head,
}
