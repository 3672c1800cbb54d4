"""The registry of localisation methods by name.

Each entry names the class that implements it (imported only when asked for) and the
keyword arguments that select the variant. A method whose module is not importable is
simply not available. Adding a built-in method means adding one line here; a package of
one's own registers its methods in the ``ppaloc.methods`` entry-point group
(:data:`ENTRY_POINTS`, :func:`registry`).

What a method accepts and what it reads from a dataset is the class's own declaration:
``parameters() -> tuple[MethodParam, ...]`` (each parameter's type, default and range;
:class:`ppaloc.localise.base.MethodParam`) and ``dataset_needs(params) -> {argument:
DatasetNeed}`` (:class:`ppaloc.localise.base.DatasetNeed`, e.g. the true moves for the
oracle motion model). The command, evaluation and sweeps read those declarations
(:func:`method_parameters`, :func:`check_method`, :func:`dataset_arguments`) and know no
method by name. A class that declares no parameters (a plugin's, say) is read from its
signature: types and defaults, no ranges.
"""

from __future__ import annotations

import functools
import importlib
import importlib.metadata
import inspect
import logging
import math
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from ppaloc.errors import PpalocError
from ppaloc.localise.base import DatasetNeed, Localiser, MethodParam, signature_parameters

__all__ = [
    "ENTRY_POINTS",
    "METHODS",
    "MethodSpec",
    "accepted_parameters",
    "available_methods",
    "check_method",
    "check_parameters",
    "dataset_arguments",
    "dataset_needs",
    "make_localiser",
    "method_parameters",
    "parameter_table",
    "plugins",
    "registry",
]

