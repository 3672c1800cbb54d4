"""User mistakes raise PpalocError subclasses whose message names the bad value and the fix.

Where an older exception type was part of the behaviour (``KeyError`` from a lookup by name,
``ValueError`` from the timing model), the error is *also* an instance of it.
"""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import PpalocError, RegisterMisuseError, SimulatorError
from ppaloc.sim import R5, R6, A, B, NoiseParams, Scamp5, TimingModel, east
from ppaloc.sim.kernel import IcwStackWarning
from ppaloc.sim.registers import register_by_name


@pytest.fixture
def sim() -> Scamp5:
    return Scamp5(rows=4, cols=4)


@pytest.mark.parametrize("seed", [-1, "a", 1.5, True])
def test_bad_seed(seed) -> None:
    with pytest.raises(SimulatorError, match=rf"seed={seed!r} is invalid: use an integer >= 0"):
        Scamp5(4, 4, seed=seed)


def test_numpy_integer_seed_is_fine() -> None:
    assert Scamp5(2, 2, seed=np.int64(3)).rows == 2


@pytest.mark.parametrize("hz", [0, -1.0, float("nan")])
def test_bad_clock(hz) -> None:
    with pytest.raises(SimulatorError, match=r"clock_hz=.* is invalid: use a positive frequency"):
        Scamp5(4, 4, clock_hz=hz)
    with pytest.raises(ValueError):  # still a ValueError for older callers
        TimingModel(clock_hz=hz)


def test_write_rejects_non_numeric_and_ragged_values(sim: Scamp5) -> None:
    with pytest.raises(SimulatorError, match=r"cannot write 'abc' into A: use numbers"):
        sim.write(A, "abc")
    with pytest.raises(SimulatorError, match=r"cannot write .* into A: use numbers"):
        sim.write(A, [[1, 2], [3]])
    with pytest.raises(SimulatorError, match=r"cannot write .* into R5: use numbers"):
        sim.write(R5, [[1, 2], [3]])


def test_stage_name_and_report_lookup(sim: Scamp5) -> None:
    with pytest.raises(SimulatorError, match=r"stage name ''.*non-empty"), sim.stage(""):
        pass
    with sim.stage("capture"):
        sim.nop()
    report = sim.timing.report()
    with pytest.raises(SimulatorError, match=r"no stage 'captur' in this report; stages: "):
        report.stage("captur")
    with pytest.raises(KeyError):  # still a KeyError for older callers
        report.stage("captur")
    with pytest.raises(PpalocError) as info:
        report.stage("x")
    assert str(info.value) == "no stage 'x' in this report; stages: 'capture'"


def test_unknown_register_name() -> None:
    with pytest.raises(RegisterMisuseError, match=r"no register is called 'G'; use one of A"):
        register_by_name("G")
    with pytest.raises(KeyError):
        register_by_name("G")


def test_global_sum_out_must_be_an_array(sim: Scamp5) -> None:
    with pytest.raises(
        SimulatorError, match=r"out must be a writable numpy array of shape \(4, 4\)"
    ):
        sim.global_sum_16(A, out=[0] * 16)


@pytest.mark.parametrize(
    ("out", "got"),
    [
        (np.zeros((4, 4), np.int8), "dtype int8, which cannot hold the codes 0-255"),
        (np.zeros((4, 4), bool), "dtype bool, which cannot hold the codes 0-255"),
        (np.zeros((4, 4), np.uint8)[::1].view(), "a read-only array"),
    ],
)
def test_global_sum_out_that_cannot_hold_the_codes_is_refused_before_the_call(
    sim: Scamp5, out, got
) -> None:
    # an int8 out read the codes 255 as -1, and a refused call was charged its time
    out.flags.writeable = got != "a read-only array"
    sim.write(A, 127.0)
    before = sim.timing.now_us
    with pytest.raises(SimulatorError, match=f"got {got}; pass np.zeros"):
        sim.global_sum_16(A, out=out)
    assert sim.timing.now_us == before
    fine = np.zeros((4, 4), np.int16)
    assert sim.global_sum_16(A, out=fine) == 16 * 255 and (fine == 255).all()


@pytest.mark.parametrize("n", [0, -2, "2", 1.0])
def test_newsblur_iterations(sim: Scamp5, n) -> None:
    with pytest.raises(SimulatorError, match=rf"newsblur\(A, B, {n!r}\): iterations={n!r}"):
        sim.newsblur(A, B, n)


