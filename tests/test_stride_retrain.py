"""The stride issue's retrain (ftin/protocol/stride_retrain.py): each family's recipe with the ILC training
floors as sparse truth beside stage three's pooled walkers; the held-out floors in no part."""

from __future__ import annotations

import pytest

from ftin.files import DEFAULT_DATA_ROOT
from ftin.protocol.campaigns import CAMPAIGNS
from ftin.protocol.stage_three import REFERENCE_DISAGREES
from ftin.protocol.stride_retrain import (
    ILC_HELD_OUT,
    ILC_TRAIN_FLOORS,
    LIGHT_SPARSE_WEIGHT,
    control_head_jobs,
    stride_control_jobs,
    stride_head_jobs,
    stride_retrain_jobs,
)
from ftin.train.config import TrainConfig

ILC = DEFAULT_DATA_ROOT / "ilc" / "site1"


@pytest.mark.skipif(not ILC.is_dir(), reason=f"{ILC} is absent (the shared ILC sample)")
def test_the_retrain_mixes_the_ilc_training_floors_and_holds_the_others_out():
    jobs = stride_retrain_jobs(DEFAULT_DATA_ROOT)
    assert [j.model for j in jobs] == ["ronin_resnet", "ftin"] and "stride-retrain" in CAMPAIGNS
    for job in jobs:
        train, every = job.parts["train"], [r for part in job.parts.values() for r in part]
        ilc = [r for r in train if r.startswith("ilc/")]
        assert {r.split("/")[2] for r in ilc} == set(ILC_TRAIN_FLOORS) and len(ilc) == 305
        assert not any(f"/{floor}/" in r for floor in ILC_HELD_OUT for r in every)
        assert not set(REFERENCE_DISAGREES) & set(every)
        config = TrainConfig.from_json({**job.config(DEFAULT_DATA_ROOT), "out_dir": "x"})
        assert config.sparse_chunks == 4 and config.imu_rate_hz == 100.0
    resnet, ftin = (j.options for j in jobs)
    assert resnet["precision"] == "bf16" and resnet["augment"] == {"mirror": None}
    assert ftin.get("precision", "fp32") == "fp32" and ftin["augment"] == {"mirror": None, "pace": None}


@pytest.mark.skipif(not ILC.is_dir(), reason=f"{ILC} is absent (the shared ILC sample)")
def test_the_light_arm_differs_only_in_the_segment_terms_weight():
    heavy, light = stride_retrain_jobs(DEFAULT_DATA_ROOT), CAMPAIGNS["stride-retrain-light"](None)
    assert [j.name for j in light] == [
        "stride-retrain-light/ronin_resnet-sparse0.1-s0",
        "stride-retrain-light/ftin-sparse0.1-s0",
    ]
    for h, lt in zip(heavy, light, strict=True):
        assert lt.options == {**h.options, "sparse_weight": LIGHT_SPARSE_WEIGHT} and lt.parts == h.parts


@pytest.mark.skipif(not ILC.is_dir(), reason=f"{ILC} is absent (the shared ILC sample)")
def test_the_head_refit_starts_from_each_light_network_on_its_dense_walks_only(tmp_path):
    light, heads = CAMPAIGNS["stride-retrain-light"](None), stride_head_jobs(DEFAULT_DATA_ROOT, tmp_path)
    assert [j.name for j in heads] == [
        "stride-retrain-light-head/ronin_resnet-sparse0.1-head-s0",
        "stride-retrain-light-head/ftin-sparse0.1-head-s0",
    ]
    for arm, head in zip(light, heads, strict=True):
        start = tmp_path.resolve() / "stride-retrain-light" / arm.name / f"{arm.model}-walking.safetensors"
        assert head.options["init_from"] == str(start) and head.options["train_only"] == ["log_std_head"]
        assert head.options["model_kwargs"]["uncertainty_head"] and head.options["augment"]["tilt"] is None
        assert "sparse_weight" not in head.options and "precision" not in head.options
        dense_train = tuple(r for r in arm.parts["train"] if not r.startswith("ilc/"))
        assert head.parts["train"] == dense_train and head.parts["val"] == arm.parts["val"]


@pytest.mark.skipif(not ILC.is_dir(), reason=f"{ILC} is absent (the shared ILC sample)")
def test_the_control_is_ftin_on_the_defaults_dense_walks_without_ilc():
    (control,) = stride_control_jobs(DEFAULT_DATA_ROOT)
    ftin_arm = stride_retrain_jobs(DEFAULT_DATA_ROOT)[1]
    assert control.model == "ftin" and "sparse_weight" not in control.options
    assert control.options["augment"] == ftin_arm.options["augment"]
    assert control.options["model_kwargs"] == {"fdl_output": "mixed"}
    assert control.parts["train"] == tuple(r for r in ftin_arm.parts["train"] if not r.startswith("ilc/"))
    assert control.parts["val"] == ftin_arm.parts["val"]
    assert not set(REFERENCE_DISAGREES) & set(control.parts["train"])
    (second,) = CAMPAIGNS["stride-retrain-control-s1"](None)
    assert second.name == "stride-retrain-control-s1/ftin-pooled-s1" and second.seed == 1
    assert second.options == control.options and second.parts == control.parts


@pytest.mark.skipif(not ILC.is_dir(), reason=f"{ILC} is absent (the shared ILC sample)")
def test_the_controls_head_starts_from_its_ftin(tmp_path):
    (head,) = control_head_jobs(DEFAULT_DATA_ROOT, runs=tmp_path)
    assert head.name == "stride-retrain-control-head/ftin-pooled-head-s0" and head.model == "ftin"
    job = tmp_path.resolve() / "stride-retrain-control" / "stride-retrain-control" / "ftin-pooled-s0"
    assert head.options["init_from"] == str(job / "ftin-walking.safetensors")
    (second,) = control_head_jobs(DEFAULT_DATA_ROOT, seed=1, runs=tmp_path)
    job = tmp_path.resolve() / "stride-retrain-control-s1" / "stride-retrain-control-s1" / "ftin-pooled-s1"
    assert second.name == "stride-retrain-control-s1-head/ftin-pooled-s1-head-s0"
    assert second.options["init_from"] == str(job / "ftin-walking.safetensors")
    assert head.options["model_kwargs"] == {"fdl_output": "mixed", "uncertainty_head": True}
