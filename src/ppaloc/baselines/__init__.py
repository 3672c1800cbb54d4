"""ppaloc.baselines (see docs/architecture.md)."""
