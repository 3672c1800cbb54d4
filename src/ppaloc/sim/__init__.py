"""ppaloc.sim (see docs/architecture.md)."""
