"""The stride head only where the flat lock fires? (issue 54, item 3; ``flat_lock.md``, ``stride_head.md``)

Question: with the body lock firing for a phone held flat in front (``ftin.body_heading``,
``held_flat``), the held-out ILC floors read the direction right and 0.80-0.82 of their path: what is
left is the speed (0.79 of true). The stride head of ``probe_stride_head`` read that speed 0.97-0.99
of true on floors it never saw, but was not adopted because, applied to every walk, it made OxIOD
validation's hand-held walk worse. Applied **only where the flat lock fires** (the carry and gait the
ILC segments teach it), on top of the flat lock, does it bring the path to its length without
touching the dense walks?

The arm (fixed before any number below was read): ``probe_stride_head``'s ``speed + stride`` head
(ridge on the five stride features and the network's log speed, penalty by grouped cross-validation,
fitted on the default's training walkers and ILC waypoint segments; ``probe_stride_head``'s docstring,
steps 2-5). Not its ``network + stride`` candidate: the brief's product is the stride features plus the
network's speed, and the backbone's 512 channels would make every prediction keep its feature taps and
ship a 16 x 512 projection; on the earlier probe's (already read) rows the two read the held-out speed
within 0.025 of each other. Applied per window over the ``CONTEXT_S`` around it (speed scaled, direction
kept), and only on a walk where ``ftin.body_heading.lock_to_phone`` locks with ``held_flat``; every
other walk is left exactly as today's default reads it.

Arms: ``flat lock`` (today's default: ``lock_to_phone`` as shipped), ``flat lock + head``.

Evidence. ILC B1 and F4 have already been read by both component probes, so the **primary evidence
is leave-one-floor-out over F1, F2, F3**: the head is fitted on the default's training walkers plus two
of the three floors (every walk) and scored on the third (every 2nd trace, the walks
``probe_flat_lock`` cached), each floor once. Secondary (already read, reported as such): B1 and F4
(every 2nd trace) with the head fitted on the training walkers plus F1-F3, the head the product would
ship. Dense sets (phone only, ``auto``, RoNIN-convention ATE as ``ftin.evaluate.score`` scores it):
OxIOD, RIDI and Inria validation, the new OxIOD validation walkers and phones (``NEW_VAL``), the ten
long floor walks (``FLOOR_DRIFT``), with the shipped head; per set the walks the head touched (locked
with ``held_flat`` and at least one window scaled).

**The rule.** Adopted when all of these hold:
1. on each left-out floor (F1, F2, F3) the median path ratio is closer to 1 than the flat lock alone's,
   and more walks lie in 0.85-1.15;
2. on B1 and on F4 (secondary) the same;
3. no dense set's mean ATE (OxIOD, RIDI, Inria validation, ``NEW_VAL``, ``FLOOR_DRIFT``) is worse by
   more than 5 %;
4. Inria validation's Texting walks (mean ATE) not worse by more than 5 %.
Nothing is tuned after a number is read; a failed clause is reported as failed, and then nothing ships.

    nice -n 10 python -m experiments.probe_flat_stride --out docs/results/probes/flat_stride.md
"""
