"""Walker profiles (``ftin.profiles``): walks of known length filed under a name, and the scale they
give a prediction. Kept in the runs index (``ftin.profiles.store``), so that they survive restarts
and ``ftin profile`` sees the same ones.

A walk is a finished run and its true length (``distance_m``), or the run alone where its GPS is good
enough by the walk verdict's own GPS check (``ftin.profiles.walks``); the service turns what the
library refuses into the messages the API answers with.
"""

from __future__ import annotations

from app.services.errors import InvalidInputError, NotFoundError
from app.services.runs import RunStore
from ftin.profiles import AppliedProfile
from ftin.profiles.store import Profile, ProfileStore, check_name
from ftin.profiles.walks import walk_of


class ProfileService:
    def __init__(self, store: ProfileStore, runs: RunStore) -> None:
        self.store = store
        self.runs = runs

    def add_walk(self, name: str, run_id: str, distance_m: float | None = None) -> Profile:
        """File run ``run_id`` under ``name`` (created with its first walk); the profile as it is now."""
        _valid_name(name)
        run = self.runs.get(run_id)  # 404 / 410 naming the run
        applied = 1.0 if run.profile is None else run.profile.found.scale
        try:
            walk = walk_of(
                run_id, run.prediction.trajectory, run.plausibility, distance_m, applied, run.model_name
            )
        except ValueError as exc:
            raise InvalidInputError(str(exc)) from None
        return self.store.add_walk(name, walk)

    def get(self, name: str) -> Profile:
        found = self.store.get(_valid_name(name))
        if found is None:
            raise NotFoundError(f"unknown profile {name!r}: add a walk with POST /profiles/{name}/walks")
        return found

    def list(self) -> list[Profile]:
        return self.store.list()

    def delete(self, name: str) -> None:
        if not self.store.delete(_valid_name(name)):
            raise NotFoundError(f"unknown profile {name!r}")

    def applied(self, name: str) -> AppliedProfile:
        """What ``POST /predict?profile=name`` applies (404 naming an unknown profile)."""
        return self.get(name).applied()


def _valid_name(name: str) -> str:
    try:
        return check_name(name)
    except ValueError as exc:
        raise InvalidInputError(str(exc)) from None
