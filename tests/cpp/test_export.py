"""Export: a recorded kernel and the traced on-sensor pipeline as SCAMP-5d C++, round trip."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.cpp import Tracer, kernel_to_cpp, run_program, to_cpp
from ppaloc.errors import PpalocError, SimulatorError
from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.sim import (
    IN,
    NEWS,
    R0,
    R5,
    R6,
    R7,
    A,
    B,
    C,
    D,
    Kernel,
    Scamp5,
    alldir,
    east,
    north,
)
from ppaloc.sim.observe import KernelRun
from ppaloc.sim.registers import ANALOG_PLANES, DIGITAL_PLANES
from ppaloc.topomap import TopoMap

SIZE = 64


def planes(sim: Scamp5) -> dict[str, np.ndarray]:
    return {r.name: sim.read(r) for r in (*ANALOG_PLANES, *DIGITAL_PLANES)}


def test_kernel_to_cpp_regroups_the_macros():
    sim = Scamp5(8, 8)
    with sim.kernel() as k:
        k.get_image(C, D)
        k.movx(A, C, east)
        k.sub(B, C, A)
        k.abs(D, B)
        k.where(D, IN)
        k.MOV(R5, R6)
        k.all()
        k.DNEWS(R6, R5, north | east)
        k.DNEWS(R7, R5, alldir, 1)
        k.add(A, A, B)
        k.add(A, A, B)  # the same call twice stays two calls
        k.bus(C)
    text = kernel_to_cpp(k, "edges")
    body = [ln.strip() for ln in text.splitlines()[3:-2]]
    assert body == [
        "get_image(C, D);",
        "movx(A, C, east);",
        "sub(B, C, A);",
        "abs(D, B);",
        "where(D, IN);",
        "MOV(R5, R6);",
        "all();",
        "DNEWS(R6, R5, east|north, 0);",
        "DNEWS(R7, R5, east|west|north|south, 1);",
        "add(A, A, B);",
        "add(A, A, B);",
        "bus(C);",
    ]
    assert text.startswith(f"// {len(k)} ICWs")


def test_xor_is_exported_as_the_device_calls_it_expands_to():
    sim = Scamp5(8, 8)
    with sim.kernel() as k:
        k.XOR(R5, R6, R7)
    body = [ln.strip() for ln in kernel_to_cpp(k, "xor").splitlines()[3:-2]]
    assert body == ["AND(R5, R6, R7);", "NOR(R0, R6, R7);", "NOR(R5, R0);"]
    assert _replay(body) == [(i.op, i.dsts, i.srcs) for i in k]
    rng = np.random.default_rng(2)  # the device calls compute XOR
    x, y = rng.random((2, 8, 8)) < 0.5
    sim.write(R6, x)
    sim.write(R7, y)
    with sim.kernel() as k2:
        k2.AND(R5, R6, R7)
        k2.NOR(R0, R6, R7)
        k2.NOR(R5, R0)
    np.testing.assert_array_equal(sim.read(R5), x ^ y)


def test_icws_without_a_device_function_become_raw_words(cxx, tmp_path):
    sim = Scamp5(8, 8)
    with sim.kernel() as k:
        k.mov(B, A)
        k.sq(B)  # a primitive with no macro call of its own
        k.bus(C, NEWS)
    text = kernel_to_cpp(k, "squares")
    assert "icw(SCAMP5_CLOCK_ANALOG, {selsq" in text
    program = tmp_path / "squares.cpp"
    program.write_text(
        "#include <scamp5.hpp>\nusing namespace SCAMP5_PE;\n"
        + text
        + "\nint main() { vs_init(); vs_frame_loop_control(); squares(); }\n"
    )
    frame = np.random.default_rng(1).integers(0, 256, (8, 8), dtype=np.uint8)
    got = run_program(program, [frame]).session.sim
    want = Scamp5(8, 8)
    want.set_image(frame)
    with want.kernel() as k2:
        for ins in k:
            k2.icw(ins.op, ins.dsts, ins.srcs)
    for name, plane in planes(want).items():
        np.testing.assert_array_equal(planes(got)[name], plane, err_msg=name)


def test_a_trace_with_an_inspection_write_is_refused():
    tracer = Tracer()
    sim = Scamp5(8, 8, observers=[tracer])
    sim.scamp5_in(A, 5)
    sim.write(B, 1.0)
    with pytest.raises(PpalocError) as err:
        to_cpp(tracer.trace_of(sim))
    assert str(err.value) == (
        "the traced run set B with sim.write, an inspection tool with no device call: set "
        "registers through kernels and controller calls in a program to export"
    )


def test_a_simulator_the_tracer_never_saw_is_named():
    tracer = Tracer()
    Scamp5(8, 8, observers=[tracer]).scamp5_in(A, 5)
    with pytest.raises(PpalocError, match=r"^this simulator did nothing while the tracer"):
        tracer.trace_of(Scamp5(8, 8))


@pytest.fixture(scope="module")
def route():
    rng = np.random.default_rng(3)
    places = [rng.integers(0, 256, (SIZE, SIZE), dtype=np.uint8) for _ in range(4)]
    query = []
    for i in (0, 0, 1, 2, 3):
        noise = rng.integers(-6, 7, (SIZE, SIZE))
        query.append(np.clip(places[i].astype(int) + noise, 0, 255).astype(np.uint8))
    return places, query


@pytest.mark.parametrize(
    ("rep", "preset"),
    [("lowres", "robust"), ("lbp", "robust"), ("lbp", "paper"), ("lbp", "robust, every frame")],
)
def test_pipeline_round_trip(cxx, route, tmp_path, rep, preset):
    places, query = route
    preset, _, every = preset.partition(", ")
    kw = {"preset": preset}
    if every:  # a map of every frame whose first place stands three frames: a run
        kw["keyframes"] = False
        places = [places[0]] * 3 + places[1:]
    mapper = OnSensorLocaliser(rep, size=SIZE, **kw)
    topomap = mapper.build_map(places)
    assert topomap.has_runs == bool(every)
    tracer = Tracer()
    loc = OnSensorLocaliser(rep, size=SIZE, observers=[tracer], **kw)
    loc.use_map(topomap)
    estimates = [loc.step(f) for f in query]
    sim = loc.pipeline.sim
    # the one sensor holding the map, and the robust preset's speed lanes (a sensor each)
    lanes = [lane.sim for lane in loc.schedule.lanes]
    assert len(lanes) == (3 if preset == "robust" else 0)
    assert [t.sim for t in tracer.traces] == [sim, *lanes]
    trace = tracer.trace_of(sim)
    assert trace.frames == len(query)
    source = to_cpp(
        trace, estimates=[(e.node, e.score) for e in estimates], title=f"on-sensor {rep}"
    )
    assert not re.search(r"\bXOR\s*\(", source)  # the device library has no XOR
    path = tmp_path / f"pipeline_{rep}_{preset}{'_runs' if every else ''}.cpp"
    path.write_text(source)
    result = run_program(path, query, timeout=120)
    texts = result.texts
    assert not [t for t in texts if t.startswith("diverged")]
    want = [f"estimate {k}: node {e.node} score {e.score:g}" for k, e in enumerate(estimates)]
    assert [t for t in texts if t.startswith("estimate")] == want
    got, ref = planes(result.session.sim), planes(sim)
    for name in ref:
        np.testing.assert_array_equal(got[name], ref[name], err_msg=name)
    # modelled time: the chip's work is the Python pipeline's; the C++ run adds its loop
    timing = result.session.sim.timing
    loop = timing.report().stage("loop").us
    chip = timing.now_us - loop
    assert chip == pytest.approx(sim.timing.now_us)
    posts = sum(timing.call_us("usb_output", len(t)) for t in texts)
    assert loop == pytest.approx(timing.call_us("vs_frame_loop_control") * (len(query) + 1) + posts)


def test_a_kernel_its_program_moved_to_the_heap_is_written_so():
    sim = Scamp5(8, 8)
    with sim.kernel() as k:
        k.move_to_heap(True)
        k.add(A, A, B)
    assert "move_to_heap(true);" in to_cpp(k)
    # in a trace written without the heap for every kernel, the robust preset's start-up
    # calibration chain (moved there by its program) still starts with it
    tracer = Tracer()
    loc = OnSensorLocaliser("lbp", size=SIZE, observers=[tracer])
    rng = np.random.default_rng(1)
    loc.use_map(TopoMap("lbp", rng.integers(0, 2**32, 4, dtype=np.uint32)))
    loc.step(rng.integers(0, 256, (SIZE, SIZE), dtype=np.uint8))
    text = to_cpp(tracer.traces[0], heap=False)
    assert text.count("move_to_heap(true);") == 1


def test_a_tracer_reaches_every_sensor_of_a_bank():
    rng = np.random.default_rng(5)
    tracer = Tracer()
    loc = OnSensorLocaliser("lbp", size=SIZE, sensor_nodes=3, observers=[tracer])
    loc.use_map(TopoMap("lbp", rng.integers(0, 2**32, 6, dtype=np.uint32)))
    loc.step(rng.integers(0, 256, (SIZE, SIZE), dtype=np.uint8))
    sensors = [s.sim for s in loc.pipeline.sensors]
    # the speed lanes' banks, fastest first
    lanes = [s.sim for lane in loc.schedule.lanes for s in lane.sensors]
    assert len(sensors) == 2 and len(lanes) == 6
    assert [t.sim for t in tracer.traces] == sensors + lanes
    assert [t.frames for t in tracer.traces] == [1] * 8


def test_a_localiser_checks_its_observers_before_any_work():
    with pytest.raises(SimulatorError) as err:
        OnSensorLocaliser("lbp", size=SIZE, observers=Tracer())
    assert str(err.value).endswith("wrap a single observer in a list")
    with pytest.raises(SimulatorError, match=r"^observer 'x' is not callable"):
        OnSensorLocaliser("lbp", size=SIZE, observers=["x"])


def _shadowed(obj: object) -> set[str]:
    """Instance attributes that hide a method of the object's class (a patched method)."""
    return {n for n in vars(obj) if callable(getattr(type(obj), n, None))}