log = logging.getLogger(__name__)


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
    "weighted-node-lowres16": MethodSpec(
        "ppaloc.localise.weighted:WeightedNodeLocaliser",
        {"representation": "lowres16"},
        "the robust weighted-node filter on the host, 16x16 images + SAD",
    ),
    "weighted-node-haar": MethodSpec(
        "ppaloc.localise.weighted:WeightedNodeLocaliser",
        {"representation": "haar"},
        "the robust weighted-node filter on the host, 192 Haar signs + Hamming",
    ),
    "weighted-node-patch": MethodSpec(
        "ppaloc.localise.weighted:WeightedNodeLocaliser",
        {"representation": "patch"},
        "the robust weighted-node filter on the host, the baselines' 64x32 patch-normalised "
        "image + mean absolute difference (host only, float)",
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
    "onsensor-lowres16": MethodSpec(
        "ppaloc.onsensor.localiser:OnSensorLocaliser",
        {"representation": "lowres16"},
        "the robust weighted-node filter as PPA programs on the simulator, 16x16 images "
        "(256 nodes a sensor, longer maps on a bank)",
    ),
    "onsensor-haar": MethodSpec(
        "ppaloc.onsensor.localiser:OnSensorLocaliser",
        {"representation": "haar"},
        "the robust weighted-node filter as PPA programs on the simulator, 192 Haar signs "
        "(512 nodes a sensor, longer maps on a bank)",
    ),
    "onsensor-auto": MethodSpec(
        "ppaloc.onsensor.localiser:OnSensorLocaliser",
        {"representation": "auto"},
        "the robust weighted-node filter as PPA programs on the simulator, the best "
        "place the map's length leaves room for on `sensors` sensors (default 1)",
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
    "seqslam-centred": MethodSpec(
        "ppaloc.baselines.seqslam:SeqSLAM",
        {"mode": "centred"},
        "OFFLINE, reads ds/2 future frames: SeqSLAM with OpenSeqSLAM's centred window",
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


def _type_words(hint: Any) -> str:
    """What a type hint asks for, in words."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is Literal:
        return "one of " + ", ".join(repr(a) for a in args)
    if origin in (typing.Union, types.UnionType):
        return " or ".join(_type_words(a) for a in args if a is not type(None))
    if origin is tuple:
        return "a list of " + (f"{len(args)} " if ... not in args else "") + "integers"
    return {bool: "true or false", int: "an integer", float: "a number", str: "text"}.get(
        hint, getattr(hint, "__name__", str(hint))
    )


def _fits(value: Any, hint: Any) -> bool:
    """Whether ``value`` (from TOML or ``--param``) fits the type hint ``hint``."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if hint is Any or hint is inspect.Parameter.empty:
        return True
    if origin is Literal:  # a subclass counts (numpy's str), but True is not the 1 of a list
        return any(
            value == a
            and isinstance(value, type(a))
            and isinstance(value, bool) == isinstance(a, bool)
            for a in args
        )
    if origin in (typing.Union, types.UnionType):
        return (value is None and type(None) in args) or any(
            _fits(value, a) for a in args if a is not type(None)
        )
    if hint is type(None):
        return value is None
    if hint is bool:
        return isinstance(value, bool)
    if hint is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if hint is float:
        return isinstance(value, int | float) and not isinstance(value, bool)
    if hint is str:
        return isinstance(value, str) and "\0" not in value and len(value) <= 4096
    if origin is tuple:
        if not isinstance(value, list | tuple):
            return False
        items = args[:1] * len(value) if len(args) == 2 and args[1] is ... else args
        return len(items) == len(value) and all(
            _fits(v, a) for v, a in zip(value, items, strict=True)
        )
    return True  # a type the command line cannot express (an array, an object): the class checks


ENTRY_POINTS = "ppaloc.methods"
"""The entry-point group a package registers its own methods in: ``NAME = "module:Class"``
(a :class:`~ppaloc.localise.base.Localiser` class) or ``NAME = "module:SPEC"`` (a
:class:`MethodSpec`, for fixed keyword arguments and a summary). They are offered
everywhere a built-in method is (``evaluate``, ``sweep``, ``bench``, ``map``,
``localise``); docs/evaluate-cli.md, "Your own method"."""


def registry() -> dict[str, MethodSpec]:
    """Every method by name: the built-in :data:`METHODS`, then the :func:`plugins`
    installed packages register (a plugin never replaces a built-in method)."""
    out = dict(METHODS)
    for name, spec in plugins().items():
        out.setdefault(name, spec)
    return out


@functools.cache
def plugins() -> dict[str, MethodSpec]:
    """The methods installed packages register in the :data:`ENTRY_POINTS` group.

    A plugin that cannot be loaded, is neither a class nor a :class:`MethodSpec`, or takes
    a built-in's name is left out with a logged warning naming it. Read once per process
    (``plugins.cache_clear()`` reads again).
    """
    out: dict[str, MethodSpec] = {}
    for ep in sorted(importlib.metadata.entry_points(group=ENTRY_POINTS), key=lambda e: e.name):
        where = f"method {ep.name!r} of the {ENTRY_POINTS} entry point {ep.value!r}"
        if ep.name in METHODS or ep.name in out:
            log.warning("%s: a method of that name exists; the plugin is not offered", where)
            continue
        try:
            obj = ep.load()
        except Exception as exc:  # a broken plugin must not break the command
            log.warning("%s cannot be loaded (%s); it is not offered", where, exc)
            continue
        if isinstance(obj, MethodSpec):
            out[ep.name] = obj
        elif isinstance(obj, type):
            doc = (inspect.getdoc(obj) or "").split("\n")[0]
            out[ep.name] = MethodSpec(ep.value, {}, f"{doc} (plugin)".strip())
        else:
            log.warning("%s is not a class or a MethodSpec; it is not offered", where)
    return out


def method_parameters(name: str) -> dict[str, MethodParam] | None:
    """The parameters method ``name`` accepts, by name, in the class's order (None: any,
    for a class that declares none and takes ``**kwargs``).

    Examples
    --------
    >>> p = method_parameters("weighted-node-lbp")["gain"]
    >>> p.default, p.low, p.high
    (4, 1, 32)
    """
    _, cls = _method_class(name)
    declared = getattr(cls, "parameters", None)
    if callable(declared):
        return {p.name: p for p in declared()}
    signature = inspect.signature(cls)
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in signature.parameters.values()):
        return None
    return {p.name: p for p in signature_parameters(cls)}


def _shown_value(value: Any) -> str:
    """A default as it would be given (TOML): ``true``, ``[1, 1]``, ``'image'``; ``-``
    for none (the method chooses, e.g. the paper preset's alpha from the map)."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, tuple | list):
        return "[" + ", ".join(_shown_value(v) for v in value) + "]"
    return repr(value) if isinstance(value, str) else str(value)


def _accepted(param: MethodParam) -> str:
    """What a value of ``param`` must be, in words, with its range."""
    if param.hint is Any or param.hint is inspect.Parameter.empty:
        return "what the method checks"
    words = _type_words(param.hint)
    if param.low is None and param.high is None:
        return words
    bounds = ", ".join(
        "inf" if b is None else (f"{b:g}" if isinstance(b, float) else str(b))
        for b in (param.low, param.high)
    )
    return f"{words} in [{bounds}]"


def parameter_table(name: str) -> tuple[list[tuple[str, str, str, str]], list[str]]:
    """The parameters method ``name`` takes with ``--param``, for ``ppaloc methods NAME``:
    rows of (parameter, default, accepted, what) in the class's order, with the default
    the method resolves (the built method's ``params``, where it keeps them: a preset's
    or a representation's own default; ``required`` for a keyword its class needs given),
    and the names left out because the method's
    preset does not read them. The keys the method's name fixes (``representation``,
    ``preset``) are not offered, as ``--param`` refuses nothing else.

    Examples
    --------
    >>> rows, _ = parameter_table("seqslam")
    >>> [r[:3] for r in rows if r[0] == "ds"]
    [('ds', '10', 'an integer in [0, 500]')]
    >>> parameter_table("weighted-node-paper-lbp")[1][:2]
    ['gain', 'memory']
    """
    spec, cls = _method_class(name)
    declared = method_parameters(name)
    if declared is None:
        return [], []
    try:  # a keyword without a default must be given: "-" would say the method chooses
        required = {
            k
            for k, p in inspect.signature(cls).parameters.items()
            if p.default is p.empty and p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)
        }
    except (TypeError, ValueError):  # no signature to read
        required = set()
    try:
        built = make_localiser(
            name, **{a: need.stand_in for a, need in dataset_needs(name, {}).items()}
        )
    except PpalocError:  # a class that needs a value given (a plugin's): its declaration
        built = None
    resolved = getattr(built, "params", None)
    fields = getattr(resolved, "__dataclass_fields__", {})
    group = getattr(resolved, "group", None)
    rows, left_out = [], []
    for key, param in declared.items():
        if key in spec.defaults:
            continue
        contract = fields[key].metadata.get("param") if key in fields else None
        if group is not None and getattr(contract, "group", None) not in (None, group):
            left_out.append(key)
            continue
        default = getattr(resolved, key) if key in fields else param.default
        shown = "required" if key in required and default is None else _shown_value(default)
        rows.append((key, shown, _accepted(param), param.doc))
    return rows, left_out


def check_parameters(name: str, params: Mapping[str, Any]) -> None:
    """Check each parameter of method ``name`` against its declared type and range
    (:func:`method_parameters`), before the method is built.

    Raises
    ------
    PpalocError
        Naming the method, the parameter, the value and what is accepted.

    Examples
    --------
    >>> check_parameters("seqslam", {"ds": 100000})
    Traceback (most recent call last):
    ppaloc.errors.PpalocError: method 'seqslam': ds=100000 must be in [0, 500]
    """
    spec, _ = _method_class(name)
    accepted = method_parameters(name)
    unknown = [key for key in params if accepted is not None and key not in accepted]
    if unknown:
        offered = [p for p in accepted or () if p not in spec.defaults]
        key = str(unknown[0])
        bare = key.partition(".")[2]
        if bare in offered:  # the METHOD.KEY form where the method is already known
            raise PpalocError(
                f"method {name!r}: unknown parameter {key[:60]!r}; the parameters here "
                f"are the method's own: give {bare}=... without the {key.partition('.')[0]!r} "
                "prefix"
            )
        raise PpalocError(
            f"method {name!r}: unknown parameter {key[:60]!r}; its parameters: "
            + ", ".join(offered)
        )
    for key, value in params.items():
        shown = repr(value) if len(repr(value)) <= 60 else repr(value)[:57] + "..."
        declared = (accepted or {}).get(key)
        hint = Any if declared is None else declared.hint
        if not _fits(value, hint):
            raise PpalocError(f"method {name!r}: {key}={shown} must be {_type_words(hint)}")
        if declared is None or value is None or (declared.low is None and declared.high is None):
            continue
        low = -math.inf if declared.low is None else declared.low
        high = math.inf if declared.high is None else declared.high
        for item in value if isinstance(value, list | tuple) else [value]:
            number = isinstance(item, int | float) and not isinstance(item, bool)
            if not number or not math.isfinite(item) or not low <= item <= high:
                bounds = ", ".join(str(b) if isinstance(b, int) else f"{b:g}" for b in (low, high))
                raise PpalocError(f"method {name!r}: {key}={shown} must be in [{bounds}]")


def dataset_needs(name: str, params: Mapping[str, Any]) -> dict[str, DatasetNeed]:
    """What method ``name`` reads from its dataset with ``params`` (argument -> need; the
    class's ``dataset_needs``, nothing for a class that declares none)."""
    _, cls = _method_class(name)
    declared = getattr(cls, "dataset_needs", None)
    return dict(declared(params)) if callable(declared) else {}


def check_method(name: str, params: Mapping[str, Any]) -> None:
    """Check ``params`` for method ``name`` once, before any data is loaded: their types
    and ranges (:func:`check_parameters`), then the method's own checks (it is built once,
    without a map, with a stand-in for what it would read from a dataset).

    Raises
    ------
    PpalocError
        One line naming the method, the parameter and the fix.
    """
    check_parameters(name, params)
    stand_ins = {arg: need.stand_in for arg, need in dataset_needs(name, params).items()}
    make_localiser(name, **params, **stand_ins)


def dataset_arguments(
    name: str, params: Mapping[str, Any], dataset: Any, spec: str
) -> dict[str, Any]:
    """The keyword arguments method ``name`` takes from ``dataset`` (its
    :func:`dataset_needs`), or a one-line error when the dataset has one of them not.

    Examples
    --------
    >>> dataset_arguments("seqslam", {}, None, "synthetic")
    {}
    """
    out = {}
    for arg, need in dataset_needs(name, params).items():
        value = getattr(dataset, need.attribute, None)
        if value is None:
            raise PpalocError(f"{name}: {need.why}, which {spec} does not have; {need.fix}")
        out[arg] = value
    return out


def _method_class(name: str) -> tuple[MethodSpec, type]:
    """The registry entry of ``name`` and its class, or a one-line error naming the fix."""
    methods = registry()
    if name not in methods:
        raise PpalocError(
            f"unknown method {name!r}; choose one of: {', '.join(available_methods())}"
        )
    spec = methods[name]
    try:
        return spec, _load(spec)
    except (ImportError, AttributeError) as exc:
        raise PpalocError(f"method {name!r} is not available in this install ({exc})") from exc


def _load(spec: MethodSpec) -> type:
    module, _, cls = spec.target.partition(":")
    return getattr(importlib.import_module(module), cls)


def available_methods() -> list[str]:
    """Names of the registered methods whose implementation can be imported."""
    names = []
    for name, spec in registry().items():
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
    spec, cls = _method_class(name)
    check_parameters(name, params)
    try:
        return cls(**{**spec.defaults, **params})
    except (TypeError, ValueError, OverflowError) as exc:
        raise PpalocError(f"method {name!r}: {exc}") from exc
    except PpalocError as exc:  # the class's own check: say which method, as above
        if str(exc).startswith(f"method {name!r}"):
            raise
        raise type(exc)(f"method {name!r}: {exc}") from exc


def accepted_parameters(name: str) -> tuple[str, ...] | None:
    """Keyword parameters the class behind method ``name`` accepts, in its declared order
    (None: any, the class takes ``**kwargs`` and declares no parameters).

    Examples
    --------
    >>> accepted_parameters("single-frame")
    ('size', 'patch', 'descriptor', 'radius', 'top_k', 'record_weights')
    """
    params = method_parameters(name)
    return None if params is None else tuple(params)
