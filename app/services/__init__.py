"""The service layer: everything the routes and the 3D scene do, without HTTP or GUI concerns."""

from __future__ import annotations

from dataclasses import dataclass

from app.services.catalog import SequenceCatalog
from app.services.checkpoint_store import ModelStore
from app.services.live import LiveService
from app.services.prediction import PredictionService
from app.services.profiles import ProfileService
from app.services.run_archive import RunArchive
from app.services.runs import RunStore
from app.settings import BUNDLED_SAMPLES_DIR, Settings
from ftin.profiles.store import ProfileStore


@dataclass
class Services:
    settings: Settings
    models: ModelStore
    catalog: SequenceCatalog
    runs: RunStore
    predictor: PredictionService
    live: LiveService
    profiles: ProfileService
    scene_url: str | None = None  # set once the viser server runs

    @classmethod
    def build(cls, settings: Settings) -> Services:
        """Load every checkpoint and list every data folder (raises StartupError for a broken checkpoint)."""
        models = ModelStore.load(
            settings.checkpoint_dir, settings.default_model, settings.default_model_is_explicit
        )
        catalog = SequenceCatalog.scan(settings.data_dirs, bundled_dir=BUNDLED_SAMPLES_DIR)
        archive = RunArchive.open(settings.runs_dir, settings.runs_disk_budget_bytes)
        runs = RunStore(settings.max_runs, settings.max_kept_samples, archive)
        predictor = PredictionService(models, catalog, runs, settings)
        live = LiveService(settings, models, runs)
        profiles = ProfileService(ProfileStore(archive.index_path), runs)  # a table in the runs index
        return cls(settings, models, catalog, runs, predictor, live, profiles)

    @property
    def notes(self) -> list[str]:
        return [*self.models.notes, *self.catalog.notes]
