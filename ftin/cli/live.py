"""``ftin live replay``: stream a Sensor Logger export to a running app as HTTP Push messages (the
app's own message format), at the recording's pace or faster, with loss, duplicates and reordering
on request (``ftin.live.replay``)."""

from __future__ import annotations

import math
import urllib.parse
from pathlib import Path
from typing import Annotated

import typer

from ftin.cli.common import app, err_console, user_errors
from ftin.data.errors import DataFormatError
from ftin.live.replay import export_messages, perturb, send

live_app = typer.Typer(
    help="Live phone streams: replay an export as Sensor Logger push messages.", no_args_is_help=True
)
app.add_typer(live_app, name="live")

DEFAULT_URL = "http://127.0.0.1:8000/live/sensorlogger"


def _url_with_token(url: str, token: str | None) -> str:
    if token is None:
        return url
    parts = urllib.parse.urlsplit(url)
    query = urllib.parse.parse_qsl(parts.query) + [("token", token)]
    return urllib.parse.urlunsplit(parts._replace(query=urllib.parse.urlencode(query)))


@live_app.command("replay")
def replay(
    export: Annotated[Path, typer.Argument(help="A Sensor Logger export: its ZIP or its unzipped folder.")],
    url: Annotated[str, typer.Option("--url", help="The app's push URL.")] = DEFAULT_URL,
    speed: Annotated[
        float, typer.Option("--speed", min=0.0, help="Times real time; 0: as fast as possible.")
    ] = 1.0,
    batch_s: Annotated[
        float, typer.Option("--batch-s", min=0.01, help="Sensor Logger's batch period: seconds per message.")
    ] = 1.0,
    loss: Annotated[float, typer.Option("--loss", min=0.0, max=0.99, help="Share of messages lost.")] = 0.0,
    duplicate: Annotated[
        float, typer.Option("--duplicate", min=0.0, max=0.99, help="Share sent twice.")
    ] = 0.0,
    reorder: Annotated[
        float, typer.Option("--reorder", min=0.0, max=0.99, help="Share swapped with the next.")
    ] = 0.0,
    repeat: Annotated[
        int, typer.Option("--repeat", min=1, help="Play the export this many times back to back.")
    ] = 1,
    seed: Annotated[int, typer.Option("--seed", help="Seed of loss, duplicates and reordering.")] = 0,
    session_id: Annotated[str | None, typer.Option("--session-id", help="Default: a fresh one.")] = None,
    device_id: Annotated[
        str, typer.Option("--device-id", help="The phone's id in the messages.")
    ] = "ftin-replay",
    token: Annotated[
        str | None,
        typer.Option(
            "--token",
            help="The app's token (FTIN_TOKEN, or the one it printed at start).",
            envvar=["FTIN_TOKEN", "FTIN_LIVE_TOKEN"],
        ),
    ] = None,
) -> None:
    """Stream EXPORT to a running app (``uvicorn app.main:app``) as Sensor Logger's HTTP Push would."""
    with user_errors(DataFormatError, ValueError, OSError):
        if not export.exists():
            raise DataFormatError(f"{export}: no such file or folder")
        messages = export_messages(export, batch_s, session_id, device_id, repeat)
        messages = perturb(messages, loss, duplicate, reorder, seed)
        target = _url_with_token(url, token)
        duration = messages[-1].at_s if messages else 0.0
        err_console.print(
            f"replaying {len(messages)} messages ({duration:.1f} s of recording) to {url} "
            f"at {'full speed' if speed == 0 else f'{speed:g}x'}"
        )
        report = send(messages, target, math.inf if speed == 0 else speed)
    ok = report.statuses.get(200, 0)
    err_console.print(
        f"sent {report.sent} in {report.wall_s:.1f} s: {ok} accepted, statuses {report.statuses}"
    )
    for error in report.errors:
        err_console.print(f"  {error}", highlight=False)
    if report.failed or ok < report.sent:
        raise typer.Exit(1)
