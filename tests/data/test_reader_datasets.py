"""One vocabulary for a dataset: its reader's registration names it (``dataset=``, ``folder=``), and the
app's kinds of data and the protocol read it there."""

from __future__ import annotations

import sys
import types

import pytest

from app.services import kinds
from ftin import protocol
from ftin.data import readers
from ftin.data.readers import _registry


def test_the_dataset_readers_name_their_datasets():
    formats = readers.dataset_formats()
    assert formats["oxiod"] == "oxiod" and formats["inria"] == "inria_attitude"
    assert {"ronin", "ridi", "tlio", "rnin", "imunet", "euroc"} <= set(formats)
    assert not {"csv", "sensorlogger", "phyphox"} & set(formats.values())  # no dataset: exports, CSV
    assert list(formats.values()) == [fmt for fmt in readers.READERS if fmt in formats.values()]  # priority
    assert (
        readers.dataset_folder("inria") == "inria_attitude/datasets"
        and readers.dataset_folder("ridi") == "ridi"
    )
    assert readers.dataset_label("oxiod") == readers.reader_label("oxiod") == "OxIOD"
    with pytest.raises(ValueError, match="no reader reads a dataset 'nope'"):
        readers.dataset_label("nope")


def test_the_app_and_the_protocol_read_the_registry():
    assert kinds.DATASET_FORMATS == readers.dataset_formats()
    assert {k: v for k, v in kinds.KIND_LABELS.items() if k != kinds.SIMULATED} == {
        d: readers.dataset_label(d) for d in readers.dataset_formats()
    }
    for dataset in protocol.DATA_FOLDERS:
        assert protocol.DATA_FOLDERS[dataset] == readers.dataset_folder(dataset)
        assert protocol.DATASET_LABELS[dataset] == readers.dataset_label(dataset)
    assert kinds.kind_of(["../shared/data/inria_attitude/datasets/ios/x"]) == "inria"


def test_a_dataset_read_twice_or_a_folder_without_a_dataset_is_refused(monkeypatch):
    for table in ("READERS", "PRIORITY", "DATASETS", "FOLDERS"):  # leave the real registry as it was
        monkeypatch.setattr(_registry, table, dict(getattr(_registry, table)))
    module = types.ModuleType("fake_oxiod_twin")
    module.FORMAT, module.LABEL = "oxiod_twin", "OxIOD twin"
    monkeypatch.setitem(sys.modules, module.__name__, module)

    def read(path):  # the fake module's read
        return path

    read.__module__ = module.__name__
    with pytest.raises(ValueError, match="dataset 'oxiod' is already read by 'oxiod'"):
        _registry.register_reader(priority=1, dataset="oxiod")(read)
    with pytest.raises(TypeError, match="folder= goes with dataset="):
        _registry.register_reader(priority=1, folder="x")
