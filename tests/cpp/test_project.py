"""Programs of several files: sources, include folders, defines, and where errors are named."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from ppaloc.cli.main import cli
from ppaloc.cpp import UnmodelledCallError, run_program
from ppaloc.cpp.build import check_project
from ppaloc.cpp.project import make_project, parse_define, project_headers
from ppaloc.errors import PpalocError

MAIN = """#include <scamp5.hpp>
#include "scale.hpp"
int main() {
    vs_init();
    while (1) {
        vs_frame_loop_control();
        vs_post_text("scaled %d", scaled(3));
    }
}
"""
HEADER = """#pragma once
#ifndef GAIN
#define GAIN 1
#endif
int scaled(int v);  // extra.cpp
"""
EXTRA = """#include <scamp5.hpp>
#include "scale.hpp"
int scaled(int v) {
    return v * GAIN;
}
"""


def _project(root: Path, extra: str = EXTRA, header: str = HEADER) -> tuple[Path, Path, Path]:
    (root / "inc").mkdir(parents=True, exist_ok=True)
    (root / "inc" / "scale.hpp").write_text(header)
    (root / "main.cpp").write_text(MAIN)
    (root / "extra.cpp").write_text(extra)
    return root / "main.cpp", root / "extra.cpp", root / "inc"


FRAME = [np.zeros((16, 16), np.uint8)]


def test_two_sources_an_include_folder_and_a_define(cxx, tmp_path):
    main, extra, inc = _project(tmp_path)
    plain = run_program([main, extra], FRAME, include_dirs=[inc])
    assert plain.texts == ["scaled 3"]
    assert plain.session.program == "main.cpp"
    out = tmp_path / "run"
    defined = run_program([main, extra], FRAME, include_dirs=[inc], defines=["GAIN=5"], out=out)
    assert defined.texts == ["scaled 15"]  # a define is part of the build's key
    summary = json.loads((out / "summary.json").read_text())
    assert summary["sources"] == [str(main), str(extra)]
    assert (summary["include_dirs"], summary["defines"]) == ([str(inc)], ["GAIN=5"])


@pytest.mark.parametrize("flags", [["-D", "GAIN=7"], ["-DGAIN=7"], ["--define", "GAIN=7"]])
def test_the_cli_takes_sources_include_folders_and_defines(cxx, tmp_path, flags, capsys):
    main, extra, inc = _project(tmp_path)
    args = ["cpp", "run", str(main), str(extra), "-I", str(inc), *flags, "--frames", "1"]
    cli.main([*args, "--out", str(tmp_path / "run")], standalone_mode=False)
    assert "scaled 21" in capsys.readouterr().out


def test_a_define_without_a_value(cxx, tmp_path):
    header = HEADER.replace(
        "#ifndef GAIN\n#define GAIN 1", "#ifdef TWICE\n#define GAIN 2\n#else\n#define GAIN 1"
    )
    main, extra, inc = _project(tmp_path, header=header)
    assert run_program([main, extra], FRAME, include_dirs=[inc], defines=["TWICE"]).texts == [
        "scaled 6"
    ]


def test_a_changed_header_builds_again(cxx, tmp_path):
    main, extra, inc = _project(tmp_path)
    assert run_program([main, extra], FRAME, include_dirs=[inc]).texts == ["scaled 3"]
    (inc / "scale.hpp").write_text(HEADER.replace("#define GAIN 1", "#define GAIN 4"))
    assert run_program([main, extra], FRAME, include_dirs=[inc]).texts == ["scaled 12"]


def test_bytes_that_are_not_utf8_in_a_source_its_name_or_a_define_are_the_program(cxx, tmp_path):
    # the build's cache key read a source as UTF-8 with such bytes replaced, so two sources
    # that differ in them only ran the program built first; a source named in them (a
    # Latin-1 file name) or a -D value of them failed the key: an internal error
    import os

    program = (
        b"#include <scamp5.hpp>\nint main() {\n    vs_init();\n    vs_frame_loop_control();\n"
        b'    const char *s = "\xe9";\n    vs_post_text("%d %d", (unsigned char)s[0], VALUE);\n'
        b"    return 0;\n}\n"
    )
    source = tmp_path / "prog.cpp"
    source.write_bytes(program)
    assert run_program(source, FRAME, defines=["VALUE=1"]).texts == ["233 1"]
    source.write_bytes(program.replace(b'"\xe9"', b'"\xe8"'))
    assert run_program(source, FRAME, defines=["VALUE=1"]).texts == ["232 1"]
    named = Path(os.fsdecode(os.path.join(os.fsencode(tmp_path), b"caf\xe9.cpp")))
    named.write_bytes(program)
    assert run_program(named, FRAME, defines=["VALUE=1"]).texts == ["233 1"]
    value = 'VALUE=sizeof("\udce9")'  # a -D value of a Latin-1 byte, as argv gives it
    assert run_program(source, FRAME, defines=[value]).texts == ["232 2"]


def test_an_error_in_the_second_file_names_it(cxx, tmp_path):
    extra = EXTRA.replace("    return v * GAIN;", "    scamp5_output_image(A, 99);\n    return v;")
    extra = extra.replace(
        "#include <scamp5.hpp>", "#include <scamp5.hpp>\nusing namespace SCAMP5_PE;"
    )
    main, extra_cpp, inc = _project(tmp_path, extra=extra)
    with pytest.raises(PpalocError, match=r"^extra\.cpp:5: display handle 99 was not created"):
        run_program([main, extra_cpp], FRAME, include_dirs=[inc])


def test_an_error_in_a_header_kernel_names_the_header(cxx, tmp_path):
    header = HEADER + (
        "#include <scamp5.hpp>\n"
        "inline void bad() {\n"
        "    using namespace SCAMP5_PE;\n"
        "    scamp5_kernel_begin();\n"
        "        sub(A, B, A);\n"
        "    scamp5_kernel_end();\n"
        "}\n"
    )
    extra = EXTRA.replace("    return v * GAIN;", "    bad();\n    return v;")
    main, extra_cpp, inc = _project(tmp_path, extra=extra, header=header)
    with pytest.raises(PpalocError, match=r"^scale\.hpp:10: in sub\(A, B, A\): "):
        run_program([main, extra_cpp], FRAME, include_dirs=[inc])


def test_the_scan_covers_every_source_and_included_header(tmp_path):
    main, extra, inc = _project(tmp_path, header=HEADER + "inline void f() { vs_nope(); }\n")
    project = make_project([main, extra], [inc])
    assert project_headers(project) == [inc / "scale.hpp"]
    with pytest.raises(UnmodelledCallError, match=r"^\S*scale\.hpp:6: vs_nope is a SCAMP-5d"):
        check_project(project)
    (inc / "scale.hpp").write_text(HEADER)
    extra.write_text(EXTRA + "void g() {\n  aout(A);\n}\n")
    with pytest.raises(UnmodelledCallError, match=r"^\S*extra\.cpp:7: aout is a SCAMP-5d"):
        check_project(make_project([main, extra], [inc]))
    # a helper defined in one file and called in another is the program's own
    extra.write_text(EXTRA + "int vs_helper(int x) { return x; }\n")
    main.write_text(MAIN.replace("scaled(3)", "vs_helper(3)"))
    check_project(make_project([main, extra], [inc]))


def test_every_new_input_is_checked_in_one_line(tmp_path):
    main, extra, inc = _project(tmp_path)
    cases = {
        "does not exist": ([main, tmp_path / "gone.cpp"], [], []),
        "is a folder, not a C++ source: give its .cpp files": ([main, inc], [], []),
        "is given twice": ([main, main], [], []),
        "the include folder does not exist": ([main], [tmp_path / "nope"], []),
        "the include folder is a file": ([main], [extra], []),
        "must be NAME or NAME=VALUE": ([main], [], ["2X=1"]),
    }
    for message, (sources, dirs, defines) in cases.items():
        with pytest.raises(PpalocError, match=re.escape(message)) as err:
            run_program(sources, FRAME, include_dirs=dirs, defines=defines, out=tmp_path / "o")
        assert "\n" not in str(err.value)
    assert not (tmp_path / "o").exists()


def test_a_pipe_for_a_source_or_a_header_is_refused_not_waited_on(tmp_path):
    # the compiler would block on a FIFO for ever (no --timeout covers the build)
    import os

    fifo = tmp_path / "piped.cpp"
    os.mkfifo(fifo)
    with pytest.raises(PpalocError, match=r"piped.cpp is not a regular file \(a pipe, device"):
        run_program([fifo], FRAME, out=tmp_path / "o")
    (tmp_path / "inc").mkdir()
    os.mkfifo(tmp_path / "inc" / "h.hpp")
    main = tmp_path / "main.cpp"
    main.write_text('#include <scamp5.hpp>\n#include "h.hpp"\nint main() {}\n')
    with pytest.raises(PpalocError, match=r'#include "h.hpp" names .*inc/h.hpp, which is not a re'):
        run_program([main], FRAME, include_dirs=[tmp_path / "inc"], out=tmp_path / "o")
    assert not (tmp_path / "o").exists()


def test_parse_define():
    assert parse_define("A=") == "A="
    assert parse_define("_x1=a b") == "_x1=a b"
    for bad in ("", "=1", "A-B=1", "A=1\n2", "A B"):
        with pytest.raises(PpalocError, match=r"^-D .* must be NAME or NAME=VALUE"):
            parse_define(bad)


def test_a_bad_access_in_the_second_file_is_placed_there(cxx, tmp_path):
    extra = EXTRA.replace(
        "    return v * GAIN;", "    volatile int buf[4];\n    buf[v + 1] = 1;\n    return buf[0];"
    )
    main, extra_cpp, inc = _project(tmp_path, extra=extra)
    with pytest.raises(PpalocError, match=r"stack-buffer-overflow .* at extra\.cpp:5$"):
        run_program([main, extra_cpp], FRAME, include_dirs=[inc])


def test_the_vendor_header_in_an_include_folder_is_not_scanned(tmp_path):
    main, extra, inc = _project(tmp_path)
    (inc / "scamp5.hpp").write_text("void vs_vendor_only() { scamp5_vendor(); }\n")
    project = make_project([main, extra], [inc])
    check_project(project)  # <scamp5.hpp> is the shim's, searched first
    assert project_headers(project) == [inc / "scamp5.hpp", inc / "scale.hpp"]  # unshadowed


def test_a_scamp7_program_is_named_as_one_before_compiling(tmp_path):
    # it failed to compile with "fatal error: scamp7.hpp: No such file or directory"
    source = tmp_path / "s7.cpp"
    source.write_text("// SCAMP-7\n#include <scamp7.hpp>\nusing namespace SCAMP7_PE;\n")
    with pytest.raises(PpalocError) as err:
        check_project(make_project([source]))
    assert str(err.value) == (
        f"{source}:2: #include <scamp7.hpp> is the SCAMP-7 device header: ppaloc simulates "
        "the SCAMP-5d and runs its programs (#include <scamp5.hpp>); a SCAMP-7 program is "
        "not supported"
    )
    (tmp_path / "scamp7.hpp").write_text("#pragma once\n")  # a header of its own: its own
    check_project(make_project([source], [tmp_path]))


def test_the_cli_refuses_bad_inputs_in_one_line(tmp_path, capsys):
    from ppaloc.cli.main import main

    source, _, inc = _project(tmp_path)
    out = str(tmp_path / "run")
    for args, message in [
        ([str(inc)], f"{inc} is a folder, not a C++ source"),
        ([str(source), "-I", str(source)], "the include folder is a file"),
        ([str(source), "-D", "A B"], "-D 'A B' must be NAME or NAME=VALUE"),
        ([str(source), "--stream-format", "v4l2"], "--stream-format v4l2 needs --stream INPUT"),
    ]:
        assert main(["cpp", "run", *args, "--out", out]) == 1
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err, err
