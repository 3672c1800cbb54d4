"""The interface every localisation method implements, and what it returns per frame."""

from __future__ import annotations

import inspect
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:
    from ppaloc.topomap import TopoMap

__all__ = ["DatasetNeed", "Estimate", "Localiser", "MethodParam", "signature_parameters"]


@dataclass(frozen=True, slots=True)
class Estimate:
    """One localisation result for one query frame.

    Parameters
    ----------
    node : int
        Index of the predicted map node (0-based, map order).
    score : float
        Confidence, higher = surer. PR curves threshold on it, so it must be comparable
        across the frames of one run (not necessarily across methods).
    moved : bool or None
        The motion model's decision for this frame (forward = True), None where the method
        has no motion model.
    ranking : ndarray of int, shape (K,), optional
        The K best nodes, best first, for recall@K; None where the method does not rank.
    weights : ndarray, shape (N,), optional
        Per-node weights or scores after this frame, only when the localiser was asked to
        record them (they cost a copy of N values per frame).
    modelled_latency_ms : float, optional
        Modelled on-sensor time for this frame (simulated methods only).
    energy_mj : float, optional
        Modelled on-sensor energy for this frame (simulated methods only).
    """

    node: int
    score: float
    moved: bool | None = None
    ranking: np.ndarray | None = None
    weights: np.ndarray | None = None
    modelled_latency_ms: float | None = None
    energy_mj: float | None = None


@runtime_checkable
class Localiser(Protocol):
    """An online, past-only localiser over a 1-D topological map.

    Every frame handed to a localiser is a sensor frame: a 2-D ``uint8`` array of shape
    (256, 256) as produced by :func:`ppaloc.datasets.to_sensor`. ``step`` sees one new frame
    and nothing of the future.
    """

    name: str

    def build_map(self, frames: Sequence[np.ndarray]) -> TopoMap:
        """Build (and keep) the map from a reference traversal; one node per frame."""
        ...

    def reset(self) -> None:
        """Forget all per-query state (weights, history); keep the map."""
        ...

    def step(self, frame: np.ndarray) -> Estimate:
        """Localise one new query frame."""
        ...


@dataclass(frozen=True)
class MethodParam:
    """One keyword parameter a localiser accepts: its type, its default and its range.

    A localiser class declares its parameters with a classmethod ``parameters() ->
    tuple[MethodParam, ...]``; the method registry (:mod:`ppaloc.methods`) checks every
    value a user gives (``--param``, TOML, a sweep) against them before any work, and
    ``ppaloc methods NAME`` lists them. A class that declares none is read from its signature.

    Attributes
    ----------
    name : str
    hint : type hint
        What a value must be (``int``, ``float``, ``bool``, ``str``, ``tuple[int, int]``,
        a ``Literal``, unions with ``None``; ``Any``: the class checks it).
    default : Any
        The default (None where it is resolved later, e.g. per preset).
    low, high : float, optional
        The accepted range of a number (of each item of a tuple).
    doc : str
        One line for help texts.
    """

    name: str
    hint: Any
    default: Any = None
    low: float | None = None
    high: float | None = None
    doc: str = ""


@dataclass(frozen=True)
class DatasetNeed:
    """What a localiser reads from the dataset it runs on, for one keyword argument.

    A localiser class declares them with a classmethod ``dataset_needs(params) -> dict[str,
    DatasetNeed]`` (argument name -> need), for the given parameters (e.g. the true moves
    only with ``motion="oracle"``). Evaluation and sweeps pass ``getattr(dataset,
    attribute)`` as that argument, or stop with ``why`` and ``fix`` when the dataset has
    none; checks made before any data is loaded pass ``stand_in``.
    """

    attribute: str
    why: str
    fix: str
    stand_in: Any = None


#: Words a sentence of a description does not end after.
_NOT_AN_END = ("e.g.", "i.e.", "et al.", "vs.", "cf.", "approx.")


def _first_sentence(text: str) -> str:
    """``text`` up to its first full stop that ends a sentence (not "e.g.", not "2 .. 3")."""
    for m in re.finditer(r"(?<=[^.\s]\.)\s+(?=[A-Z\"(`])", text):
        if not text[: m.start()].endswith(_NOT_AN_END):
            return text[: m.start()]
    return text


