"""Bag analysis: the seeds' metrics (metrics.py), figures (figures.py), bag -> arrays (data.py)."""
