"""Live phone streams: push messages in, a trajectory that grows as the person walks.

``formats`` turns one request body of a phone app's push stream (Sensor Logger today) into a
``messages.PushMessage``; ``ordering`` puts messages back in order (loss, duplicates, overtaking),
``grid`` merges the sensors onto the model's clock in the export reader's units and signs,
``orientation`` is causal (the phone's own, else VQF online), ``incremental`` runs the model on new
windows only, ``session`` ties them together per phone (steps by ``ftin.metrics.steps``, as uploads),
``replay`` streams a Sensor Logger export as push messages (tests, demos, benchmarks).
"""
