"""ppaloc.onsensor (see docs/architecture.md)."""