@pytest.mark.parametrize("name", ["newsblur", "newsblurh", "gauss", "gaussv"])
def test_blur_iterations_beyond_the_controllers_bound_are_refused(sim: Scamp5, name) -> None:
    # 2**70 iterations built a list of 2**71 steps (memory until the machine gave out; a
    # C++ int of 10**8 took tens of GB), where any kernel keeps 1024 ICWs
    with pytest.raises(SimulatorError) as err, sim.kernel() as k:
        getattr(k, name)(A, B, 2**70)
    assert str(err.value) == (
        f"{name}(A, B, {2**70}): iterations={2**70} is too many; use an integer in "
        "[1, 65536] (a kernel holds 1024 ICWs)"
    )
    with pytest.raises(SimulatorError, match="is too many"), sim.kernel() as k:
        getattr(k, name)(A, B, (1 << 16) + 1)
    with pytest.warns(IcwStackWarning, match="lost"), sim.kernel() as k:
        getattr(k, name)(A, B, 600)  # more than a kernel holds: its first ICWs kept, as ever
    assert len(k) == 1024 and k.dropped > 0


def test_noise_params_must_be_numbers() -> None:
    with pytest.raises(SimulatorError, match=r"NoiseParams.temporal_sd='a' is invalid: use a"):
        NoiseParams(temporal_sd="a")


def test_icw_operands_must_be_sequences(sim: Scamp5) -> None:
    with pytest.raises(RegisterMisuseError, match=r"icw\('bus'\): dsts=A .* e\.g\. \(A,\)"):
        sim.icw("bus", A, (B,))


def test_dnews_boundary_is_0_or_1(sim: Scamp5) -> None:
    with pytest.raises(RegisterMisuseError, match=r"boundary=2 .* use 0 or 1"):
        sim.DNEWS(R5, R6, east, 2)


def test_unknown_clock_class_in_icw_us() -> None:
    with pytest.raises(SimulatorError, match=r"unknown clock class 'fast'; expected one of"):
        TimingModel().icw_us("fast")


def test_timing_arguments(sim: Scamp5) -> None:
    import dataclasses

    from ppaloc.sim import TimingConstants

    with pytest.raises(SimulatorError, match=r"stage name 3 is invalid"), sim.stage(3):
        pass
    with pytest.raises(SimulatorError, match=r"TimingConstants.analog_cycles=-1 is invalid"):
        dataclasses.replace(TimingConstants(), analog_cycles=-1)
    with pytest.raises(SimulatorError, match=r"constants=5 is invalid: use a ppaloc.sim"):
        TimingModel(constants=5)


def test_render_errors(sim: Scamp5, tmp_path) -> None:
    from ppaloc.sim import render_montage, render_register

    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(SimulatorError, match=r"cannot write '.*file/a.png': .*writable folder"):
        render_register(sim, A, blocker / "a.png")
    with pytest.raises(SimulatorError, match=r"'A' is not a register handle"):
        render_montage(sim, tmp_path / "m.png", ["A"])


def test_numpy_integers_are_accepted_where_ints_are(sim: Scamp5) -> None:
    sim.write(R6, np.eye(4, dtype=bool))
    sim.DNEWS(R5, R6, east, np.int64(1))
    assert sim.read(R5)[:, 3].all()  # the east edge reads the boundary 1
    sim.DNEWS(R5, R6, east, np.bool_(False))
    assert not sim.read(R5)[:, 3].any()
    sim.write(A, np.ones((4, 4)))
    sim.newsblur(B, A, np.int64(1))
    assert sim.read(B)[1, 1] == 4
    with pytest.raises(RegisterMisuseError, match=r"boundary=1.0 .* use 0 or 1"):
        sim.DNEWS(R5, R6, east, 1.0)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        # a digital destination beside a source that is no register: the message about the
        # destination printed the instruction, and stopped on the source's missing name
        (lambda s: s.abs(R5, None), r"bus: None is not a register handle"),
        (lambda s: s.bus(R5, None), r"bus: None is not a register handle"),
        (lambda s: s.bus(None), r"bus\(None\): give a register"),
        (lambda s: s.bus(3), r"bus\(3\): give a register"),
        (lambda s: s.icw([], (A,)), r"\[\] is not an instruction"),
        (lambda s: s.address_mask(None, 0, 0, 0, False), r"address_mask: r=None must be"),
        (lambda s: s.address_mask(0, 0, 0, 300, False), r"address_mask: cx=300 is out of"),
    ],
)
def test_api_arguments_of_the_wrong_kind_are_one_line(sim: Scamp5, call, message) -> None:
    with pytest.raises(PpalocError, match=message) as err:
        call(sim)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    "call",
    [
        lambda s, a: s.scamp5_load_pattern(R5, 3, 4, 0, 0, scamp_addr=a),
        lambda s, a: s.load_point(R5, 1, 2, scamp_addr=a),
        lambda s, a: s.select_point(1, 2, scamp_addr=a),
        lambda s, a: s.global_or(R5, 0, 0, 0, 0, scamp_addr=a),
        lambda s, a: s.read_areg(A, 1, 2, scamp_addr=a),
        lambda s, a: (s.draw_begin(R5), s.draw_point(1, 2, scamp_addr=a), s.draw_end()),
        lambda s, a: s.address_mask(0, 0, 0, 0, a),
    ],
)
def test_scamp_addr_is_true_or_false(sim: Scamp5, call) -> None:
    # a list was an internal TypeError (the address patterns' cache) or taken as True
    for value in ([1, 2], 2, "yes", None):
        with pytest.raises(SimulatorError, match=r"scamp_addr=.* must be True or False"):
            call(sim, value)
    for value in (True, False, 1, 0, np.bool_(True)):
        call(sim, value)


