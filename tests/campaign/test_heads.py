"""``ftin.campaign.heads``: a variance head trained on a frozen shipped checkpoint replaces its weights and
adds a section to its card, and nothing else; a run whose network moved is refused."""

from __future__ import annotations

import json
import shutil

import pytest
import torch
from safetensors.torch import load_file, save_file

from ftin.campaign.heads import SECTION_TITLE, HeadShipError, ship_head
from ftin.checkpoint import load_model
from ftin.train import train
from tests.utils.checkpoints import head_train_config, tiny_model_kwargs, write_checkpoint

KWARGS = tiny_model_kwargs("ronin_resnet")
STEM = "ronin_resnet"


@pytest.fixture
def shipped_and_run(tmp_path, sim_sequences):
    shipped = tmp_path / "checkpoints"
    source = write_checkpoint(shipped / STEM, "ronin_resnet", seed=5, model_kwargs=KWARGS, story="as shipped")
    (shipped / f"{STEM}.md").write_text("# the card\n\nTable 1 row.\n")
    config = head_train_config(tmp_path / "run", source, max_epochs=1)
    train(config, sim_sequences, progress=False)
    return shipped, tmp_path / "run"


def test_the_head_is_shipped_onto_the_unchanged_network(shipped_and_run):
    shipped, run = shipped_and_run
    before = load_model(shipped / f"{STEM}.safetensors")
    ship_head(run, shipped, STEM, "stage-three/ronin_resnet-head-s0")
    after = load_model(shipped / f"{STEM}.safetensors")  # the card's hash matches the new weights
    assert after.model.has_uncertainty and not before.model.has_uncertainty
    x = torch.randn(3, 6, KWARGS["window"])
    with torch.no_grad():
        assert torch.equal(after.model.eval()(x).velocity, before.model.eval()(x).velocity)
    card = json.loads((shipped / f"{STEM}.json").read_text())
    assert card["story"] == "as shipped"  # the rest of the card stays as it was
    assert card["variance_head"]["job"] == "stage-three/ronin_resnet-head-s0"
    assert card["variance_head"]["trained"] == ["log_std_head"]
    text = (shipped / f"{STEM}.md").read_text()
    assert text.startswith("# the card") and text.count(SECTION_TITLE) == 1
    with pytest.raises(HeadShipError, match="already has a variance head"):
        ship_head(run, shipped, STEM, "again")


def test_a_run_whose_network_moved_is_refused(shipped_and_run, tmp_path):
    shipped, run = shipped_and_run
    moved = tmp_path / "moved"
    shutil.copytree(run, moved)
    tensors = load_file(moved / f"{STEM}.safetensors")
    name = next(k for k in tensors if not k.startswith("log_std_head") and tensors[k].is_floating_point())
    tensors[name] = tensors[name] + 1.0
    save_file(tensors, moved / f"{STEM}.safetensors")
    weights = (shipped / f"{STEM}.safetensors").read_bytes()
    with pytest.raises(HeadShipError, match="frozen tensors changed"):
        ship_head(moved, shipped, STEM, "moved")
    assert (shipped / f"{STEM}.safetensors").read_bytes() == weights  # nothing written
