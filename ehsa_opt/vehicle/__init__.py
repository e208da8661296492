"""Vehicle room: ISO 8608 roads, ISO 2631 W_k weighting, the exact frequency path
(:mod:`.metrics`), the compiled time-domain path (:mod:`.simulate`) and the paper's §4.1
studies (:mod:`.studies`). Imports physics, datasets and utils."""

__all__: list[str] = []
