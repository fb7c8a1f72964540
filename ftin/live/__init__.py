"""Live phone streams: Sensor Logger's push messages in, a trajectory that grows as the person walks.

``messages`` parses and checks a push body, ``ordering`` puts messages back in order (loss,
duplicates, overtaking), ``grid`` merges the sensors onto the model's clock in the export reader's
units and signs, ``orientation`` is causal (the phone's own, else VQF online), ``incremental`` runs
the model on new windows only, ``steps`` counts steps for the status line, ``session`` ties them
together per phone, ``replay`` streams an export as push messages (tests, demos, benchmarks).
"""
