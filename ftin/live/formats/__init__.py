"""Live push formats, one module each, by name: ``FORMATS["sensorlogger"]`` is Sensor Logger's HTTP
Push. A second app's stream (phyphox's remote access, an MQTT bridge) is one more module here that
builds a ``PushFormat`` (its parser maps its sensors onto ``ftin.live.messages``' names) and one
more entry below; the endpoint ``POST /live/{name}`` and the sessions come with it."""

from __future__ import annotations

from ftin.live.formats import sensorlogger
from ftin.live.formats.base import PushFormat

FORMATS: dict[str, PushFormat] = {f.name: f for f in (sensorlogger.FORMAT,)}
DEFAULT_FORMAT = sensorlogger.FORMAT  # the one the upload page's push URL names

__all__ = ["DEFAULT_FORMAT", "FORMATS", "PushFormat"]
