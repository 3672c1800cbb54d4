"""``load_dataset(spec)``: the one entry point from a spec string to a :class:`RouteDataset`.

Adding a layout means adding one module under ``ppaloc.datasets.loaders`` (or a package
like ``synthetic``) with ``SCHEMA`` and ``load(spec) -> RawRoute``, and one line in
:data:`KINDS`.
"""

from __future__ import annotations

import dataclasses
from importlib import import_module
from types import ModuleType

from ppaloc.datasets.base import RouteDataset
from ppaloc.datasets.route import assemble
from ppaloc.datasets.spec import DatasetSpec, DatasetSpecError, KindSchema, parse_spec

__all__ = [
    "KINDS",
    "REFERENCE_ALONE",
    "load_dataset",
    "load_reference",
    "parse_dataset_spec",
    "parse_reference_spec",
]

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


REFERENCE_ALONE = ("folder", "video")
"""Kinds of two traversals whose reference may be given alone where only it is read."""


def parse_reference_spec(spec: str) -> DatasetSpec:
    """Parse ``spec`` as :func:`parse_dataset_spec` does, with the reference of a kind of
    two traversals (:data:`REFERENCE_ALONE`) allowed alone (``folder:REF_DIR``).

    Raises
    ------
    DatasetSpecError
        Naming the bad part of the spec and the fix.
    """
    kinds = schemas()
    for kind in REFERENCE_ALONE:
        if kind in kinds:
            kinds[kind] = dataclasses.replace(kinds[kind], n_paths=(1, *kinds[kind].n_paths))
    return parse_spec(spec, kinds)


def load_reference(spec: str) -> RouteDataset:
    """The dataset of a spec whose reference traversal alone is read (``ppaloc map``).

    As :func:`load_dataset`, and a kind of two traversals (``folder:``, ``video:``) also
    takes its reference alone (``folder:REF_DIR``, ``video:REF.mp4``): the query is then
    the reference itself (read by nobody), so no query folder has to exist for a map.

    Raises
    ------
    DatasetSpecError, DataError
        As :func:`load_dataset`.

    Examples
    --------
    >>> import tempfile, numpy as np
    >>> from PIL import Image
    >>> folder = tempfile.mkdtemp()
    >>> for i in range(3):
    ...     Image.fromarray(np.full((4, 4), i, np.uint8)).save(f"{folder}/f{i}.png")
    >>> ds = load_reference(f"folder:{folder}?step=2")
    >>> len(ds.reference), ds.name.startswith("folder ")
    (2, True)
    """
    try:
        parsed = parse_reference_spec(spec)
    except DatasetSpecError:
        kind = spec.strip().partition(":")[0].strip().lower() if isinstance(spec, str) else ""
        if kind in REFERENCE_ALONE:  # load_dataset would call a bad key a missing query path
            raise
        return load_dataset(spec)  # the same mistake, named as load_dataset names it
    if len(parsed.paths) != 1 or parsed.kind not in REFERENCE_ALONE:
        return load_dataset(spec)
    (path,) = parsed.paths
    raw = _modules()[parsed.kind].load(dataclasses.replace(parsed, paths=(path, path)))
    raw.name = f"{parsed.kind} {path.name}"
    ds = assemble(raw, parsed.options)
    ds.meta.setdefault("spec", spec)
    return ds
