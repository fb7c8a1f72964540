"""Live push formats, one module each, by name: ``FORMATS["sensorlogger"]`` is Sensor Logger's HTTP
Push. A second app's stream (phyphox's remote access, an MQTT bridge) is one more module here that
builds a ``PushFormat`` (its parser maps its sensors onto ``ftin.live.messages``' names) and registers
it (``register_push_format``, ``ftin.live.formats.base``); importing this package imports every
module in it, and the endpoint ``POST /live/{name}`` and the sessions come with it."""

from __future__ import annotations

from ftin.live.formats.base import FORMATS, PushFormat, default_format, register_push_format
from ftin.submodules import import_submodules

import_submodules(__name__, __path__)  # base, imported above, again: a no-op

DEFAULT_FORMAT = default_format()  # the one the upload page's push URL names

__all__ = ["DEFAULT_FORMAT", "FORMATS", "PushFormat", "register_push_format"]