def test_tracing_replaces_nothing_in_the_simulator(route):
    """The export observes the run: no class attribute and no method of any simulator or
    kernel is replaced while it traces or writes the program."""
    places, query = route
    classes = [c for c in (*Scamp5.__mro__, *Kernel.__mro__) if c is not object]
    before = {c: dict(vars(c)) for c in classes}
    init = Scamp5.__init__
    checked = []

    def unpatched(sim, event):
        assert Scamp5.__init__ is init
        assert not _shadowed(sim)
        if isinstance(event, KernelRun) and event.kernel is not None:
            assert not _shadowed(event.kernel)
        checked.append(event)

    tracer = Tracer()
    loc = OnSensorLocaliser("lbp", size=SIZE, observers=[tracer, unpatched])
    loc.use_map(OnSensorLocaliser("lbp", size=SIZE).build_map(places))
    loc.step(query[0])
    assert "void ppaloc_frame_0()" in to_cpp(tracer.trace_of(loc.pipeline.sim))
    assert len(checked) == sum(len(t.events) for t in tracer.traces) > 100
    for c in classes:
        assert vars(c) == before[c], c.__name__
    assert not _shadowed(loc.pipeline.sim)


# ------------------------------------------------------------------ invariant: exact ICWs
_AREGS = (A, B, C, D)
_DREGS = (R5, R6, R7)
_MACROS = {
    "mov": (_AREGS, _AREGS),
    "add": (_AREGS, _AREGS, _AREGS),
    "sub": (_AREGS, _AREGS, _AREGS),
    "neg": (_AREGS, _AREGS),
    "abs": (_AREGS, _AREGS),
    "movx": (_AREGS, _AREGS, (east, north)),
    "divq": (_AREGS, _AREGS),
    "where": (_AREGS,),
    "all": (),
    "OR": (_DREGS, _DREGS, _DREGS),
    "NOT": (_DREGS, _DREGS),
    "AND": (_DREGS, _DREGS, _DREGS),
    "XOR": (_DREGS, _DREGS, _DREGS),
    "DNEWS": (_DREGS, _DREGS, (north, east | north, alldir), (0, 1)),
    "bus": (_AREGS, _AREGS),
    "CLR": (_DREGS,),
}


