"""The registry of localisation methods by name.

Each entry names the class that implements it (imported only when asked for) and the
keyword arguments that select the variant. A method whose module is not importable is
simply not available. Adding a method means adding one line here.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ppaloc.errors import PpalocError
from ppaloc.localise.base import Localiser

__all__ = ["METHODS", "MethodSpec", "accepted_parameters", "available_methods", "make_localiser"]


@dataclass(frozen=True)
class MethodSpec:
    """Where a method lives and how its variant is selected."""

    target: str
    """``"module:Class"`` of the ``Localiser`` implementation."""
    defaults: Mapping[str, Any] = field(default_factory=dict)
    """Keyword arguments fixed by the method name (e.g. the representation)."""
    summary: str = ""


METHODS: dict[str, MethodSpec] = {
    "weighted-node-lowres": MethodSpec(
        "ppaloc.localise.weighted:WeightedNodeLocaliser",
        {"representation": "lowres"},
        "the robust weighted-node filter on the host, 8x8 images + SAD",
    ),
    "weighted-node-lbp": MethodSpec(
        "ppaloc.localise.weighted:WeightedNodeLocaliser",
        {"representation": "lbp"},
        "the robust weighted-node filter on the host, 32-bit LBP descriptors + Hamming",
    ),
    "weighted-node-paper-lowres": MethodSpec(
        "ppaloc.localise.weighted:WeightedNodeLocaliser",
        {"representation": "lowres", "preset": "paper"},
        "the paper's Algorithm 1 on the host, 8x8 images + SAD",
    ),
    "weighted-node-paper-lbp": MethodSpec(
        "ppaloc.localise.weighted:WeightedNodeLocaliser",
        {"representation": "lbp", "preset": "paper"},
        "the paper's Algorithm 1 on the host, 32-bit LBP descriptors + Hamming",
    ),
    "onsensor-lowres": MethodSpec(
        "ppaloc.onsensor.localiser:OnSensorLocaliser",
        {"representation": "lowres"},
        "the robust weighted-node filter as PPA programs on the simulator, 8x8 images",
    ),
    "onsensor-lbp": MethodSpec(
        "ppaloc.onsensor.localiser:OnSensorLocaliser",
        {"representation": "lbp"},
        "the robust weighted-node filter as PPA programs on the simulator, LBP descriptors",
    ),
    "onsensor-paper-lowres": MethodSpec(
        "ppaloc.onsensor.localiser:OnSensorLocaliser",
        {"representation": "lowres", "preset": "paper"},
        "the paper's Algorithm 1 as PPA programs on the simulator, 8x8 images",
    ),
    "onsensor-paper-lbp": MethodSpec(
        "ppaloc.onsensor.localiser:OnSensorLocaliser",
        {"representation": "lbp", "preset": "paper"},
        "the paper's Algorithm 1 as PPA programs on the simulator, LBP descriptors",
    ),
    "seqslam": MethodSpec(
        "ppaloc.baselines.seqslam:SeqSLAM", {}, "SeqSLAM (Milford & Wyeth 2012), past-only"
    ),
    "able-m": MethodSpec(
        "ppaloc.baselines.ablem:ABLEM", {}, "ABLE-M (Arroyo et al., ICRA 2015), binary sequences"
    ),
    "particle-filter": MethodSpec(
        "ppaloc.baselines.particle:ParticleFilter",
        {},
        "1-D particle filter over map nodes (after Liu & Zhang)",
    ),
    "single-frame": MethodSpec(
        "ppaloc.baselines.single:SingleFrame", {}, "best single-frame match, no sequence"
    ),
}


def _load(spec: MethodSpec) -> type:
    module, _, cls = spec.target.partition(":")
    return getattr(importlib.import_module(module), cls)


def available_methods() -> list[str]:
    """Names of the registered methods whose implementation can be imported."""
    names = []
    for name, spec in METHODS.items():
        try:
            _load(spec)
        except (ImportError, AttributeError):
            continue
        names.append(name)
    return names


def make_localiser(name: str, **params: Any) -> Localiser:
    """Construct the localiser registered as ``name`` with extra keyword ``params``.

    Raises
    ------
    PpalocError
        If the name is unknown or unavailable, or a parameter is not accepted.
    """
    if name not in METHODS:
        raise PpalocError(
            f"unknown method {name!r}; choose one of: {', '.join(available_methods())}"
        )
    spec = METHODS[name]
    try:
        cls = _load(spec)
    except (ImportError, AttributeError) as exc:
        raise PpalocError(f"method {name!r} is not available in this install ({exc})") from exc
    accepted = accepted_parameters(name)
    unknown = [key for key in params if accepted is not None and key not in accepted]
    if unknown:
        offered = [p for p in accepted or () if p not in spec.defaults]
        raise PpalocError(
            f"method {name!r}: unknown parameter {unknown[0]!r}; its parameters: "
            + ", ".join(offered)
        )
    try:
        return cls(**{**spec.defaults, **params})
    except TypeError as exc:
        raise PpalocError(f"method {name!r}: {exc}") from exc


def accepted_parameters(name: str) -> tuple[str, ...] | None:
    """Keyword parameters the class behind method ``name`` accepts, in its signature's order
    (None: any, the class takes ``**kwargs``).

    Examples
    --------
    >>> accepted_parameters("single-frame")
    ('size', 'patch', 'radius', 'top_k', 'record_weights')
    """
    signature = inspect.signature(_load(METHODS[name]))
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in signature.parameters.values()):
        return None
    return tuple(signature.parameters)
