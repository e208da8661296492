"""Pipeline room: ``ehsa-opt reproduce`` — its steps (:mod:`.base` holds the contract),
the per-topic report sections, the step cache. The only room that imports every other."""

__all__: list[str] = []
