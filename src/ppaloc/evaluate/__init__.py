"""ppaloc.evaluate (see docs/architecture.md)."""
