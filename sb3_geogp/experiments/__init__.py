"""Experiments built on the public API: data generators, ground truth, runners, plots."""
