"""The ``ftin`` command line: thin callers of the library. One sub-module per command (``data`` a
group of them) registers it on ``app`` (``ftin.cli.common``) on import; shared plumbing lives in
``common`` too, so no command module imports this package back."""

from __future__ import annotations

# Sub-modules add their commands to `app` on import; the import order is `ftin --help`'s order.
from ftin.cli import bench, campaign, data, evaluate, live, models, predict, profile, sim, table, train  # noqa: E402,F401,I001
from ftin.cli.common import app


def main() -> None:
    app()
