"""Model-discrepancy workflow (SPEC §7–9)."""
