"""Live push formats register themselves like readers: a module in ``ftin.live.formats`` is a format."""

from __future__ import annotations

import pkgutil
from dataclasses import replace

import pytest

from ftin.live import formats
from ftin.live.formats import base


def test_every_format_module_is_registered_and_one_is_the_default():
    names = [m.name for m in pkgutil.iter_modules(formats.__path__)]
    modules = [name for name in names if name != "base" and not name.startswith("_")]
    assert sorted(modules) == sorted(formats.FORMATS)  # one module, one format, under its own name
    assert formats.DEFAULT_FORMAT is formats.FORMATS["sensorlogger"] is base.default_format()


def test_a_second_format_under_a_taken_name_or_a_second_default_is_refused(monkeypatch):
    monkeypatch.setattr(base, "FORMATS", dict(base.FORMATS))
    taken = formats.FORMATS["sensorlogger"]
    with pytest.raises(ValueError, match="'sensorlogger' is already registered"):
        base.register_push_format(replace(taken, app="Another app"))
    with pytest.raises(ValueError, match="'sensorlogger' is already the default"):
        base.register_push_format(replace(taken, name="other"), default=True)
    assert base.register_push_format(taken) is taken  # its own module imported again: no error
