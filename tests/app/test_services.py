"""The service layer without HTTP: checkpoint loading at start-up, the sequence catalogue, runs."""

from __future__ import annotations

import json
import os
import threading
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace

import pytest
from fastapi.testclient import TestClient

from app.main import create_app
from app.services import Services
from app.services.catalog import SequenceCatalog, make_sequence_id
from app.services.checkpoint_store import ModelEntry, ModelStore
from app.services.errors import ConflictError, InvalidInputError, NotFoundError, StartupError
from app.services.runs import RunListener, RunState, RunStore
from app.settings import BUNDLED_SAMPLES_DIR, DEFAULT_CHECKPOINT_DIR, Settings

# --- settings ------------------------------------------------------------------------------------


def test_settings_defaults_need_no_configuration(monkeypatch: pytest.MonkeyPatch) -> None:
    for key in list(os.environ):
        if key.startswith("FTIN_"):
            monkeypatch.delenv(key)
    settings = Settings()
    assert settings.data_dirs == [BUNDLED_SAMPLES_DIR] and BUNDLED_SAMPLES_DIR.is_dir()
    assert settings.checkpoint_dir == DEFAULT_CHECKPOINT_DIR
    assert settings.viser_host == "127.0.0.1" and settings.viser_port == 8080
    assert settings.cors_origins == [] and settings.default_model == "ftin-pedestrian"
    assert not settings.default_model_is_explicit
    assert settings.max_samples == 720_000 and settings.max_concurrent_inferences == 1
    assert settings.torch_threads == 1
    catalog = SequenceCatalog.scan(settings.data_dirs)  # lists names only: reads no sample
    assert {e.name for e in catalog.list()} >= {
        "sim_handheld",
        "sim_pocket",
        "sim_stops_turns",
        "sim_trolley",
    }
    assert catalog.get("samples--sim_handheld").dataset == "csv" and catalog.notes == []


