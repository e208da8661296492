"""The test suite; its folders mirror the package's rooms (see docs/architecture.md)."""
