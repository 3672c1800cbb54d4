"""Observers of the simulator: the events of a scripted run, in order; several observers;
detaching; no sharing between simulators; the planes every event says it wrote."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import RegisterMisuseError, SimulatorError
from ppaloc.sim import (
    FLAG,
    IN,
    NEWS,
    OPS,
    PIX,
    R1,
    R2,
    R3,
    R4,
    R5,
    R6,
    R7,
    R12,
    SELECT,
    A,
    B,
    C,
    D,
    E,
    F,
    Kernel,
    Scamp5,
    east,
)
from ppaloc.sim.controller import ControllerMixin
from ppaloc.sim.isa import make
from ppaloc.sim.observe import (
    ControllerCall,
    ImageSet,
    KernelRun,
    Observation,
    PlaneWrite,
    icw_writes,
)
from ppaloc.sim.registers import ANALOG_PLANES, DIGITAL_PLANES, RECT, XE, XN, XS, XW

IMAGE = np.arange(64, dtype=np.uint8).reshape(8, 8) * 3


class Log:
    """An observer keeping (sim, event) pairs."""

    def __init__(self) -> None:
        self.seen: list[tuple[Scamp5, object]] = []

    def __call__(self, sim, event) -> None:
        self.seen.append((sim, event))

    @property
    def events(self) -> list:
        return [e for _, e in self.seen]


def script(sim: Scamp5) -> Kernel:
    """A small host program touching every kind of event."""
    sim.scamp5_in(A, 5)
    sim.set_image(IMAGE)
    sim.scamp5_get_image(C, D)  # one call, its 6-ICW macro kernel inside it
    with sim.kernel() as k:
        k.sub(B, C, A)
        k.where(B)
    sim.mov(E, B)  # direct instructions: a kernel of their own
    k.run()  # a replay: the same kernel again
    sim.scamp5_load_pattern(R5, 0, 1, 2, 2)  # the scamp5_ spelling
    sim.scan_events_cr(R5, 3)  # calls scan_events inside: reported once
    sim.global_or(R5)
    sim.write(F, 1.0)
    return k


def summary(event) -> tuple:
    """The fields of an event, in a form a golden list can spell out."""
    if isinstance(event, KernelRun):
        icws = [str(i) for i in event.instructions]
        return ("kernel", event.kernel, icws, event.writes)
    if isinstance(event, ControllerCall):
        result = event.result.tolist() if isinstance(event.result, np.ndarray) else event.result
        ops = [i.op for i in event.instructions]
        return ("call", event.name, dict(event.arguments), result, ops, event.writes)
    if isinstance(event, ImageSet):
        return ("image", event.image.tolist(), event.writes)
    assert isinstance(event, PlaneWrite)
    return ("write", event.register, event.values.tolist(), event.writes)


def test_an_observer_sees_the_operations_of_a_scripted_run_in_order():
    log = Log()
    sim = Scamp5(8, 8, observers=[log])
    k = script(sim)
    no_pattern = {"r": 0, "c": 0, "rx": 255, "cx": 255, "scamp_addr": False}
    assert [summary(e) for e in log.events] == [
        ("call", "scamp5_in", {"areg": A, "value": 5, "temp": NEWS}, None, [], (IN, NEWS, A)),
        ("image", IMAGE.tolist(), (PIX,)),
        (
            "call",
            "scamp5_get_image",
            {"yf": C, "yh": D, "gain": 1},
            None,
            ["bus", "bus", "rpix", "rpix", "nop", "bus"],  # the get_image(C, D) macro
            (NEWS, D, PIX, C),
        ),
        ("kernel", k, ["bus(NEWS, C)", "bus(B, NEWS, A)", "where(B)"], (NEWS, B, FLAG)),
        ("kernel", None, ["bus(NEWS, B)", "bus(E, NEWS)"], (NEWS, E)),
        ("kernel", k, ["bus(NEWS, C)", "bus(B, NEWS, A)", "where(B)"], (NEWS, B, FLAG)),
        (
            "call",
            "load_pattern",
            {"dreg": R5, "r": 0, "c": 1, "rx": 2, "cx": 2, "scamp_addr": False},
            None,
            [],
            (R5,),
        ),
        (
            "call",
            "scan_events_cr",
            {"dreg": R5, "max_num": 3, "h_dir": 0, "v_dir": 0, "scamp_addr": False},
            [[0, 3], [2, 3], [0, 1]],  # east column first
            [],
            (),
        ),
        ("call", "global_or", {"dreg": R5, **no_pattern}, 1, [], ()),
        ("write", F, np.ones((8, 8)).tolist(), (F,)),
    ]
    assert all(s is sim for s, _ in log.seen)
    assert str(log.events[0]) == "scamp5_in(areg=A, value=5, temp=NEWS)"
    assert str(log.events[7]).endswith("-> array(3, 2)")


def test_get_image_reports_its_macro_icws_as_recorded():
    log = Log()
    sim = Scamp5(8, 8, observers=[log])
    sim.set_image(IMAGE)
    sim.scamp5_get_image(C, D)
    with sim.kernel() as k:
        k.get_image(C, D)
    call, run = log.events[1:]
    assert call.instructions == run.instructions == k.instructions
    assert {i.origin for i in call.instructions} == {"get_image(C, D)"}


def test_a_call_keeps_its_arguments_as_passed_and_bound():
    log = Log()
    sim = Scamp5(8, 8, observers=[log])
    sim.load_pattern(R5, 0, 1, 2, 2)
    sim.global_or(R5, 0, cx=3)
    (call,) = log.events[1:]
    assert call.args == (R5, 0) and dict(call.kwargs) == {"cx": 3}
    assert dict(call.arguments) == {
        "dreg": R5, "r": 0, "c": 0, "rx": 255, "cx": 3, "scamp_addr": False,
    }  # fmt: skip
    assert call.function is ControllerMixin.global_or.__wrapped__
    assert call.arguments is call.arguments  # bound once


def test_events_hold_what_was_read_and_written_not_later_changes():
    log = Log()
    sim = Scamp5(8, 8, observers=[log])
    sim.load_pattern(R5, 0, 1, 2, 2)
    out = sim.scan_events(R5, 4)
    out[:] = 0  # the caller's array; the event keeps its own
    image = IMAGE.copy()
    sim.set_image(image)
    image[:] = 0
    sim.write(A, 7.0)
    sim.write(A, 9.0)
    _, events, frame, first, _ = log.events
    assert events.result.tolist() == [[0, 3], [2, 3], [0, 1], [2, 1]]
    assert frame.image.tolist() == IMAGE.tolist()
    assert (first.values == 7).all()
    for array in (events.result, frame.image, first.values):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 1


def test_two_observers_receive_every_event_in_the_order_attached():
    order: list[tuple[str, str]] = []
    first = Log()

    def second(sim, event):
        order.append(("second", type(event).__name__))

    def tagged(sim, event):
        first(sim, event)
        order.append(("first", type(event).__name__))

    sim = Scamp5(8, 8, observers=[tagged])
    sim.observe(second)
    script(sim)
    names = [type(e).__name__ for e in first.events]
    assert len(names) == 10
    assert order == [(who, n) for n in names for who in ("first", "second")]


def test_detaching_stops_the_events():
    log, other = Log(), Log()
    sim = Scamp5(8, 8)
    with sim.observe(log) as handle:
        assert isinstance(handle, Observation) and handle.active
        sim.scamp5_in(A, 1)
    assert not handle.active
    handle.close()  # closing again does nothing
    sim.scamp5_in(A, 2)
    sim.observe(other)
    sim.scamp5_in(A, 3)
    sim.unobserve(other)
    script(sim)
    assert [e.arguments["value"] for e in log.events] == [1]
    assert [e.arguments["value"] for e in other.events] == [3]
    assert sim.observers == ()


def test_an_observer_attached_at_construction_is_detached_by_unobserve():
    log = Log()
    sim = Scamp5(8, 8, observers=[log])
    assert sim.observers == (log,)
    sim.unobserve(log)
    script(sim)
    assert log.events == []


def test_no_observer_is_shared_between_simulators():
    log = Log()
    watched = Scamp5(8, 8, observers=[log])
    other = Scamp5(8, 8)
    script(other)
    third = Scamp5(8, 8)
    third.observe(Log())
    script(third)
    assert other.observers == () and watched.observers == (log,)
    assert log.events == []
    script(watched)
    assert {id(s) for s, _ in log.seen} == {id(watched)}


def test_an_observer_may_watch_several_simulators():
    log = Log()
    one, two = Scamp5(8, 8, observers=[log]), Scamp5(8, 8)
    two.observe(log)
    one.scamp5_in(A, 1)
    two.scamp5_in(A, 2)
    assert [(s, e.arguments["value"]) for s, e in log.seen] == [(one, 1), (two, 2)]


def test_a_call_that_raises_is_not_reported():
    log = Log()
    sim = Scamp5(8, 8, observers=[log])
    with pytest.raises(SimulatorError):
        sim.scamp5_in(A, 500)
    with pytest.raises(RegisterMisuseError):
        sim.load_pattern(A, 0, 0, 0, 0)
    sim.scamp5_in(A, 5)  # a frame left over from the failed call would swallow this one
    assert [e.name for e in log.events] == ["scamp5_in"]


def test_an_observer_error_reaches_the_caller_after_the_operation():
    def fail(sim, event):
        raise RuntimeError("observer failed")

    sim = Scamp5(8, 8, observers=[fail])
    with pytest.raises(RuntimeError, match="observer failed"):
        sim.scamp5_in(A, 5)
    assert (sim.read(A) == 5).all()
    sim.unobserve(fail)
    sim.scamp5_in(A, 6)  # the simulator goes on
    assert (sim.read(A) == 6).all()


def test_bad_observers_are_refused_with_the_fix():
    log = Log()
    sim = Scamp5(8, 8)
    with pytest.raises(SimulatorError) as err:
        sim.observe(3)
    assert str(err.value) == (
        "observer 3 is not callable: an observer is called as observer(sim, event)"
    )
    with pytest.raises(SimulatorError) as err:
        Scamp5(8, 8, observers=log)
    assert str(err.value).endswith("wrap a single observer in a list")
    with pytest.raises(SimulatorError, match="is listed twice; list each observer once"):
        Scamp5(8, 8, observers=[log, log])
    sim.observe(log)
    with pytest.raises(SimulatorError, match="already attached to this simulator; detach it"):
        sim.observe(log)
    with pytest.raises(SimulatorError, match="is not attached to this simulator"):
        Scamp5(8, 8).unobserve(log)


# ------------------------------------------------------------------ writes
def _planes(sim: Scamp5) -> dict:
    out = {r: sim.read(r) for r in (*ANALOG_PLANES, *DIGITAL_PLANES)}
    out[RECT] = sim._dplane(RECT).copy()
    return out


def _changed(before: dict, after: dict) -> set:
    return {r for r in before if not np.array_equal(before[r], after[r])}


def _randomise(sim: Scamp5, rng: np.random.Generator) -> None:
    for r in ANALOG_PLANES:
        if r is not PIX:
            sim.write(r, rng.integers(-128, 128, (sim.rows, sim.cols)) / 2)
    for r in DIGITAL_PLANES:
        sim.write(r, rng.random((sim.rows, sim.cols)) < 0.5)
    sim.write(FLAG, rng.random((sim.rows, sim.cols)) < 0.7)
    sim.set_image(rng.integers(0, 256, (sim.rows, sim.cols), dtype=np.uint8))


ANALOG = [A, B, C, D, E, F, NEWS, XN, XE, XS, XW]
DIGITAL = [R1, R2, R3, R4, R5, R6, R7]
POOLS = {"analog": (ANALOG, [*ANALOG, PIX, IN]), "digital": (DIGITAL, [*DIGITAL, FLAG, SELECT])}


def _random_icw(op: str, rng: np.random.Generator):
    spec = OPS[op]
    while True:
        regs = []
        for kind, (lo, hi), role in (
            (spec.dst_kind, spec.n_dst, 0),
            (spec.src_kind, spec.n_src, 1),
        ):
            pool = POOLS[kind][role] if kind else []
            n = int(rng.integers(lo, hi + 1)) if kind else 0
            regs.append(tuple(pool[i] for i in rng.choice(len(pool), n, replace=False)))
        try:
            return make(op, regs[0], regs[1])
        except RegisterMisuseError:
            continue


@pytest.mark.parametrize("op", sorted(OPS))
def test_every_plane_an_icw_changes_is_in_its_writes(op):
    rng = np.random.default_rng(sorted(OPS).index(op))
    log = Log()
    sim = Scamp5(4, 5, observers=[log])
    for _ in range(6):
        ins = _random_icw(op, rng)
        _randomise(sim, rng)
        before = _planes(sim)
        sim.icw(ins.op, ins.dsts, ins.srcs)
        event = log.events[-1]
        assert isinstance(event, KernelRun) and event.kernel is None
        assert _changed(before, _planes(sim)) <= set(event.writes), str(ins)


def test_icw_writes_names_the_plane_behind_an_alias_and_the_implicit_ones():
    icws = [make("bus", (XE,), (A,)), make("where", (), (B,)), make("rpix"), make("all")]
    assert icw_writes(icws) == (NEWS, FLAG, PIX)
    assert icw_writes([make("PROP0", (R5,))]) == (R12,)  # PROP floods R12, as the engine


# One call of every controller call (its canonical name first), on an 8 x 8 array.
CALLS = [
    ("scamp5_in", (A, 5)),
    ("scamp5_get_image", (C, D)),
    ("load_in", (A, 7)),
    ("load_pattern", (R5, 0, 1, 2, 2)),
    ("load_point", (R5, 2, 3)),
    ("load_rect", (R5, 1, 1, 3, 5)),
    ("select_pattern", (0, 1, 2, 2)),
    ("select_point", (2, 3)),
    ("select_rect", (1, 1, 3, 5)),
    ("shift", (A, 1, -2)),
    ("shift", (R5, -1, 1, 1)),
    ("global_sum_16", (A,)),
    ("global_sum_64", (A,)),
    ("global_or", (R5,)),
    ("global_count", (R5, B)),
    ("read_areg", (A, 1, 2)),
    ("scan_areg", (A, 0, 0, 7, 7, 2, 2)),
    ("scan_areg_8x8", (A,)),
    ("scan_areg_mean_8x8", (A,)),
    ("scan_dreg", (R5, 1, 3)),
    ("scan_events", (R5, 5)),
    ("load_dac", (B, 3000)),
    ("diffuse", (A, 2)),
    ("flood", (R5, R6, 0)),
    ("kernel_all", ()),
    ("kernel_refresh_dreg", ()),
    ("select_col", (3,)),
    ("select_row", (2,)),
    ("select_colx", (1,)),
    ("select_rowx", (1,)),
    ("global_sum_fast", (A,)),
    ("global_sum_sparse", (A,)),
    ("global_sum_region", (A, 0, 0, 3, 3)),
    ("scan_events_cr", (R5, 2)),
    ("scan_events_rc", (R5, 2)),
    ("scan_boundingbox", (R5,)),
    ("vs_scamp5_get_parameter", (5,)),
    ("draw_begin", (R7,)),
    ("draw_pixel", (9, 2)),
    ("draw_point", (1, 1)),
    ("draw_rect", (2, 2, 3, 4)),
    ("draw_line", (0, 0, 7, 5)),
    ("draw_circle", (4, 4, 2)),
    ("draw_negate", ()),
    ("draw_end", ()),
]


#: Public methods of the controller that are not calls: a context manager, an inspection.
NOT_CALLS = {"stage", "address_mask"}


def test_every_controller_call_is_observed():
    names = {n for n in dir(ControllerMixin) if not n.startswith("_") and n not in NOT_CALLS}
    names = {n for n in names if callable(getattr(ControllerMixin, n))}
    unmarked = {n for n in names if not hasattr(getattr(ControllerMixin, n), "controller_call")}
    assert unmarked == set()
    canonical = {getattr(ControllerMixin, n).controller_call for n in names}
    assert canonical == {name for name, _ in CALLS}


@pytest.mark.parametrize("seed", range(3))
def test_every_plane_a_call_changes_is_in_its_writes(seed):
    rng = np.random.default_rng(seed)
    log = Log()
    sim = Scamp5(8, 8, observers=[log])
    _randomise(sim, rng)
    for name, args in CALLS:
        before = _planes(sim)
        getattr(sim, name)(*args)
        event = log.events[-1]
        assert isinstance(event, ControllerCall) and event.name == name
        changed = _changed(before, _planes(sim))
        assert changed <= set(event.writes), f"{name}: {changed - set(event.writes)}"
    sim.set_image(IMAGE)
    # the writes these calls must name, whatever the planes held
    expected = {
        "scamp5_in": (IN, NEWS, A),
        "select_rect": (RECT, SELECT),
        "select_col": (SELECT,),
        "global_count": (B,),
        "shift": (A,),
    }
    for name, writes in expected.items():
        getattr(sim, name)(*next(args for n, args in CALLS if n == name))
        assert log.events[-1].writes == writes, name


def test_shift_of_a_dreg_names_the_selectors_it_leaves():
    log = Log()
    sim = Scamp5(8, 8, observers=[log])
    sim.shift(R5, 0, 2)
    assert log.events[-1].writes == (R1, R2, R3, R4, R5)
    sim.movx(A, B, east)
    assert log.events[-1].writes == (NEWS, A)
