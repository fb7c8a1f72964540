"""Benchmarks of the models and the product on this machine, as a library; ``ftin models`` and
``ftin bench`` print them. Import the module you need (this package imports nothing, so that a
measuring process started as ``python -m ftin.bench.memory`` loads only what it measures):

* ``profile``: size and speed of one model at a window — parameters, FLOPs per window (with the
  formulas PyTorch lacks), measured eval-mode windows/s (``ftin models``);
* ``side_by_side``: every model's inference and training windows/s, real-time factor and peak memory,
  each phase in its own forked process (``ftin bench``);
* ``memory``: the peak memory of one long prediction, in a fresh process (``ftin bench memory``);
* ``yaw_copies``: what the turned-copy average costs at inference (``ftin bench yaw-copies``);
* ``predict``, ``live``, ``scene``, ``load``: the product end to end — the REST upload round trip,
  phones streaming live, the 3D scene with many runs, the server under concurrent clients
  (``ftin bench predict|live|scene|load``). The app is a layer above this package: the command line
  starts it and hands over what these measure; they need the ``test`` extra (httpx, Playwright).
"""
