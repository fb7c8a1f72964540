"""``ftin profile add / show / list / delete``: walker profiles (``ftin.profiles``), kept in the runs
index of a runs folder (``--runs-dir``, ``FTIN_RUNS_DIR``): the same store a server on this machine
uses, so that a profile made on the page serves ``ftin predict --profile`` and the other way round.

``add`` reads the run from that folder's run archive (a run the app made and stored), as the app's
``POST /profiles/{name}/walks`` does: with ``--distance``, that walk's true length; without, its GPS
path where the walk verdict's GPS check finds the GPS good enough.
"""

from __future__ import annotations

import json
from typing import Annotated

import typer

from ftin.cli.common import RunsDirOption, app, runs_dir_or_default, user_errors
from ftin.profiles.store import Profile, ProfileStore, UnknownProfileError, check_name
from ftin.profiles.walks import walk_of

profile_app = typer.Typer(
    help="Walker profiles: a walker's own distance scale from walks of known length.", no_args_is_help=True
)
app.add_typer(profile_app, name="profile")

NameArgument = Annotated[str, typer.Argument(help="The profile's name (1-64 letters, digits, _ - .).")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print JSON (the API's answer) instead of text.")]
PROFILE_ERRORS = (UnknownProfileError, ValueError, OSError)


def _store(runs_dir: RunsDirOption) -> ProfileStore:
    return ProfileStore.in_runs_dir(runs_dir_or_default(runs_dir))


def _print(profile: Profile, as_json: bool) -> None:
    if as_json:
        typer.echo(json.dumps(profile.to_json(), indent=1))
        return
    found = profile.scale
    typer.echo(
        f"{profile.name}: scale {found.scale:.3f}, spread {found.scale_sigma:.1%} "
        f"({found.walks} walk{'s' if found.walks != 1 else ''})"
    )
    for walk in profile.walks:
        typer.echo(
            f"  run {walk.run_id}: {walk.distance_m:.1f} m ({walk.source}), {walk.model or 'the model'} "
            f"read {walk.predicted_m:.1f} m: x{walk.sample:.3f}"
        )


@profile_app.command("add")
def add(
    name: NameArgument,
    run: Annotated[
        str, typer.Option("--run", help="A run stored in the runs folder (GET /runs lists them).")
    ],
    distance: Annotated[
        float | None,
        typer.Option("--distance", min=0.0, help="The walk's true length in metres (default: its GPS path)."),
    ] = None,
    runs_dir: RunsDirOption = None,
    as_json: JsonOption = False,
) -> None:
    """Add a stored run as a walk of known length to profile NAME (created with its first walk)."""
    with user_errors(*PROFILE_ERRORS):
        check_name(name)
        folder = runs_dir_or_default(runs_dir)
        # deferred: the run archive is the app's (its codec, its Run); only `add` reads a run
        from app.services.stored_runs import read_stored_run

        stored = read_stored_run(folder, run)
        applied = 1.0 if stored.profile is None else stored.profile.found.scale
        walk = walk_of(
            run, stored.prediction.trajectory, stored.plausibility, distance, applied, stored.model_name
        )
        _print(ProfileStore.in_runs_dir(folder).add_walk(name, walk), as_json)


@profile_app.command("show")
def show(name: NameArgument, runs_dir: RunsDirOption = None, as_json: JsonOption = False) -> None:
    """Print profile NAME: its scale, spread and walks."""
    with user_errors(*PROFILE_ERRORS):
        _print(_store(runs_dir).require(name), as_json)


@profile_app.command("list")
def list_profiles(runs_dir: RunsDirOption = None, as_json: JsonOption = False) -> None:
    """Print every profile."""
    with user_errors(*PROFILE_ERRORS):
        found = _store(runs_dir).list()
    if as_json:
        typer.echo(json.dumps([p.to_json() for p in found], indent=1))
    elif not found:
        typer.echo("no profiles")
    for profile in [] if as_json else found:
        _print(profile, False)


@profile_app.command("delete")
def delete(name: NameArgument, runs_dir: RunsDirOption = None) -> None:
    """Delete profile NAME and its walks."""
    with user_errors(*PROFILE_ERRORS):
        store = _store(runs_dir)
        store.require(name)
        store.delete(name)
    typer.echo(f"deleted profile {name}")
