"""One module per dataset layout; each declares ``SCHEMA`` and ``load(spec) -> RawRoute``."""
