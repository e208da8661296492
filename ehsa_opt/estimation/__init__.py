"""Estimation room: friction identification (paper §3, Eq 5 minimax), identifiability,
and the model-discrepancy workflow. Imports physics, datasets and utils."""

__all__: list[str] = []
