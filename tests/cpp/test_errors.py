"""Bad input: compile errors, unmodelled calls, misuse, hangs and crashes, each one line."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ppaloc.cli import main
from ppaloc.cpp import CompileError, UnmodelledCallError, compile_program, run_program
from ppaloc.cpp.build import check_source
from ppaloc.errors import PpalocError

from .conftest import PROGRAMS

FAULTS = PROGRAMS / "faults.cpp"
FRAMES = [np.full((64, 64), 100, np.uint8)]


@pytest.fixture(scope="module")
def faults(cxx):
    return compile_program(FAULTS)


def fault(n: int, tmp_path=None, timeout: float = 60, **settings):
    values = {"fault": str(n), **{k: str(v) for k, v in settings.items()}}
    out = None if tmp_path is None else tmp_path / "out"
    return run_program(FAULTS, FRAMES, settings=values, timeout=timeout, out=out)


def test_compile_error_names_file_and_line(cxx):
    with pytest.raises(CompileError) as err:
        compile_program(PROGRAMS / "broken.cpp")
    assert "broken.cpp:6:" in str(err.value)
    assert "undefined_name" in str(err.value)


def test_compiler_messages_that_are_not_utf8_are_read(cxx, tmp_path):
    """A source in Latin-1 (or any bytes) makes the compiler quote bytes that are not
    UTF-8: its errors are still one CompileError, and its warnings do not stop the run."""
    bad = tmp_path / "latin1.cpp"
    bad.write_bytes(b'#include <scamp5.hpp>\nint main() { vs_init(); int x = "caf\xe9"; }\n')
    with pytest.raises(CompileError, match=r"latin1.cpp:2:"):
        compile_program(bad)
    warns = tmp_path / "warns.cpp"
    warns.write_bytes(b"#include <scamp5.hpp>\n#warning caf\xe9\nint main() { vs_init(); }\n")
    assert compile_program(warns).exists()


def test_link_errors_name_their_cause(cxx, tmp_path):
    no_main = tmp_path / "nomain.cpp"
    no_main.write_text("#include <scamp5.hpp>\nint foo() { return 1; }\n")
    with pytest.raises(CompileError, match=r"undefined reference to `main'"):
        compile_program(no_main)
    twice = tmp_path / "twice.cpp"
    twice.write_text("int foo() { return 2; }\n")
    (tmp_path / "main.cpp").write_text("int foo() { return 1; }\nint main() { return foo(); }\n")
    with pytest.raises(CompileError, match=r"multiple definition of `foo\(\)'"):
        compile_program([tmp_path / "main.cpp", twice])
    notes = tmp_path / "notes.txt"  # not a source: the linker reads it as a script
    notes.write_text("hello world\n")
    with pytest.raises(CompileError, match=r"notes.txt: file format not recognized"):
        compile_program(notes)


def test_windows_include_path_named_with_its_fix(tmp_path):
    # the device's Windows toolchain reads "..\inc\x.hpp" as a path; g++ would only say
    # that no file of that name exists
    (tmp_path / "inc").mkdir()
    (tmp_path / "inc" / "x.hpp").write_text("#pragma once\n")
    (tmp_path / "src").mkdir()
    main_cpp = tmp_path / "src" / "main.cpp"
    main_cpp.write_text('#include <scamp5.hpp>\n#include "..\\inc\\x.hpp"\nint main() {}\n')
    with pytest.raises(PpalocError) as err:
        compile_program(main_cpp)
    assert str(err.value) == (
        f'{main_cpp}:2: #include "..\\inc\\x.hpp" separates folders with \\, which only a '
        "Windows compiler reads as a folder separator (g++ here takes it as part of the file "
        'name): write #include "../inc/x.hpp"'
    )
    # the same in a header of an -I folder, written <inc\x.hpp>
    main_cpp.write_text("#include <scamp5.hpp>\n\n#include <inc\\x.hpp>\nint main() {}\n")
    with pytest.raises(PpalocError, match=r"main.cpp:3: #include <inc\\x.hpp> .* <inc/x.hpp>$"):
        compile_program(main_cpp, include_dirs=[tmp_path])


def test_unmodelled_call_named_before_the_run():
    with pytest.raises(UnmodelledCallError, match=r"unmodelled.cpp:9: vs_post_message is a"):
        compile_program(PROGRAMS / "unmodelled.cpp")
    with pytest.raises(UnmodelledCallError, match=r"p.cpp:2: aout is"):
        check_source("scamp5_kernel_begin();\n  aout(A);\n", "p.cpp")
    check_source('vs_post_text("scamp5_output_events");\nmov(A, B);\n', "p.cpp")  # strings, known
    own = "static int scamp5_total = 0;\nvoid vs_helper(int x) { scamp5_total += x; }\n"
    check_source(own + "int main() { vs_helper(scamp5_total); }\n", "p.cpp")  # its own names


def test_every_unmodelled_call_is_named_at_once_sorted():
    with pytest.raises(UnmodelledCallError) as err:
        check_source("vs_b();\n  aout(A);\nvs_b();\nscamp5_c(1);\n", "p.cpp")
    assert str(err.value) == (
        "p.cpp: 3 SCAMP-5d functions the simulator does not model: aout (line 2), "
        "scamp5_c (line 4), vs_b (lines 1, 3); docs/cpp.md lists what is modelled"
    )
    with pytest.raises(UnmodelledCallError, match=r"^p.cpp:1: vs_b is a .* \(also lines 3\);"):
        check_source("vs_b();\n\nvs_b();\n", "p.cpp")
    many = "".join(f"vs_missing_{k:02d}();\n" for k in reversed(range(12)))
    with pytest.raises(UnmodelledCallError) as err:
        check_source(many, "p.cpp")
    lines = str(err.value).splitlines()
    assert lines[0] == (
        "p.cpp: 12 SCAMP-5d functions the simulator does not model (docs/cpp.md lists what "
        "is modelled):"
    )
    # separated by commas, which the CLI's one line keeps (it read 'a (line 1) b (line 2)')
    assert lines[1:] == [f"  vs_missing_{k:02d} (line {12 - k})," for k in range(11)] + [
        "  vs_missing_11 (line 1)"
    ]


def test_hang_is_stopped(faults, tmp_path):
    with pytest.raises(PpalocError, match=r"did not finish within 3 s \(stopped in frame 0\)"):
        fault(1, tmp_path, timeout=3)
    assert not (tmp_path / "out").exists()


def test_a_loop_that_never_begins_a_frame_says_so(cxx, tmp_path):
    # a loop that runs free on the device (vs_process_message alone, no frame calls, no
    # loop counter: tests/cpp/test_idioms.py runs one that counts its frames with it)
    source = tmp_path / "free.cpp"
    source.write_text(
        "#include <scamp5.hpp>\nusing namespace SCAMP5_PE;\nint main() {\n    vs_init();\n"
        "    while (1) {\n        vs_process_message();\n        scamp5_in(A, 10);\n"
        "    }\n}\n"
    )
    with pytest.raises(PpalocError) as err:
        run_program(source, FRAMES, timeout=2, out=tmp_path / "out")
    assert str(err.value) == (
        "free.cpp did not finish within 2 s and never began a frame: each frame begins at "
        "vs_frame_loop_control() or vs_wait_frame_trigger() (in a loop that waits for "
        "neither, vs_loop_counter_inc() ends one); a loop that never ends, or a frame loop "
        "without any of them (call vs_frame_loop_control() at its top)? raise --timeout if "
        "it needs longer"
    )
    assert not (tmp_path / "out").exists()


def test_a_slider_whose_minimum_is_above_its_maximum_is_named(cxx, tmp_path):
    # no --set value could be in its range; vs_gui_set_slider_range refuses it too
    source = tmp_path / "range.cpp"
    source.write_text(
        "#include <scamp5.hpp>\nint main() {\n    vs_init();\n"
        '    vs_gui_add_slider("level", 10, 0, 5);\n    vs_frame_loop_control();\n}\n'
    )
    with pytest.raises(PpalocError) as err:
        run_program(source, FRAMES, timeout=60)
    assert str(err.value) == (
        "range.cpp:4: vs_gui_add_slider('level', 10, 0, 5): the minimum is above the maximum"
    )


def test_a_program_that_closes_its_pipe_is_not_a_finished_run(cxx, tmp_path):
    # it ended 'successfully' with fewer frames than asked, its outputs written
    source = tmp_path / "closes.cpp"
    source.write_text(
        "#include <scamp5.hpp>\n#include <unistd.h>\nint main() {\n    vs_init();\n"
        "    vs_frame_loop_control();\n    for (int fd = 3; fd < 64; fd++) close(fd);\n"
        "    while (1) vs_frame_loop_control();\n}\n"
    )
    with pytest.raises(PpalocError) as err:
        run_program(source, FRAMES * 3, timeout=60, out=tmp_path / "out")
    assert str(err.value).startswith(
        "closes.cpp lost its pipe to the simulator in frame 0 (it closed the file descriptors"
    )
    assert not (tmp_path / "out").exists()


def test_a_full_disk_names_the_file_in_the_runs_folder(cxx, tmp_path, monkeypatch):
    # a display's PNG refused by the system was named by its path in the hidden staging
    # folder ('.out.ppaloc-new-...'), with "choose a writable folder" for a full disk
    from ppaloc import fileio

    source = tmp_path / "shows.cpp"
    source.write_text(
        "#include <scamp5.hpp>\nusing namespace SCAMP5_PE;\nint main() {\n    vs_init();\n"
        '    vs_handle d = vs_gui_add_display("image", 0, 0);\n'
        "    while (1) {\n        vs_frame_loop_control();\n        scamp5_get_image(A, B);\n"
        "        scamp5_output_image(A, d);\n    }\n}\n"
    )
    compile_program(source)

    def disk_full(*_args):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(fileio.os, "fsync", disk_full)
    out = tmp_path / "out"
    with pytest.raises(OSError) as err:
        run_program(source, FRAMES, timeout=60, out=out)
    assert err.value.filename == str(out / "displays" / "image" / "frame_0000.png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["shows.cpp"]


def test_out_of_bounds_write_is_one_line_and_leaves_no_folder(faults, tmp_path):
    fault(2, index=3)  # in bounds: fine
    with pytest.raises(PpalocError) as err:
        fault(2, tmp_path, index=16)
    message = str(err.value)
    assert "crashed in frame 0" in message and "faults.cpp:" in message
    assert "\n" not in message
    assert list(tmp_path.iterdir()) == []


def test_null_pointer_crash(faults, tmp_path):
    with pytest.raises(PpalocError, match="crashed in frame 0"):
        fault(6, tmp_path)
    assert list(tmp_path.iterdir()) == []


ABORTS = r"""
#include <scamp5.hpp>
#include <cassert>
#include <stdexcept>
int main() {
    vs_init();
    int mode = 0;
    vs_gui_add_slider("mode", 0, 2, 0, &mode);
    while (1) {
        vs_frame_loop_control();
        if (mode == 0) assert(mode > 0 && "a mode");
        if (mode == 1) throw std::out_of_range("index 7 is past the end");
        if (mode == 2) throw 42;
    }
}
"""


@pytest.mark.parametrize(
    ("mode", "cause"),
    [
        (0, 'the assertion `mode > 0 && "a mode"\' failed at aborts.cpp:11'),
        (1, "an uncaught exception std::out_of_range: index 7 is past the end"),
        (2, "an uncaught exception int"),
    ],
)
def test_an_abort_names_its_cause(cxx, tmp_path, mode, cause):
    source = tmp_path / "aborts.cpp"
    source.write_text(ABORTS)
    with pytest.raises(PpalocError) as err:
        run_program(source, FRAMES, settings={"mode": str(mode)}, timeout=60)
    assert str(err.value) == f"aborts.cpp crashed in frame 0 (SIGABRT): {cause}"


def test_division_by_zero_gives_the_devices_zero_and_is_reported(faults, tmp_path):
    assert fault(7, index=4).texts == ["25 0"] * len(FRAMES)
    result = fault(7)  # 100 / 0 and 100 % 0 in every frame: 0, and the dividend
    assert result.texts == ["0 100"] * len(FRAMES)
    if platform.machine() == "x86_64":  # the host traps: caught, given 0, reported
        assert result.session.warnings == [
            f"faults.cpp:40: an integer division by zero (first in frame 0, {2 * len(FRAMES)}"
            " in all) gave 0, as the device's run-time library does, and the program went on"
        ]


HELPER_KERNELS = """#include <scamp5.hpp>
using namespace SCAMP5_PE;
void moveDir(AREG y, AREG x, news_t dir) {
    scamp5_kernel_begin();
        movx(y, x, dir);
    scamp5_kernel_end();
}
void copy(AREG y) {
    scamp5_kernel_begin();
        allow_highspeed(true);
        mov(y, A);
    scamp5_kernel_end();
}
int main() {
    vs_init();
    while (1) {
        vs_frame_loop_control();
        scamp5_get_image(A, B);
        moveDir(B, A, north);
        moveDir(C, A, south);
        moveDir(D, A, east);
        copy(E);
        copy(E);
    }
}
"""


def test_a_static_kernel_begun_again_with_other_calls_is_reported_once(cxx, tmp_path):
    path = tmp_path / "helper.cpp"
    path.write_text(HELPER_KERNELS)
    result = run_program(path, FRAMES * 3)
    # the device's semantics: recorded once, the first call's registers replayed
    assert [(k.calls, k.runs) for k in result.session.kernels.values()] == [
        (["movx(B, A, north)"], 9),
        (["mov(E, A)"], 6),
    ]
    assert result.session.warnings == [
        "helper.cpp:4: the static kernel begun here was begun again in frame 0 with other "
        "calls (movx(C, A, south) where it recorded movx(B, A, north)): it runs as first "
        "recorded, as on the device (the device's simulator records it again at every pass); "
        "use scamp5_dynamic_kernel_begin() for a kernel that changes"
    ]
    # a kernel whose passes agree: no warning, its host call recorded once as before
    assert result.session.host_log == [(0, "allow_highspeed(1)")]


COUNTING_KERNEL = """#include <scamp5.hpp>
using namespace SCAMP5_PE;
int main() {
    vs_init();
    int n = 0;
    while (1) {
        vs_frame_loop_control();
        scamp5_kernel_begin();
            mov(A, B);
            n++;
        scamp5_kernel_end();
        vs_post_text("n=%d", n);
    }
}
"""


@pytest.mark.parametrize(("check", "texts"), [(True, ["n=1", "n=2", "n=3"]), (False, ["n=1"] * 3)])
def test_a_static_kernels_body_runs_once_without_the_kernel_check(cxx, tmp_path, check, texts):
    # the device runs the body once; the check runs it again to compare, and its C++ with it
    path = tmp_path / "count.cpp"
    path.write_text(COUNTING_KERNEL)
    result = run_program(path, FRAMES * 3, kernel_check=check)
    assert result.texts == texts
    assert [k.runs for k in result.session.kernels.values()] == [3]
    helper = tmp_path / "helper.cpp"
    helper.write_text(HELPER_KERNELS)
    warned = run_program(helper, FRAMES, kernel_check=check).session.warnings
    assert len(warned) == int(check)  # the helper's other registers: found by the check only


def test_int_min_by_minus_one_wraps_as_on_the_device_without_a_report(faults):
    result = fault(8)  # INT_MIN / -1, INT_MIN % -1, LLONG_MIN / -1, LLONG_MIN % -1
    assert result.texts == ["-2147483648 0 -9223372036854775808 0"] * len(FRAMES)
    assert result.session.warnings == []
    assert fault(8, index=4).texts == ["-715827882 -2 -3074457345618258602 -2"] * len(FRAMES)


DIVIDED = [  # fault 9: "RAX RDX" after each x86-64 division form (faults.cpp says which)
    "1111222233338000 aaaabbbbcccc0000",  # 16-bit INT16_MIN / -1: only AX, DX written
    "1111222233330000 aaaabbbbcccc0064",  # 16-bit 100 / 0: only AX, DX written
    "0000000080000000 0000000000000000",  # INT_MIN / -1, a stack operand: zero-extended
    "0000000080000000 0000000000000000",  # INT_MIN / -1, [r13 + r12 * 4 - 4]
    "8000000000000000 0000000000000000",  # LLONG_MIN / -1 in r15
    "0000000080000000 0000000000000000",  # INT_MIN / -1, RIP-relative
    "0000000080000000 0000000000000000",  # INT_MIN / -1, FS-relative (thread-local)
    "1111222233330080 0000000000000005",  # -128 / -1 by CH: AL -128, AH 0
    "1111222233336400 0000000000000100",  # 100 / 0 by SIL (DH is 1): AL 0, AH 100
    "0000000000000000 0000000000000064",  # unsigned 100 / 0, a stack operand
    "0000000000000003 00000000ffffffff",  # -(2^33 + 7) / -2: 2^32 + 3's low bits, rem. -1
    "0000000000000001 0000000000000007",  # unsigned: 0x100000001's low bits, remainder 7
]


@pytest.mark.skipif(platform.machine() != "x86_64", reason="x86-64 division instructions")
def test_every_x86_64_division_form_gives_the_devices_result(faults):
    result = fault(9)
    assert result.texts == DIVIDED * len(FRAMES)
    assert result.session.warnings == [  # the divisions by zero, not the overflows
        f"faults.cpp:{line}: an integer division by zero (first in frame 0, {len(FRAMES)} in all)"
        " gave 0, as the device's run-time library does, and the program went on"
        for line in (74, 87, 89)
    ]


def test_register_misuse_names_the_line(faults):
    message = r"faults.cpp:28: in sub\(A, B, A\): .*lists A twice"
    with pytest.raises(PpalocError, match=message) as e:
        fault(3)
    assert str(e.value).count("sub(A, B, A)") == 1  # the call named once


@pytest.mark.parametrize(
    ("call", "message"),
    [
        ("bus(A, A)", "k.cpp:6: bus(A, A) lists A twice;"),
        ("DNEWS(R5, R1, south)", "k.cpp:6: DNEWS(R5, R1, south, 0): R1 cannot be an argument"),
        ("div(A, B, C, A)", "k.cpp:6: div(A, B, C, A): A appears twice"),
    ],
)
def test_a_misused_call_is_named_once_in_the_simulators_own_spelling(cxx, tmp_path, call, message):
    # the shim's call text came first, then the simulator's own naming of the same call
    path = tmp_path / "k.cpp"
    path.write_text(
        "#include <scamp5.hpp>\nusing namespace SCAMP5_PE;\nint main() {\n    vs_init();\n"
        f"    while (1) {{ vs_frame_loop_control();\n        scamp5_kernel_begin(); {call}; "
        "scamp5_kernel_end();\n    }\n}\n"
    )
    with pytest.raises(PpalocError) as e:
        run_program(path, FRAMES)
    assert str(e.value).startswith(message)
    assert str(e.value).count(call.partition("(")[0] + "(") == 1


def test_kernel_function_outside_a_kernel(faults):
    with pytest.raises(PpalocError, match=r"faults.cpp:32: mov\(\) is a kernel function"):
        fault(4)


def test_bad_controller_value_names_the_line(faults):
    with pytest.raises(PpalocError, match=r"faults.cpp:34: scamp5_load_point\(R5, 200, 3\)"):
        fault(5)


def test_settings_checked(faults):
    with pytest.raises(PpalocError, match=r"--set fault=12 is outside the slider's range"):
        fault(12)
    with pytest.raises(PpalocError, match="has no slider, switch or button of that name"):
        run_program(FAULTS, FRAMES, settings={"nope": "1"})


def test_a_slider_named_with_a_colon_is_set_with_or_without_it(faults, tmp_path, capsys):
    for name in ("gain: ", "gain:", "gain"):  # as declared, and without ': '
        assert run_program(FAULTS, FRAMES, settings={name: "4"}).session.gui_values["gain: "] == 4
    out = tmp_path / "run"
    assert main(["cpp", "run", str(FAULTS), "--out", str(out), "-q", "--set", "gain=5"]) == 0
    assert json.loads((out / "summary.json").read_text())["gui_values"]["gain: "] == 5
    assert main(["cpp", "run", str(FAULTS), "--out", str(out), "-q", "--set", "gian=5"]) == 1
    assert capsys.readouterr().err == (
        "ppaloc: error: --set gian=...: faults.cpp has no slider, switch or button of that name "
        "(it has: fault, index, gain)\n"
    )


def test_settings_from_python_take_numbers(faults):
    got = run_program(FAULTS, FRAMES, settings={"fault": 0, "gain": 4, "index": 2.0})
    assert got.session.gui_values == {"fault": 0, "index": 2, "gain: ": 4}


def test_cli_exit_codes(faults, tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["cpp", "run", str(FAULTS), "--out", str(out), "--frames", "2", "-q"]) == 0
    assert (out / "displays" / "image" / "frame_0001.png").exists()
    noisy = tmp_path / "noisy"
    args = ["cpp", "run", str(FAULTS), "--out", str(noisy), "--noise", "typical", "--seed", "3"]
    assert main([*args, "-q"]) == 0
    assert main(["cpp", "run", str(FAULTS), "--out", str(noisy), "--seed", "-1"]) == 1
    assert "--seed -1 must be 0 or more" in capsys.readouterr().err
    # as every other command's seed: at most 2**63 - 1 (a larger one ran)
    assert main(["cpp", "run", str(FAULTS), "--out", str(noisy), "--seed", str(2**64)]) == 1
    assert capsys.readouterr().err == (
        f"ppaloc: error: --seed {2**64} is too large: give an integer in [0, {2**63 - 1}]\n"
    )
    code = main(["cpp", "run", str(FAULTS), "--out", str(tmp_path / "bad"), "--set", "fault=3"])
    assert code == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "faults.cpp:28" in err


def test_a_runs_files_are_utf8_whatever_the_locale(cxx, tmp_path):
    # text.txt, host.txt and stdout.txt were written in the locale's encoding: under an
    # ASCII one (C, Python's UTF-8 mode off) a program's non-ASCII text failed them after
    # the run (an internal error, exit 3, nothing kept); under Latin-1 they were Latin-1
    exe = Path(sys.executable).with_name("ppaloc")
    if not exe.is_file():
        pytest.skip("the ppaloc console script is not installed next to this python")
    program = tmp_path / "text.cpp"
    program.write_text(
        "#include <scamp5.hpp>\n#include <cstdio>\nint main() {\n    vs_init();\n"
        '    vs_frame_loop_control();\n    vs_post_text("temp\u00e9rature %d", 5);\n'
        '    std::printf("sortie \u00e9\\n");\n    return 0;\n}\n',
        encoding="utf-8",
    )
    env = {**os.environ, "LC_ALL": "C", "PYTHONUTF8": "0", "PYTHONCOERCECLOCALE": "0"}
    out = tmp_path / "run"
    done = subprocess.run(
        [str(exe), "cpp", "run", str(program), "--out", str(out), "-q"],
        capture_output=True,
        env=env,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert (out / "text.txt").read_text(encoding="utf-8") == "frame 0: temp\u00e9rature 5\n"
    assert (out / "stdout.txt").read_text(encoding="utf-8") == "sortie \u00e9\n"


def test_an_output_folder_of_other_files_is_refused_before_the_run(tmp_path):
    from ppaloc.cpp.run import check_output_folder
    from ppaloc.errors import PpalocError

    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    with pytest.raises(PpalocError, match=r"holds 'notes\.txt', which ppaloc cpp run did not"):
        check_output_folder(mine)
    (mine / "notes.txt").unlink()
    (mine / "timing.json").write_text("{}")  # a run's name, but no summary.json
    with pytest.raises(PpalocError, match="replaced whole"):
        check_output_folder(mine)
    (mine / "summary.json").write_text("{}")
    check_output_folder(mine)  # an earlier run's folder
    check_output_folder(tmp_path / "new")


def test_an_earlier_runs_summary_nested_too_deep_is_one_line(tmp_path):
    # reading which files the run wrote in displays/ ended in an internal error (RecursionError)
    from ppaloc.cpp.run import check_output_folder
    from ppaloc.errors import PpalocError

    (tmp_path / "displays" / "image").mkdir(parents=True)
    (tmp_path / "displays" / "image" / "frame_0000.png").write_bytes(b"png")
    (tmp_path / "summary.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(PpalocError, match="holds 'displays/image', which ppaloc cpp run did not"):
        check_output_folder(tmp_path)


def test_a_users_file_inside_displays_or_at_the_top_is_refused(faults, tmp_path, capsys):
    out = tmp_path / "run"
    args = ["cpp", "run", str(FAULTS), "--out", str(out), "-q", "--frames", "2"]
    assert main(args) == 0
    assert main(args) == 0  # an earlier run's folder: every file in it the run's own
    summary = json.loads((out / "summary.json").read_text())
    assert summary["files"] == [f"displays/image/frame_000{i}.png" for i in (0, 1)]
    del summary["files"]  # a run's folder from before summary.json listed its files
    (out / "summary.json").write_text(json.dumps(summary))
    assert main(args) == 0
    capsys.readouterr()
    for mine in ("displays/image/notes.txt", "displays/mine.png", ".notes.txt"):
        (out / mine).write_text("keep me")
        assert main(args) == 1
        err = capsys.readouterr().err
        assert err == (
            f"ppaloc: error: --out {out} holds {mine!r}, which ppaloc cpp run did not write, "
            "and a run's folder is replaced whole; give a new folder or an earlier run's "
            "folder\n"
        )
        assert (out / mine).read_text() == "keep me"
        (out / mine).unlink()
    assert main(args) == 0


ROM_TABLE = "static const uint32_t table[2][5] = {{0, 0, 0, 0, 0}, {0, 0, 0, 0, 0}};\n"
ROM_LOOP = "    while (1) {\n        vs_frame_loop_control();\n        rom();\n    }\n}\n"
ROM_IN_MAIN = "int main() {\n    vs_init();\n    scamp5_kernel rom(table, 2);\n"


@pytest.mark.parametrize(
    ("source", "line"),
    [
        (ROM_TABLE + ROM_IN_MAIN + ROM_LOOP, 5),
        (ROM_TABLE + "static scamp5_kernel rom(table, 2);\nint main() {\n" + ROM_LOOP, 3),
    ],
    ids=["in-main", "file-scope"],
)
def test_a_rom_kernel_compiles_and_stops_where_it_is_built(cxx, tmp_path, source, line):
    path = tmp_path / "rom.cpp"
    path.write_text("#include <scamp5.hpp>\n" + source)
    with pytest.raises(PpalocError) as err:
        run_program(path, FRAMES, out=tmp_path / "out")
    message = str(err.value)
    assert message.startswith(
        f"rom.cpp:{line}: scamp5_kernel(icw, n): ROM kernels (precompiled ICW words) are not "
        "modelled; record the kernel with scamp5_kernel_begin()/scamp5_kernel_end() or from a "
        "lambda"
    )
    assert message.endswith("or run raw ICW words with vs_scamp5_execute_icw")
    assert "\n" not in message
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("shape", [(64, 32), (32, 64), (300, 300)])
def test_frames_not_square_or_larger_than_the_device_are_refused(faults, shape):
    # the array took their shape: a program's hardware addresses (8-bit, 0..255) then
    # failed mid-run (select_col(5) of a 300-wide array: "c=294 is out of range")
    with pytest.raises(PpalocError) as err:
        run_program(FAULTS, [np.zeros(shape, np.uint8)])
    assert str(err.value).startswith(
        f"the frames are {shape[0]} x {shape[1]}: the array a device program runs on is "
        "square and at most 256 x 256"
    )


def test_a_program_that_prints_without_end_is_kept_within_a_bound(cxx, tmp_path, monkeypatch):
    # its output went to temporary files read back whole: a printf in a loop that never
    # ended wrote gigabytes before the timeout (6.5 GB resident after a 10 s timeout), now
    # the first MAX_OUTPUT_BYTES of stdout are kept, and the first and last of stderr
    from ppaloc.cpp import capture

    monkeypatch.setattr(capture, "MAX_OUTPUT_BYTES", 1000)
    source = tmp_path / "chatty.cpp"
    source.write_text(
        "#include <scamp5.hpp>\n#include <cstdio>\n"
        "int main() {\n    vs_init();\n    vs_frame_loop_control();\n"
        '    for (int i = 0; i < 100000; i++) printf("line %06d\\n", i);\n'
        '    for (int i = 0; i < 100000; i++) fprintf(stderr, "noise %06d\\n", i);\n'
        '    fprintf(stderr, "the last words\\n");\n    return 3;\n}\n'
    )
    with pytest.raises(PpalocError) as err:
        run_program(source, FRAMES, timeout=60)
    assert str(err.value) == "chatty.cpp exited with status 3 in frame 0: the last words"
    source.write_text(source.read_text().replace("return 3;", "return 0;"))
    result = run_program(source, FRAMES, timeout=60)
    printed = "".join(f"line {i:06d}\n" for i in range(100000))  # 1,200,000 bytes
    assert result.stdout == (
        printed[:1000] + "\n[ppaloc: 1199000 more bytes of standard output not kept: a run "
        "keeps the first 1000 bytes]\n"
    )
    assert result.session.warnings == [
        "chatty.cpp printed 1200000 bytes to standard output; stdout.txt keeps the first 1000"
    ]


def test_a_capture_stops_at_its_deadline_while_a_writer_holds_the_pipe():
    # a process the program leaves running keeps its standard output open: the captures
    # waited for each pipe to close, 5 s each, one after the other, and their threads and
    # pipes stayed until the process ended; now they stop together at one deadline
    import os

    from ppaloc.cpp.capture import Capture, finish_all

    pipes = [os.pipe(), os.pipe()]
    captures = (Capture(pipes[0][0]), Capture(pipes[1][0], tail=True))
    os.write(pipes[0][1], b"the parent ends\n")
    try:
        finish_all(captures, wait=0.2)
        assert captures[0].head == b"the parent ends\n"
        assert not any(c._thread.is_alive() for c in captures)
        for read_end, _ in pipes:
            with pytest.raises(OSError):
                os.fstat(read_end)  # closed by the capture
    finally:
        for _, write_end in pipes:
            os.close(write_end)


def test_an_empty_cxx_is_unset_and_a_missing_one_is_named(tmp_path, capsys, monkeypatch):
    # CXX= (set, empty) said "no C++ compiler found (g++)" where g++ is installed, and
    # CXX=/nonexistent was blamed on g++ too
    import shutil

    from ppaloc.cpp.build import compiler

    monkeypatch.setenv("CXX", "")
    assert compiler() == shutil.which("g++")
    monkeypatch.setenv("CXX", "/nonexistent/c++")
    source = tmp_path / "p.cpp"
    source.write_text("int main() { return 0; }\n")
    assert main(["cpp", "run", str(source), "--out", str(tmp_path / "run"), "-q"]) == 1
    assert capsys.readouterr().err == (
        "ppaloc: error: $CXX='/nonexistent/c++' is not a program found on PATH; set CXX to a "
        "C++ compiler (g++, clang++, or its full path) or unset it to use g++\n"
    )
