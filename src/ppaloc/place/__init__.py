"""ppaloc.place (see docs/architecture.md)."""