def test_address_mask_takes_numpy_integers(sim: Scamp5) -> None:
    # np.uint8(255) & ~3 overflowed uint8 (an OverflowError)
    got = sim.address_mask(np.uint8(255), np.uint8(0), np.uint8(3), np.uint8(0), False)
    np.testing.assert_array_equal(got, sim.address_mask(255, 0, 3, 0, False))


@pytest.mark.parametrize(
    ("tmp", "clear", "message"),
    [
        ("R5", False, r"pattern_cells\(R5, cells, R5\): tmp must be another digital register"),
        ("R0", True, r"pattern_cells\(R5, cells, R0, clear=True\): tmp must be another"),
    ],
)
def test_pattern_cells_refuses_a_tmp_it_would_clobber_before_any_call(tmp, clear, message):
    # the error came from deep inside, after the pattern was loaded and its time charged
    from ppaloc.sim import registers

    sim = Scamp5(8, 8)
    sim.SET(R5)
    before = sim.timing.now_us
    with pytest.raises(RegisterMisuseError, match=message):
        sim.pattern_cells(R5, np.eye(2, dtype=bool), getattr(registers, tmp), clear)
    assert sim.timing.now_us == before and sim.read(R5).all()


def test_shift_refuses_the_dnews_selectors_and_an_analogue_boundary():
    from ppaloc.sim import R1, R4

    sim = Scamp5(8, 8)
    for reg in (R1, R4):  # a digital shift's DNEWS steps overwrite R1-R4 first
        with pytest.raises(RegisterMisuseError, match=rf"shift\({reg.name}, 1, 0\): .*R1-R4"):
            sim.shift(reg, 1, 0)
    with pytest.raises(RegisterMisuseError, match=r"shift\(A, 1, 0, boundary=1\): an analogue"):
        sim.shift(A, 1, 0, boundary=1)
    assert sim.timing.now_us == 0.0
    sim.shift(R5, 1, 0, boundary=1)  # a digital register of the program's own: fine


@pytest.mark.parametrize(
    ("name", "value"),
    [("clock_hz", 0), ("clock_hz", -1e3), ("clock_hz", float("nan")), ("pe_count", -5),
     ("pe_count", 2.5), ("pe_count", True), ("constants", {})],
)  # fmt: skip
def test_timing_setters_check_as_the_constructor_does(name, value):
    # time ran backwards, energy went negative, or a ZeroDivisionError came at the next call
    sim = Scamp5(8, 8)
    with pytest.raises(SimulatorError, match=rf"{name}=.* is invalid"):
        setattr(sim.timing, name, value)
    with pytest.raises(SimulatorError, match=rf"{name}=.* is invalid"):
        TimingModel(**{name: value})
    sim.mov(A, B)
    assert sim.timing.now_us > 0


def test_default_patterns_select_the_whole_of_an_array_larger_than_the_chip():
    # the defaults stopped at row and column 255: a point at (299, 299) was not seen
    sim = Scamp5(300, 300)
    sim.load_point(R5, 299, 299)
    assert sim.global_or(R5) == 1
    sim.write(A, 5.0)
    assert sim.global_sum_sparse(A) == 4 * 5 + 128  # as on 256 x 256: a quarter, 4 v + 128
    assert sim.global_sum_sparse(A, 2, 2, 254, 254, scamp_addr=True) == 148  # given: the same
    small = Scamp5(256, 256)
    small.write(A, 5.0)
    assert small.global_sum_sparse(A) == 148
