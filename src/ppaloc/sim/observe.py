"""Observers of a simulator: every kernel run, controller call and host write, in order.

A :class:`~ppaloc.sim.Scamp5` reports what its host program does to the observers
attached to it (``sim.observe(observer)``, or ``Scamp5(..., observers=[observer])``): one
event per operation of its host API, delivered after the operation completed, to every
observer in the order they were attached. An observer is any callable
``observer(sim, event)`` (:class:`SimObserver`); events are immutable records:

======================  ==================================================================
:class:`KernelRun`      a recorded kernel ran (its first run at the end of its ``with``
                        block, and every replay), or instructions issued on the simulator
                        itself ran as a kernel of their own (``kernel`` is None): the ICWs
                        as recorded
:class:`ControllerCall` a controller call returned (``scamp5_*``, ``load_pattern``,
                        ``shift``, ``draw_*``, ...): its name, arguments, result (the
                        readout, a copy), the ICWs it ran as kernels of its own, the planes
                        it wrote
:class:`ImageSet`       ``set_image`` gave ``PIX`` a new scene (a frame boundary)
:class:`PlaneWrite`     ``sim.write`` (an inspection tool) set a plane
======================  ==================================================================

An operation made inside another (a call that another call makes, the macro kernel of
``scamp5_get_image``) is part of the outer event, never reported on its own, so the events
of a run are the operations its host program made, each once, in the order it made them.
Every event says which planes it wrote (``event.writes``); the droop and decay the noise
model applies as modelled time passes are not writes. A call that raises is not reported
(calls check their arguments before they change anything).

With no observer attached the simulator does no more than test that its tuple of
observers is empty, once per kernel run and host call (docs/sim-controller.md,
"Observers", gives the measured cost). An observer's exception propagates to the caller
of the operation, which has then completed; later observers do not receive that event.

Examples
--------
>>> from collections import Counter
>>> from ppaloc.sim import Scamp5, A, B
>>> icws = Counter()
>>> def count(sim, event):
...     if isinstance(event, KernelRun):
...         icws[id(event.kernel)] += len(event.instructions)
>>> sim = Scamp5(8, 8)
>>> with sim.observe(count):
...     with sim.kernel() as k:
...         k.add(A, A, B)
...     k.run()
>>> k.run()  # detached: not counted
>>> icws[id(k)]
4
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Protocol, TypeVar

import numpy as np

from ppaloc.errors import SimulatorError
from ppaloc.sim.isa import Instruction
from ppaloc.sim.registers import FLAG, NEWS, PIX, R12, Register

if TYPE_CHECKING:
    from ppaloc.sim.engine import Scamp5
    from ppaloc.sim.kernel import Kernel

__all__ = [
    "ControllerCall",
    "ImageSet",
    "KernelRun",
    "ObservableMixin",
    "Observation",
    "PlaneWrite",
    "SimEvent",
    "SimObserver",
    "check_observers",
    "controller_call",
    "icw_writes",
]

#: Planes an ICW writes other than its destinations, by operation: ``where``, ``WHERE``
#: and ``all`` write FLAG, ``rpix`` resets PIX, and ``PROP0``/``PROP1`` flood R12 whatever
#: destination they name (:func:`ppaloc.sim.semantics.build_prop`). tests/sim/test_observe.py
#: checks this against the engine for every row of the op table.
_IMPLICIT_WRITES: dict[str, tuple[Register, ...]] = {
    "where": (FLAG,),
    "WHERE": (FLAG,),
    "all": (FLAG,),
    "rpix": (PIX,),
    "PROP0": (R12,),
    "PROP1": (R12,),
}
#: Operations whose named destination is not what they write.
_DSTS_NOT_WRITTEN = frozenset({"PROP0", "PROP1"})


def icw_writes(instructions: Iterable[Instruction]) -> tuple[Register, ...]:
    """The register planes ``instructions`` write, in order of first write.

    A neighbour alias (``XE`` as a destination) writes ``NEWS``; ``where``, ``WHERE`` and
    ``all`` write ``FLAG``; ``rpix`` writes ``PIX``; ``PROP0``/``PROP1`` write ``R12``.
    The bus latch is not a plane.

    Examples
    --------
    >>> from ppaloc.sim.isa import make
    >>> from ppaloc.sim import A, B, XE
    >>> icw_writes([make("bus", (XE,), (A,)), make("where", (), (B,)), make("bus", (A,), (B,))])
    (NEWS, FLAG, A)
    """
    out: dict[Register, None] = {}
    for ins in instructions:
        if ins.op not in _DSTS_NOT_WRITTEN:
            for d in ins.dsts:
                out[NEWS if d.role == "neighbour" else d] = None
        for d in _IMPLICIT_WRITES.get(ins.op, ()):
            out[d] = None
    return tuple(out)


# ------------------------------------------------------------------ events
@dataclass(frozen=True, slots=True)
class KernelRun:
    """A kernel ran.

    Attributes
    ----------
    kernel : Kernel or None
        The recorded kernel (the same object at every replay: its identity), or None for
        instructions issued on the simulator directly (``sim.mov(A, B)``), which run as a
        kernel of their own.
    instructions : tuple of Instruction
        Its ICWs as recorded (with the macro call each came from, ``Instruction.origin``).
    """

    kernel: Kernel | None
    instructions: tuple[Instruction, ...]

    @property
    def writes(self) -> tuple[Register, ...]:
        """The planes the ICWs write (:func:`icw_writes`)."""
        return icw_writes(self.instructions)

    def __str__(self) -> str:
        what = "kernel" if self.kernel is not None else "direct"
        return f"{what} of {len(self.instructions)} ICWs"


@dataclass(frozen=True, slots=True)
class ControllerCall:
    """A controller call returned.

    Attributes
    ----------
    name : str
        The call's name in ``ppaloc.sim`` (``"load_pattern"``, ``"scamp5_in"``,
        ``"scamp5_get_image"``; ``scamp5_load_pattern`` is reported as ``load_pattern``,
        ``in_`` as ``scamp5_in``).
    function : callable
        The controller method that ran (unbound, e.g. ``ControllerMixin.load_pattern``
        as written, without its observer wrapper): what :attr:`arguments` binds to.
    args, kwargs : tuple, Mapping[str, Any]
        The arguments as passed (an ``out=`` array is the caller's, as the call left it).
    result : Any
        What the call returned: None, an int, or a readout array (a read-only copy, so
        it stays what the call read).
    instructions : tuple of Instruction
        ICWs the call ran as kernels of its own (``scamp5_get_image``, ``diffuse``,
        ``flood``, ``kernel_all``, ``draw_negate``, ...); empty for the others.
    writes : tuple of Register
        The planes the call wrote, in order of first write (``IN`` for every DAC load,
        the ``temp`` of ``scamp5_in``, ``SELECT`` for the ``select_*`` calls, ...).
    """

    name: str
    function: Callable[..., Any] = field(repr=False)
    args: tuple[Any, ...] = ()
    kwargs: Mapping[str, Any] = field(default_factory=dict)
    result: Any = None
    instructions: tuple[Instruction, ...] = ()
    writes: tuple[Register, ...] = ()
    _arguments: Mapping[str, Any] | None = field(
        default=None, init=False, repr=False, compare=False
    )

    @property
    def arguments(self) -> Mapping[str, Any]:
        """Every parameter of the call by name, defaults filled in (bound on first use,
        so observers that do not look pay nothing for it)."""
        if self._arguments is None:
            bound = _signature(self.function).bind(None, *self.args, **self.kwargs)
            bound.apply_defaults()
            arguments = dict(bound.arguments)
            del arguments[next(iter(arguments))]  # the method's self
            object.__setattr__(self, "_arguments", MappingProxyType(arguments))
        return self._arguments  # type: ignore[return-value]

    def __str__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.arguments.items())
        shown = "" if self.result is None else f" -> {_short(self.result)}"
        return f"{self.name}({args}){shown}"


@dataclass(frozen=True, slots=True)
class ImageSet:
    """``set_image`` gave ``PIX`` a new scene: ``image``, uint8 (rows, cols), read-only."""

    image: np.ndarray
    writes: tuple[Register, ...] = (PIX,)

    def __str__(self) -> str:
        return f"set_image({self.image.shape[0]}x{self.image.shape[1]})"


@dataclass(frozen=True, slots=True)
class PlaneWrite:
    """``sim.write`` set ``register``'s plane to ``values`` (as stored: float32 clipped
    to [-128, 127] or bool, shape (rows, cols), read-only)."""

    register: Register
    values: np.ndarray = field(repr=False)

    @property
    def writes(self) -> tuple[Register, ...]:
        """``(register,)``."""
        return (self.register,)

    def __str__(self) -> str:
        return f"write({self.register.name})"


#: What an observer receives.
SimEvent = KernelRun | ControllerCall | ImageSet | PlaneWrite


class SimObserver(Protocol):
    """Anything called as ``observer(sim, event)`` for each event of the simulators it
    observes (a function, or an object with ``__call__``)."""

    def __call__(self, sim: Scamp5, event: SimEvent, /) -> None: ...


def _short(value: Any) -> str:
    if isinstance(value, np.ndarray):
        return f"array{value.shape}"
    return repr(value)


def _frozen(value: Any) -> Any:
    """A readout as returned, arrays copied and made read-only."""
    if isinstance(value, np.ndarray):
        value = value.copy()
        value.flags.writeable = False
    return value


def check_observers(observers: Iterable[SimObserver]) -> tuple[SimObserver, ...]:
    """``observers`` as a tuple, each checked to be callable and listed once.

    Raises
    ------
    SimulatorError
        If ``observers`` is not an iterable of callables, or lists one twice.
    """
    if callable(observers) or not isinstance(observers, Iterable):
        raise SimulatorError(
            f"observers={observers!r} must be a list of callables observer(sim, event); "
            "wrap a single observer in a list"
        )
    out = tuple(observers)
    for obs in out:
        if not callable(obs):
            raise SimulatorError(
                f"observer {obs!r} is not callable: an observer is called as observer(sim, event)"
            )
    for i, obs in enumerate(out):
        if any(obs is other for other in out[:i]):
            raise SimulatorError(f"observer {obs!r} is listed twice; list each observer once")
    return out


# ------------------------------------------------------------------ attaching
class Observation:
    """An observer attached to one simulator (from :meth:`ObservableMixin.observe`).

    ``close()`` detaches it (closing again does nothing); as a context manager it
    detaches it at the end of the ``with`` block.
    """

    def __init__(self, sim: ObservableMixin, observer: SimObserver) -> None:
        self.sim = sim
        self.observer = observer

    @property
    def active(self) -> bool:
        """Whether the observer is still attached."""
        return any(o is self.observer for o in self.sim.observers)

    def close(self) -> None:
        """Detach the observer; it receives no event after this."""
        if self.active:
            self.sim.unobserve(self.observer)

    def __enter__(self) -> Observation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "active" if self.active else "closed"
        return f"Observation({self.observer!r} on {self.sim!r}, {state})"


class _CallFrame:
    """What a host call does while observers watch it (ICWs it runs, planes it writes)."""

    __slots__ = ("instructions", "writes")

    def __init__(self) -> None:
        self.instructions: list[Instruction] = []
        self.writes: list[Register] = []


class ObservableMixin:
    """Observer bookkeeping of :class:`~ppaloc.sim.Scamp5` (this module's docstring).

    The engine calls :meth:`_observed_icws` after every kernel run, :meth:`_notify` after
    ``set_image`` and ``write`` and :meth:`_note_write` where a host call writes a
    plane; controller calls are wrapped by :func:`controller_call`. Each does nothing but a test
    while no observer is attached.
    """

    _observers: tuple[SimObserver, ...]
    _call_frame: _CallFrame | None

    def _init_observers(self, observers: Iterable[SimObserver]) -> None:
        """This simulator's own observers (checked), and no call under way."""
        self._observers = check_observers(observers)
        self._call_frame = None

    @property
    def observers(self) -> tuple[SimObserver, ...]:
        """The attached observers, in the order they receive each event."""
        return self._observers

    def observe(self, observer: SimObserver) -> Observation:
        """Attach ``observer``: from now on it is called as ``observer(sim, event)`` after
        every operation of this simulator (``ppaloc.sim.observe``).

        Returns
        -------
        Observation
            ``close()`` it, or use it as a context manager, to detach the observer.

        Raises
        ------
        SimulatorError
            If ``observer`` is not callable or is already attached to this simulator.
        """
        (obs,) = check_observers([observer])
        if any(o is obs for o in self._observers):
            raise SimulatorError(
                f"observer {obs!r} is already attached to this simulator; detach it first "
                "(close its Observation or sim.unobserve(observer))"
            )
        self._observers = (*self._observers, obs)
        return Observation(self, obs)

    def unobserve(self, observer: SimObserver) -> None:
        """Detach ``observer`` (attached by :meth:`observe` or ``Scamp5(observers=...)``).

        Raises
        ------
        SimulatorError
            If ``observer`` is not attached to this simulator.
        """
        kept = tuple(o for o in self._observers if o is not observer)
        if len(kept) == len(self._observers):
            raise SimulatorError(f"observer {observer!r} is not attached to this simulator")
        self._observers = kept

    def _notify(self, event: SimEvent) -> None:
        for obs in self._observers:
            obs(self, event)  # type: ignore[arg-type]

    def _observed_icws(self, kernel: Kernel | None, instructions: tuple[Instruction, ...]) -> None:
        """A kernel (or direct instructions) ran while observed: part of the host call
        that ran it, else an event of its own."""
        frame = self._call_frame
        if frame is not None:
            frame.instructions.extend(instructions)
            frame.writes.extend(icw_writes(instructions))
        else:
            self._notify(KernelRun(kernel, tuple(instructions)))

    def _note_write(self, reg: Register) -> None:
        """A host call wrote ``reg``'s plane. Called as ``if self._call_frame is not None:
        self._note_write(reg)``: only while an observed call runs."""
        self._call_frame.writes.append(reg)  # type: ignore[union-attr]

    def _observe_call(
        self, name: str, fn: Callable[..., Any], args: tuple, kwargs: dict[str, Any]
    ) -> Any:
        """Run the host call ``fn`` and report it as one :class:`ControllerCall`."""
        frame = self._call_frame = _CallFrame()
        try:
            result = fn(self, *args, **kwargs)
        finally:
            self._call_frame = None
        event = ControllerCall(
            name,
            fn,
            args,
            MappingProxyType(kwargs),
            _frozen(result),
            tuple(frame.instructions),
            tuple(dict.fromkeys(frame.writes)),
        )
        self._notify(event)
        return result


@functools.cache
def _signature(fn: Callable[..., Any]) -> inspect.Signature:
    return inspect.signature(fn)


F = TypeVar("F", bound=Callable[..., Any])


def yes_no_argument(call: str, name: str, value: Any) -> bool:
    """A controller call's yes/no argument (``scamp_addr``) as a bool: True, False, or 1
    and 0 as a C++ caller passes them; anything else is named in one line (a list was an
    internal TypeError where the address patterns are cached)."""
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer) and value in (0, 1):
        return bool(value)
    raise SimulatorError(f"{call}: {name}={value!r:.40} must be True or False")


def controller_call(fn: F) -> F:
    """Mark a controller call: observers receive each top-level call as one
    :class:`ControllerCall` named ``fn.__name__``.

    With no observer attached (or inside another call) the wrapper calls ``fn`` at once.
    """
    name = fn.__name__

    @functools.wraps(fn)
    def call(self, *args, **kwargs):
        if kwargs and "scamp_addr" in kwargs:
            kwargs["scamp_addr"] = yes_no_argument(name, "scamp_addr", kwargs["scamp_addr"])
        if not self._observers or self._call_frame is not None:
            return fn(self, *args, **kwargs)
        return self._observe_call(name, fn, args, kwargs)

    call.controller_call = name  # type: ignore[attr-defined]
    return call  # type: ignore[return-value]