def _replay(statements: list[str]):
    """The ICWs the exported statements issue, read back with the export's own parser."""
    from ppaloc.cpp.export import _parse_arg, _Recorder

    rec = _Recorder()
    for stmt in statements:
        name, body = stmt.rstrip(";").split("(", 1)
        body = body[:-1]
        args = [_parse_arg(t) for t in body.split(",")] if body.strip() else []
        getattr(rec, name)(*args)
    return [(i.op, i.dsts, i.srcs) for i in rec.out]


@settings(max_examples=60, deadline=None)
@given(st.data())
def test_exported_kernels_issue_the_recorded_icws(data):
    from ppaloc.cpp.export import _Recorder

    rec = _Recorder()  # records ICWs as a kernel does, without running them
    calls = data.draw(st.lists(st.sampled_from(sorted(_MACROS)), min_size=1, max_size=12))
    for name in calls:
        args = [data.draw(st.sampled_from(choices)) for choices in _MACROS[name]]
        try:
            getattr(rec, name)(*args)
        except PpalocError:
            pass  # an invalid combination (a register twice): nothing recorded
    text = kernel_to_cpp(rec.out, "k")
    statements = [ln.strip() for ln in text.splitlines()[3:-2]]
    assert _replay(statements) == [(i.op, i.dsts, i.srcs) for i in rec.out]
    assert not any(s.startswith("XOR(") for s in statements)  # not a device function
