"""The evaluation protocol: disjoint splits by whole recording, carry modes in every part, valid jobs."""

from __future__ import annotations

from pathlib import Path

import pytest

from ftin import protocol
from ftin.train.config import TrainConfig


@pytest.mark.parametrize("dataset", sorted(protocol.SPLITS))
def test_parts_are_disjoint_whole_recordings(dataset):
    parts = protocol.SPLITS[dataset]
    seen: set[str] = set()
    for name in ("train", "val", "test"):
        assert parts[name] and not seen & set(parts[name]), f"{dataset} {name} overlaps another part"
        seen |= set(parts[name])


def _carry(dataset: str, recording: str) -> str:
    if dataset == protocol.OXIOD:
        return "trolley" if recording.startswith("trolley") else "handheld"
    return next(mode for mode in ("bag", "body", "handheld", "leg") if mode in recording)


@pytest.mark.parametrize("dataset", sorted(protocol.SPLITS))
def test_every_carry_mode_in_every_part_where_the_data_allows(dataset):
    parts = protocol.SPLITS[dataset]
    modes = {name: {_carry(dataset, r) for r in parts[name]} for name in parts}
    for mode in set().union(*modes.values()):
        count = sum(_carry(dataset, r) == mode for part in parts.values() for r in part)
        in_parts = sum(mode in found for found in modes.values())
        assert in_parts == min(3, count), f"{dataset}: {mode} ({count} recordings) is in {in_parts} part(s)"


def test_ridi_test_users_appear_nowhere_else():
    parts = protocol.SPLITS[protocol.RIDI]
    users = {name: {r.split("_")[0] for r in parts[name]} for name in parts}
    assert {"huayi", "shali"} <= users["test"]
    assert not {"huayi", "shali"} & (users["train"] | users["val"])


def test_every_job_is_a_valid_training_config(tmp_path):
    jobs = protocol.campaign_jobs("ordered")
    names = [job.name for job in jobs]
    assert len(names) == len(set(names))
    for job in jobs:
        config = TrainConfig(out_dir=str(tmp_path / job.name), **job.config(Path("/data")))
        assert config.early_stop_patience == protocol.COMMON["early_stop_patience"]
        assert config.window is not None and config.stride * protocol.PASSES_PER_EPOCH == config.window
    seeds = {(j.model, j.dataset): set() for j in jobs}
    for job in jobs:
        seeds[(job.model, job.dataset)].add(job.seed)
    for model in protocol.MULTI_SEED:
        for dataset in (protocol.OXIOD, protocol.RIDI):
            assert seeds[(model, dataset)] >= set(protocol.SEEDS), (model, dataset)
    # before the variant is chosen only seed 0 of both FTIN variants runs
    early = protocol.campaign_jobs(None)
    assert {j.variant for j in early if j.model == "ftin"} == {"mixed", "ordered"}
    assert all(j.seed == 0 for j in early if j.model == "ftin")


def test_split_paths_exist_in_the_shared_data(shared_data):
    for dataset in protocol.SPLITS:
        for part in ("train", "val", "test"):
            for path in protocol.split_paths(shared_data, dataset, part):
                assert path.exists(), path