def test_settings_from_environment(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("FTIN_DATA_DIRS", os.pathsep.join([str(tmp_path / "a"), str(tmp_path / "b"), ""]))
    monkeypatch.setenv("FTIN_CHECKPOINT_DIR", str(tmp_path / "ckpt"))
    monkeypatch.setenv("FTIN_VISER_HOST", "0.0.0.0")
    monkeypatch.setenv("FTIN_VISER_PORT", "9123")
    monkeypatch.setenv("FTIN_MAX_UPLOAD_MB", "2.5")
    monkeypatch.setenv("FTIN_DEFAULT_MODEL", "Mine")
    monkeypatch.setenv("FTIN_CORS_ORIGINS", "http://a.example, http://b.example")
    monkeypatch.setenv("FTIN_MAX_SAMPLES", "1000")
    monkeypatch.setenv("FTIN_INFERENCE_TIMEOUT_S", "7.5")
    monkeypatch.setenv("FTIN_MAX_CONCURRENT_INFERENCES", "2")
    monkeypatch.setenv("FTIN_MAX_KEPT_SAMPLES", "5000")
    monkeypatch.setenv("FTIN_TORCH_THREADS", "0")
    settings = Settings()
    assert (settings.max_samples, settings.inference_timeout_s, settings.max_concurrent_inferences) == (
        1000,
        7.5,
        2,
    )
    assert settings.max_kept_samples == 5000 and settings.torch_threads == 0
    assert settings.data_dirs == [tmp_path / "a", tmp_path / "b"]
    assert settings.checkpoint_dir == tmp_path / "ckpt"
    assert (settings.viser_host, settings.viser_port) == ("0.0.0.0", 9123)
    assert settings.max_upload_bytes == int(2.5 * 2**20)
    assert settings.default_model == "Mine" and settings.default_model_is_explicit
    assert settings.cors_origins == ["http://a.example", "http://b.example"]


def test_bad_setting_names_the_variable(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FTIN_VISER_PORT", "eighty")
    with pytest.raises(ValueError, match="viser_port"):
        Settings()


# --- models --------------------------------------------------------------------------------------


def test_model_store_loads_every_checkpoint(checkpoint_dir: Path) -> None:
    store = ModelStore.load(checkpoint_dir, "ftin-oxiod")
    assert store.names() == ["ftin-oxiod", "resnet-tiny"] and store.default_name == "ftin-oxiod"
    assert store.get(None).name == "ftin-oxiod" and store.get("resnet-tiny").architecture == "resnet1d"
    with pytest.raises(NotFoundError, match="unknown model 'x'; loaded models: ftin-oxiod, resnet-tiny"):
        store.get("x")


def test_missing_default_falls_back_to_an_ftin_checkpoint(checkpoint_dir: Path) -> None:
    store = ModelStore.load(checkpoint_dir, "Somewhere-Else")
    assert store.default_name == "ftin-oxiod"
    assert store.notes == [
        f"default model 'Somewhere-Else' not found (no {checkpoint_dir}/Somewhere-Else.safetensors); "
        "using 'ftin-oxiod' instead"
    ]


def test_built_in_default_is_ftin_pedestrian_else_the_first_ftin_checkpoint(
    monkeypatch: pytest.MonkeyPatch, checkpoint_dir: Path
) -> None:
    """checkpoints/ftin-pedestrian.safetensors is the default; without it (today's tiny test folder)
    the first FTIN checkpoint stands in and a note names the file looked for. Names are matched in
    the paper's spelling too."""
    for key in list(os.environ):
        if key.startswith("FTIN_"):
            monkeypatch.delenv(key)
    monkeypatch.setenv("FTIN_CHECKPOINT_DIR", str(checkpoint_dir))
    settings = Settings()
    assert settings.default_model == "ftin-pedestrian"
    services = Services.build(settings.model_copy(update={"viser_enabled": False}))
    assert services.models.default_name == "ftin-oxiod"
    assert len(services.notes) == 1 and "ftin-pedestrian.safetensors" in services.notes[0]
    assert services.models.get(None).path == checkpoint_dir / "ftin-oxiod.safetensors"
    for spelling in ("FTIN-OxIOD", "FTIN-OXIOD", "ftin-oxiod"):
        assert services.models.get(spelling).name == "ftin-oxiod"
    assert (
        ModelStore.load(checkpoint_dir, "FTIN-OxIOD", default_is_explicit=True).default_name == "ftin-oxiod"
    )


def test_without_ftin_checkpoints_another_model_stands_in(tmp_path: Path, checkpoint_dir: Path) -> None:
    for suffix in (".safetensors", ".json"):
        (tmp_path / f"resnet-tiny{suffix}").write_bytes(
            (checkpoint_dir / f"resnet-tiny{suffix}").read_bytes()
        )
    store = ModelStore.load(tmp_path, "ftin-oxiod")
    assert store.default_name == "resnet-tiny"
    assert "default model 'ftin-oxiod' not found" in store.notes[0]
    assert f"{tmp_path}/ftin-oxiod.safetensors" in store.notes[0]


def test_names_differing_only_in_case_refuse_to_start(tmp_path: Path, checkpoint_dir: Path) -> None:
    for stem in ("ftin-oxiod", "FTIN-OxIOD"):
        for suffix in (".safetensors", ".json"):
            (tmp_path / f"{stem}{suffix}").write_bytes((checkpoint_dir / f"ftin-oxiod{suffix}").read_bytes())
    with pytest.raises(StartupError, match="both declare the model name .* case-insensitively"):
        ModelStore.load(tmp_path, "ftin-oxiod")


def test_explicit_missing_default_refuses_to_start(checkpoint_dir: Path) -> None:
    with pytest.raises(StartupError, match="FTIN_DEFAULT_MODEL='Mine' is not among the checkpoints"):
        ModelStore.load(checkpoint_dir, "Mine", default_is_explicit=True)


def test_empty_or_missing_checkpoint_folder_is_reported(tmp_path: Path) -> None:
    empty = ModelStore.load(tmp_path, "ftin-oxiod")
    assert empty.entries == {} and empty.default_name is None
    assert "no *.safetensors checkpoints in" in empty.notes[0] and "FTIN_CHECKPOINT_DIR" in empty.notes[0]
    with pytest.raises(NotFoundError, match="no model is loaded"):
        empty.get(None)
    missing = ModelStore.load(tmp_path / "nope", "ftin-oxiod")
    assert "does not exist" in missing.notes[0]


def test_empty_checkpoint_folder_app_starts_and_says_why(
    make_settings: Callable[..., Settings], tmp_path: Path, csv_with_gt: bytes
) -> None:
    with TestClient(create_app(make_settings(checkpoint_dir=tmp_path))) as client:
        health = client.get("/health").json()
        assert health["models"] == [] and health["default_model"] is None
        assert any(str(tmp_path) in note for note in health["notes"])
        assert client.get("/models").json() == []
        response = client.post("/predict", files={"file": ("w.csv", csv_with_gt, "text/csv")})
        assert response.status_code == 404 and "no model is loaded" in response.json()["detail"]


def _edit_config(json_path: Path, model_name: str | None = None, model_kwargs: dict | None = None) -> None:
    meta = json.loads(json_path.read_text())
    if model_name is not None:
        meta["model_name"] = model_name
    meta["model_kwargs"] = {**meta["model_kwargs"], **(model_kwargs or {})}
    json_path.write_text(json.dumps(meta))


@pytest.mark.parametrize(
    ("damage", "expected"),
    [
        (lambda w, j: w.write_bytes(w.read_bytes()[:100]), "truncated"),
        (lambda w, j: j.write_text("{not json"), "not valid JSON"),
        (lambda w, j: j.unlink(), "missing its config"),
        # Wrong architecture: the config builds a model the weights do not fit.
        (
            lambda w, j: _edit_config(j, model_kwargs={"resnet_channels": [8, 32]}),
            "weights do not match model",
        ),
        (lambda w, j: _edit_config(j, model_name="ftin"), "weights do not match model 'ftin'"),
        (lambda w, j: _edit_config(j, model_name="no_such_net"), "no_such_net"),
    ],
)
def test_corrupt_checkpoint_refuses_to_start(
    make_settings: Callable[..., Settings], checkpoint_dir: Path, tmp_path: Path, damage, expected: str
) -> None:
    for path in checkpoint_dir.iterdir():
        (tmp_path / path.name).write_bytes(path.read_bytes())
    damage(tmp_path / "resnet-tiny.safetensors", tmp_path / "resnet-tiny.json")
    app = create_app(make_settings(checkpoint_dir=tmp_path))
    with pytest.raises(StartupError, match=expected) as info:
        with TestClient(app):
            pass
    assert str(info.value).startswith(f"cannot load checkpoint {tmp_path}/resnet-tiny.")


# --- sequences -----------------------------------------------------------------------------------


def test_sequence_ids_are_url_safe() -> None:
    assert (
        make_sequence_id(Path("/data/oxiod"), "multi users/user2/syn/imu4")
        == "oxiod--multi-users-user2-syn-imu4"
    )
    assert make_sequence_id(Path("/x/samples"), "../../etc/passwd") == "samples--..-..-etc-passwd"


def test_catalog_drops_references_that_leave_the_folder(tmp_path: Path, data_dir: Path) -> None:
    root = tmp_path / "root"
    root.mkdir()
    (root / "inside.csv").write_bytes((data_dir / "walk_gt.csv").read_bytes())
    outside = tmp_path / "outside.csv"
    outside.write_bytes((data_dir / "walk_gt.csv").read_bytes())
    (root / "escape.csv").symlink_to(outside)
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "elsewhere" / "secret.csv").write_bytes(outside.read_bytes())
    (root / "linked").symlink_to(tmp_path / "elsewhere", target_is_directory=True)
    catalog = SequenceCatalog.scan([root, tmp_path / "missing"])
    assert [e.id for e in catalog.list()] == ["root--inside"]
    assert any("escape.csv" in note and "outside the data folder" in note for note in catalog.notes)
    assert any("missing" in note and "does not exist" in note for note in catalog.notes)
    with pytest.raises(NotFoundError):
        catalog.read("root--escape")


def test_catalog_ids_stay_unique_across_folders(tmp_path: Path, data_dir: Path) -> None:
    for name in ("one", "two"):
        folder = tmp_path / name / "walks"
        folder.mkdir(parents=True)
        (folder / "walk.csv").write_bytes((data_dir / "walk_gt.csv").read_bytes())
    catalog = SequenceCatalog.scan([tmp_path / "one" / "walks", tmp_path / "two" / "walks"])
    assert [e.id for e in catalog.list()] == ["walks--walk", "walks--walk-2"]
    summary = catalog.summary("walks--walk-2")
    assert summary.n_samples == 2000 and summary.has_ground_truth


def test_catalog_read_errors_are_invalid_input(data_dir: Path) -> None:
    catalog = SequenceCatalog.scan([data_dir])
    with pytest.raises(InvalidInputError, match="'walks--broken' cannot be read"):
        catalog.read("walks--broken")
    assert isinstance(catalog.summary("walks--broken"), str)


# --- runs ----------------------------------------------------------------------------------------


class Recorder(RunListener):
    def __init__(self) -> None:
        self.events: list[tuple[str, str]] = []

    def run_started(self, status) -> None:
        self.events.append(("started", status.run_id))

    def run_progress(self, status) -> None:
        self.events.append(("progress", f"{status.done}/{status.total}"))

    def run_failed(self, status) -> None:
        self.events.append(("failed", status.message))


class Broken(RunListener):
    def run_started(self, status) -> None:
        raise RuntimeError("viewer crashed")


def test_run_store_tracks_progress_and_isolates_listeners() -> None:
    store = RunStore(max_runs=2)
    recorder = Recorder()
    store.subscribe(Broken())
    store.subscribe(recorder)
    run_id = store.new_id("client-run-1")
    store.start(run_id, "FTIN", "walk")
    store.progress(run_id, 3, 10)
    assert store.status(run_id).state is RunState.RUNNING and store.status(run_id).done == 3
    store.fail(run_id, "bad data")
    assert store.status(run_id).state is RunState.FAILED
    assert recorder.events == [("started", "client-run-1"), ("progress", "3/10"), ("failed", "bad data")]
    with pytest.raises(ConflictError):
        store.new_id("client-run-1")
    with pytest.raises(InvalidInputError):
        store.new_id("../x")
    with pytest.raises(NotFoundError):
        store.get(run_id)  # failed runs keep a status, not a result
    assert len({store.new_id() for _ in range(100)}) == 100


def test_run_store_is_thread_safe() -> None:
    store = RunStore()

    def work(k: int) -> None:
        for i in range(50):
            run_id = f"run-{k}-{i:03d}"
            store.start(run_id, "m", "s")
            store.progress(run_id, 1, 2)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert store.status("run-3-049").done == 1


def test_training_data_is_summarised_in_words_not_listed() -> None:
    """No developer paths in the UI; the kind of data, else the folder's name."""

    def trained_on(data: object) -> str | None:
        return ModelEntry(
            "m", Path("m.safetensors"), SimpleNamespace(meta={"training_data": data})
        ).trained_on

    files = ["../data/oxiod/handheld/imu1.csv", "../data/oxiod/trolley/imu2.csv", "../data/oxiod/x/imu3.csv"]
    assert trained_on({"paths": files, "sequences": ["a", "b", "c"]}) == "OxIOD (3 sequences)"
    both = {"paths": [*files, "../data/ridi/dan_bag1"], "sequences": ["a", "b", "c", "dan_bag1"]}
    assert trained_on(both) == "OxIOD and RIDI (4 sequences)"
    assert trained_on({"paths": ["/data/sim/"], "sequences": ["a"]}) == "simulated walks (1 sequence)"
    assert trained_on({"paths": ["runs/x/train"], "sequences": ["sim_1000_handheld"]}) == (
        "simulated walks (1 sequence)"
    )
    assert trained_on({"paths": ["../my/walks/a.csv", "../my/walks/b.csv"]}) == "walks"
    assert trained_on({"paths": ["/abs/a.csv", "rel/b.csv"]}) == "unknown data"
    assert trained_on({"paths": []}) == "unknown data"
    assert trained_on("OxIOD handheld") == "OxIOD handheld" and trained_on(None) is None


def test_a_checkpoint_trained_on_two_kinds_serves_both() -> None:
    """ftin-pedestrian (OxIOD and RIDI) is ticked for either kind; the default before other FTIN ones."""

    def entry(name: str, architecture: str, *folders: str) -> ModelEntry:
        paths = [f"../data/{folder}/rec" for folder in folders]
        meta = {"training_data": {"paths": paths, "sequences": ["rec"] * len(paths)}}
        return ModelEntry(name, Path(name), SimpleNamespace(model_name=architecture, meta=meta))

    entries = [
        entry("resnet-ridi", "ronin_resnet", "ridi"),
        entry("ftin-oxiod", "ftin", "oxiod"),
        entry("ftin-pedestrian", "ftin", "oxiod", "ridi"),
        entry("ftin-sim", "ftin", "sim"),
    ]
    store = ModelStore(Path("."), {e.name: e for e in entries}, "ftin-pedestrian", [])
    assert store.entries["ftin-pedestrian"].data_kinds == ("oxiod", "ridi")
    assert store.for_kind("ridi") == "ftin-pedestrian" and store.for_kind("oxiod") == "ftin-pedestrian"
    assert store.for_kind("simulated") == "ftin-sim" and store.for_kind("euroc") == "ftin-pedestrian"
    assert (
        ModelStore(Path("."), {e.name: e for e in entries}, "ftin-sim", []).for_kind("oxiod") == "ftin-oxiod"
    )


# --- the default chosen on validation (default.json, written by `ftin campaign ship`) -------------


def _folder_with_default(tmp_path: Path, checkpoint_dir: Path, choice: object) -> Path:
    for path in checkpoint_dir.iterdir():
        (tmp_path / path.name).write_bytes(path.read_bytes())
    (tmp_path / "default.json").write_text(json.dumps(choice))
    return tmp_path


def test_default_json_names_the_default_and_why(
    tmp_path: Path, checkpoint_dir: Path, make_settings: Callable[..., Settings], csv_with_gt: bytes
) -> None:
    why = "the pedestrian checkpoint that walks its validation walks best (phone only): ATE 0.41x"
    folder = _folder_with_default(tmp_path, checkpoint_dir, {"model": "resnet-tiny", "why": why})
    store = ModelStore.load(folder, "ftin-pedestrian")
    assert store.default_name == "resnet-tiny" and store.default_why == why and not store.notes
    # FTIN_DEFAULT_MODEL still decides when set
    explicit = ModelStore.load(folder, "ftin-oxiod", default_is_explicit=True)
    assert explicit.default_name == "ftin-oxiod" and explicit.default_why is None
    # the answer and the page say which and why
    with TestClient(create_app(make_settings(checkpoint_dir=folder))) as client:
        assert client.get("/health").json()["default_model_why"] == why
        files = {"file": ("walk.csv", csv_with_gt, "text/csv")}
        choice = client.post("/predict", files=files).json()["model_choice"]
    assert choice["model"] == "resnet-tiny" and choice["rule"] == "default"
    # under every result a short clause; the campaign's story stays in /health and docs/models.md
    assert "chosen as the best on validation walks" in choice["reason"] and why not in choice["reason"]


def test_default_json_naming_a_missing_model_falls_back_and_a_broken_one_stops_the_start(
    tmp_path: Path, checkpoint_dir: Path
) -> None:
    folder = _folder_with_default(tmp_path, checkpoint_dir, {"model": "gone", "why": "best on validation"})
    store = ModelStore.load(folder, "ftin-pedestrian")
    assert store.default_name == "ftin-oxiod" and store.default_why is None
    assert "default model 'gone' not found" in store.notes[0]
    (folder / "default.json").write_text('{"model": 3}')
    with pytest.raises(StartupError, match=r"default\.json: expected"):
        ModelStore.load(folder, "ftin-pedestrian")
    (folder / "default.json").write_text("{not json")
    with pytest.raises(StartupError, match=r"cannot read .*default\.json"):
        ModelStore.load(folder, "ftin-pedestrian")
