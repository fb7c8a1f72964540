"""The ``ftin`` command line: thin callers of the library. Each sub-module registers its commands."""

from __future__ import annotations

import typer

app = typer.Typer(
    name="ftin",
    help="FTIN Studio: inertial odometry data tools, models, training, evaluation and prediction.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
)

# Sub-modules add their commands to `app` on import.
from ftin.cli import data, models, report, sim, train  # noqa: E402,F401


def main() -> None:
    app()
