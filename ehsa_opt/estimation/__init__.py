"""Estimation room: friction identification (paper §3, Eq 5 minimax), identifiability,
and the model-discrepancy workflow (SPEC §7–9). Imports physics, datasets and utils."""

__all__: list[str] = []
