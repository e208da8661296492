"""Accuracy studies: the product's answers against known truths on cases fixed before the
first run (held-out confusion matrices, interval coverage, the second bench-data
generator, bounds and extrapolation).  Speed runs are in ``benchmarks/``."""
