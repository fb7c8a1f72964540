"""Probes: one-off studies that answered a question, each beside its result (index: ``README.md``).

Run from the repository root as ``python -m experiments.<probe>``; they use the library, the library
never uses them.
"""