def parameter_lines(doc: str | None) -> dict[str, str]:
    r"""What each entry of a numpydoc ``Parameters`` section says, by name, with reST
    markup taken out: the line ``ppaloc methods NAME`` shows, from the docstring that
    already documents it. An entry's first sentence; the whole entry where its type is a
    set of choices (``{"a", "b"}``: each choice is described in turn). ``a, b : int``
    gives both names the line.

    Examples
    --------
    >>> doc = "\n".join([
    ...     "A toy.", "", "Parameters", "----------", "size : int",
    ...     '    Side of the image (``descriptor="patch"`` only), e.g. 64. More words.',
    ...     "lo, hi: float", "    Bounds of :func:`~ppaloc.place.thing`;", "",
    ...     "    :attr:`Estimate.weights` inclusive.",
    ...     'mode : {"a", "b"}', '    "a": one way. "b": the other.',
    ...     "", "Returns", "-------", "int",
    ... ])
    >>> lines = parameter_lines(doc)
    >>> lines["size"]
    'Side of the image (descriptor="patch" only), e.g. 64.'
    >>> lines["hi"], list(lines)
    ('Bounds of thing; Estimate.weights inclusive.', ['size', 'lo', 'hi', 'mode'])
    >>> lines["mode"]
    '"a": one way. "b": the other.'
    """
    lines = inspect.cleandoc(doc or "").splitlines()
    rule = [bool(ln.strip()) and set(ln.strip()) == {"-"} for ln in lines]
    start = next(
        (k + 2 for k in range(len(lines) - 1) if lines[k].strip() == "Parameters" and rule[k + 1]),
        None,
    )
    out: dict[str, str] = {}
    if start is None:
        return out
    names: list[str] = []
    kind = ""
    text: list[str] = []

    def keep() -> None:
        line = re.sub(
            r":(?:\w+:)*\w+:`(~?)([^`<]+?)\s*(?:<[^>]*>)?`",
            lambda m: m.group(2).rsplit(".", 1)[-1] if m.group(1) else m.group(2),
            " ".join(text),
        ).replace("``", "")
        if not kind.startswith("{"):
            line = _first_sentence(line)
        for name in names:
            out.setdefault(name, line)

    for k in range(start, len(lines)):
        line = lines[k]
        if k + 1 < len(lines) and rule[k + 1]:
            break  # the next section's heading
        if line and not line[0].isspace():  # an entry: "name : type" or "a, b : type"
            keep()
            head, *rest = re.split(r"\s*:\s", line, maxsplit=1)
            kind = rest[0].strip() if rest else ""
            names = [n.strip() for n in head.split(",") if n.strip()]
            text = []
        elif line.strip():
            text.append(line.strip())
    keep()
    return out


def signature_parameters(
    cls: type, ranges: dict[str, tuple[float, float]] | None = None
) -> tuple[MethodParam, ...]:
    """A class's keyword parameters as :class:`MethodParam`: the types of its ``__init__``
    annotations, the defaults of its signature and ``ranges`` (name -> (low, high)), so each
    parameter has one default (the signature's) and one range (the class's table), and the
    first sentence of its entry in the class docstring (:func:`parameter_lines`).

    Examples
    --------
    >>> class Toy:
    ...     def __init__(self, *, size: int = 8, name: str = "toy") -> None: ...
    >>> [(p.name, p.hint, p.default, p.high) for p in signature_parameters(Toy, {"size": (1, 64)})]
    [('size', <class 'int'>, 8, 64), ('name', <class 'str'>, 'toy', None)]
    """
    import typing

    try:
        hints = typing.get_type_hints(cls.__init__)  # type: ignore[misc]
    except Exception:  # an annotation that does not resolve: leave the types to the class
        hints = {}
    # the class's Parameters section, else __init__'s (where a class documents them)
    docs = {**parameter_lines(inspect.getdoc(cls.__init__)), **parameter_lines(inspect.getdoc(cls))}
    out = []
    for key, p in inspect.signature(cls).parameters.items():
        if p.kind in (inspect.Parameter.VAR_KEYWORD, inspect.Parameter.VAR_POSITIONAL):
            continue
        default = None if p.default is inspect.Parameter.empty else p.default
        low, high = (ranges or {}).get(key, (None, None))
        out.append(MethodParam(key, hints.get(key, Any), default, low, high, docs.get(key, "")))
    return tuple(out)
