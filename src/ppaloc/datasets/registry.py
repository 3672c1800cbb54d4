"""``load_dataset(spec)``: the one entry point from a spec string to a :class:`RouteDataset`.

Adding a layout means adding one module under ``ppaloc.datasets.loaders`` (or a package
like ``synthetic``) with ``SCHEMA`` and ``load(spec) -> RawRoute``, and one line in
:data:`KINDS`.
"""

from __future__ import annotations

from importlib import import_module
from types import ModuleType

from ppaloc.datasets.base import RouteDataset
from ppaloc.datasets.route import assemble
from ppaloc.datasets.spec import DatasetSpec, KindSchema, parse_spec

__all__ = ["KINDS", "load_dataset", "parse_dataset_spec"]

KINDS: dict[str, str] = {
    "folder": "ppaloc.datasets.loaders.folder",
    "nordland": "ppaloc.datasets.loaders.nordland",
    "gardens-point": "ppaloc.datasets.loaders.gardens_point",
    "vprbench": "ppaloc.datasets.loaders.vprbench",
    "citycentre": "ppaloc.datasets.loaders.citycentre",
    "video": "ppaloc.datasets.loaders.video",
    "synthetic": "ppaloc.datasets.synthetic.loader",
}
"""Dataset kind -> module that declares ``SCHEMA`` and ``load``."""


def _modules() -> dict[str, ModuleType]:
    out = {}
    for kind, name in KINDS.items():
        try:
            out[kind] = import_module(name)
        except ModuleNotFoundError as exc:  # a layout not written yet is simply not offered
            if exc.name != name:
                raise
    return out


def schemas() -> dict[str, KindSchema]:
    """Kind -> the paths and keys it accepts."""
    return {kind: mod.SCHEMA for kind, mod in _modules().items()}


def parse_dataset_spec(spec: str) -> DatasetSpec:
    """Parse and type-check ``spec`` (``KIND:PATH[?key=value&...]``) without loading data.

    Raises
    ------
    DatasetSpecError
        Naming the bad part of the spec and the fix.
    """
    return parse_spec(spec, schemas())


def load_dataset(spec: str) -> RouteDataset:
    """Return the :class:`RouteDataset` a spec string names.

    Parameters
    ----------
    spec : str
        ``KIND:PATH[?key=value&...]``, e.g. ``"nordland:data/nordland-64x32?ref=summer&
        query=winter"``, ``"folder:ref_dir,query_dir"`` or
        ``"synthetic:?places=500&query=winter&seed=1"``. Every kind accepts ``tolerance``,
        ``start``, ``stop``, ``step`` and ``patch_norm`` (see ``docs/datasets.md``).

    Returns
    -------
    RouteDataset
        Lazy traversals (frames are read on access) and the ground truth with the
        tolerance applied.

    Raises
    ------
    DatasetSpecError
        If the spec is malformed or names an unknown kind or key.
    DataError
        If a folder, image or ground-truth file is missing, unreadable or inconsistent.

    Examples
    --------
    >>> ds = load_dataset("synthetic:?places=20&sync=1&seed=3")
    >>> len(ds.reference), len(ds.query), ds.ground_truth[5].tolist()
    (20, 20, [4, 5, 6])
    """
    parsed = parse_dataset_spec(spec)
    raw = _modules()[parsed.kind].load(parsed)
    ds = assemble(raw, parsed.options)
    ds.meta.setdefault("spec", spec)
    return ds
