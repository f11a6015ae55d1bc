"""Measured and simulated data: experiment files, the features read off a test or an experiment, pseudo-experiments."""
