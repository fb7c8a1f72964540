"""Analyses of trained models: what they read from their input (``speed_cues``)."""
