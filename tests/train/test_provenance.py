"""What a checkpoint records about its training data: datasets by name, recordings relative to the
data folder, and the one-time conversion of cards written before that."""

from __future__ import annotations

from types import SimpleNamespace

from app.services.kinds import training_kinds
from ftin.data.readers import READERS
from ftin.train.model_card import _dataset_of
from ftin.train.provenance import (
    KNOWN_DATASETS,
    absolute_paths_in,
    convert_card,
    relative_recording,
    training_data_record,
)


def _seq(name: str, dataset: str) -> SimpleNamespace:
    return SimpleNamespace(name=name, meta={"dataset": dataset})


def test_a_record_names_datasets_and_cuts_paths_at_the_dataset_folder() -> None:
    paths = [
        "/home/me/data/oxiod/handheld/data1/syn/imu2.csv",
        "C:\\\\data\\\\ridi\\\\dan_bag1",
        "/tmp/mine.csv",
    ]
    record = training_data_record(paths, [_seq("a", "oxiod"), _seq("b", "ridi"), _seq("c", "oxiod")])
    assert record["datasets"] == ["oxiod", "ridi"]
    assert record["recordings"] == ["oxiod/handheld/data1/syn/imu2.csv", "ridi/dan_bag1", "mine.csv"]
    assert record["sequences"] == ["a", "b", "c"] and absolute_paths_in(record) == []
    assert relative_recording("/x/runs/campaign/sim-data/train", ["sim"]) == "sim-data/train"
    walk = "/d/inria_attitude/datasets/ios/Thibaud_iPhone5_NoDist_AR"  # a dataset named with "_"
    assert (
        relative_recording(walk, ["oxiod", "inria_attitude"])
        == "inria_attitude/datasets/ios/Thibaud_iPhone5_NoDist_AR"
    )


def test_a_card_cut_by_the_older_rule_reads_its_recordings_from_its_training_paths() -> None:
    walk = "/work/shared/data/inria_attitude/datasets/ios/Thibaud_iPhone5_NoDist_AR"
    card = {
        "training_data": {
            "datasets": ["oxiod", "inria_attitude"],
            "recordings": ["oxiod/trolley/imu1.csv", "Thibaud_iPhone5_NoDist_AR"],  # the name alone
            "sequences": ["trolley/imu1", "Thibaud_iPhone5_NoDist_AR"],
        },
        "train_config": {"data": ["/work/shared/data/oxiod/trolley/imu1.csv", walk], "out_dir": "/w/runs/a"},
    }
    converted = convert_card(card)
    assert (
        converted["training_data"]["recordings"][1] == "inria_attitude/datasets/ios/Thibaud_iPhone5_NoDist_AR"
    )
    assert converted["train_config"]["data"] == converted["training_data"]["recordings"]
    assert absolute_paths_in(converted) == [] and convert_card(converted) == converted
    assert _dataset_of({"training_data": {"datasets": ["oxiod", "ridi", "inria_attitude"]}}) == "walking"


def test_a_legacy_card_is_converted_once_and_read_without_guessing() -> None:
    legacy = {
        "training_data": {
            "paths": ["/work/shared/data/oxiod/trolley/imu1.csv", "/work/shared/data/ridi/dan_bag1"],
            "sequences": ["trolley/imu1", "dan_bag1"],
        },
        "train_config": {
            "data": ["/work/shared/data/oxiod/trolley/imu1.csv"],
            "val": ["/work/shared/data/ridi/hang_body1"],
            "out_dir": "/work/main/runs/campaign/pedestrian/ftin-s0",
        },
        "weights_sha256": "abc",
    }
    card = convert_card(legacy)
    assert card["training_data"]["datasets"] == ["oxiod", "ridi"]
    assert card["train_config"]["out_dir"] == "runs/campaign/pedestrian/ftin-s0"
    assert card["train_config"]["val"] == ["ridi/hang_body1"] and card["weights_sha256"] == "abc"
    assert absolute_paths_in(card) == [] and absolute_paths_in(legacy) != []
    assert convert_card(card) == card  # once: a converted card stays as it is
    # The app and the model card read the datasets the card names.
    assert training_kinds(card["training_data"]) == ("oxiod", "ridi") and _dataset_of(card) == "pedestrian"
    named_only = {"datasets": ["sim"], "recordings": ["x/train"], "sequences": ["walk"]}
    assert (
        training_kinds(named_only) == ("simulated",) and _dataset_of({"training_data": named_only}) == "sim"
    )


def test_the_datasets_a_legacy_card_may_name_are_reader_formats_or_the_simulators() -> None:
    assert set(KNOWN_DATASETS) - {"sim"} <= set(READERS)
