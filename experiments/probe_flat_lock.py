"""Should the body lock fire for a phone held flat in front? (issue 54 / 50; ``ilc_direction.md``)

On the ILC mall walks (phone held flat in front, 50 Hz) the network's direction does not follow the
phone; the phone's heading plus the gait's forward offset (``ftin.body_heading``'s lock, forced on)
read the held-out floors far better, but the shipped lock does not fire there: the walks are shorter
than ``MIN_WALK_S`` (60 s) and their steadiness (0.42-0.78) is above ``LOCK_BELOW`` (0.35). The
candidate: lock where the phone is held flat in front (gravity along the device z, steadily).

The gate (written before any number below was read). A walk is **held flat** when the device z axis
of its phone-only orientation (``auto``, as the app runs) lies within ``tilt`` degrees of the vertical
(either face up or down) on at least ``share`` of its samples and it lasts at least ``min_s`` seconds.
A held-flat walk whose median steadiness (``ftin.body_heading.steadiness``) is under ``below`` is
locked exactly as the shipped lock locks (every window keeps the network's speed and takes the
phone's heading plus the walk's gait forward offset). The shipped rule (steadiness < 0.35 over a walk
of a minute or more) stays as it is, beside it.

Choosing the gate's parameters: on the tuning sets only, from the grid ``tilt`` 15, 25, 35 deg,
``share`` 0.8, 0.9, 0.95, ``min_s`` 10, 20 s, ``below`` 0.8, 0.9, any (1.01). A grid point qualifies
when, against today's default (the shipped lock), no tuning dense set's mean ATE is worse by more than
5 % and none of the Inria training walker's AR, Swinging and Texting walks (each motion's mean) either.
Of those, the one with the lowest median ATE at the waypoints over the pooled ILC tuning walks; ties
within 0.02 m go to the one locking the fewest dense tuning walks, then to the stricter gate (smaller
``tilt``, larger ``share``, longer ``min_s``, lower ``below``). No qualifying point: not adopted.

Sets (phone only, ``auto``; the default checkpoint, ``checkpoints/ronin_resnet-walking``):
- tuning: OxIOD, RIDI and Inria training parts (Inria: Thibaud), stage three's new training walks
  (``NEW_TRAIN``), ILC floors F1, F2, F3 (every ``--every``-th trace, 2);
- held out (read once, after the choice): OxIOD, RIDI and Inria validation parts (Inria: Guillaume,
  the held-out walker), the new OxIOD validation walkers and phones (``NEW_VAL``), the ten long floor
  walks with Tango truth (``FLOOR_DRIFT``), ILC floors B1 and F4 (every ``--every``-th trace, 2).

Adopted when, on the held-out sets, the chosen gate against today's default:
1. no dense set's mean ATE (RoNIN convention as ``ftin.evaluate.score`` scores a phone-only walk) is
   worse by more than 5 % (OxIOD, RIDI, Inria validation, the new validation walks, the floor walks);
2. Inria validation AR, Swinging and Texting walks (each motion's mean ATE) not worse by more than 5 %;
3. on ILC B1 and on F4 each, the median path ratio is closer to 1 and the median ATE at the waypoints
   lower (``ftin.metrics.waypoints``);
4. the heading error (``ftin.metrics.heading``: start-aligned, 10-s windows; the median over walks of
   each walk's median, as issue 50's tables) not worse by more than 1 deg on the floor walks, Inria
   validation, OxIOD validation and the new validation walks.
Failing any clause: not adopted, and the library stays as it is.

Method: each walk is read phone only and the network run once (``predict_trajectory``,
``body_lock=False``); its window velocities, spans, the prepared orientation and world-frame
acceleration are cached (``runs/probes/flat_lock``); each arm only re-locks and re-integrates
(``ftin.infer.integrate_spans``) and is scored. Arms: ``default`` (the shipped lock), ``locked`` (the
lock forced on: what a firing gate gives); a gate's result per walk is one or the other.

    nice -n 10 python -m experiments.probe_flat_lock --phase tune
    nice -n 10 python -m experiments.probe_flat_lock --phase check --out docs/results/probes/flat_lock.md
"""
