"""ppaloc.cpp.coverage: the declared scamp5_*/vs_* names of a header folder, split by
whether the shim has them (hand-written headers, a few lines each)."""

from __future__ import annotations

import pytest

from ppaloc.cpp.coverage import HeaderFolderError, coverage, declared_names, shim_names

MAIN = """\
#ifndef VS_MAIN_HPP
#define VS_MAIN_HPP
#include <vs_extra.h>
#include <stdio.h>
/* vs_in_a_comment(int x); */
#define VS_LED_0 0
#define vs_on_host_connect vs_on_gui_connect
namespace vs_sim { void config(); }
struct vs_vec_xy_t { int x; };
typedef unsigned int vs_handle;
enum vs_mode { VS_MODE_A, VS_MODE_B = 4 };
void vs_led_on(int idx);
vs_handle vs_gui_set_lineplot(vs_handle h, int min);
vs_io_agent_api*scamp5_get_io_agent();
inline int twice(int x) { return vs_not_declared(x); }
#ifdef VS_M0_PRIVATE
void vs_private_thing();
#endif
#endif
"""


@pytest.fixture
def folders(tmp_path):
    own, shared = tmp_path / "device", tmp_path / "shared"
    own.mkdir()
    shared.mkdir()
    (own / "vs_main.hpp").write_text(MAIN)
    (shared / "vs_extra.h").write_text("extern int vs_extra_count;\n")
    (shared / "vs_unreached.h").write_text("void vs_unreached();\n")
    return [own, shared]


def test_declared_names_follow_includes_and_skip_guards_comments_calls_and_private(folders):
    assert declared_names(folders) == {
        name: "vs_main.hpp"
        for name in (
            "VS_LED_0", "vs_on_host_connect", "vs_sim", "vs_vec_xy_t", "vs_handle", "vs_mode",
            "VS_MODE_A", "VS_MODE_B", "vs_led_on", "vs_gui_set_lineplot",
            "scamp5_get_io_agent",  # a pointer type with no space before the name
        )
    } | {"vs_extra_count": "vs_extra.h"}  # fmt: skip


def test_coverage_splits_by_the_shim(folders):
    c = coverage(folders)
    # the shim has these eight; not the enum or a variable of its own
    assert c.covered == ["VS_LED_0", "scamp5_get_io_agent", "vs_gui_set_lineplot", "vs_handle",
                         "vs_led_on", "vs_on_host_connect", "vs_sim", "vs_vec_xy_t"]  # fmt: skip
    assert c.missing == ["VS_MODE_A", "VS_MODE_B", "vs_extra_count", "vs_mode"]
    assert c.summary() == "8 / 12 declared scamp5_*/vs_* names covered (67%)"


def test_shim_names_leave_out_its_comments_and_strings():
    names = shim_names()
    assert {"vs_led_on", "scamp5_get_image", "SCAMP5_CLOCK_ANALOG", "mov"} <= names
    assert "vs_host_event" not in names  # only the name of a message, in a string


def test_a_bad_folder_is_one_line(tmp_path):
    with pytest.raises(HeaderFolderError, match=r"nope: no such folder; give the device's"):
        coverage([tmp_path / "nope"])
    with pytest.raises(HeaderFolderError, match=r": holds no C or C\+\+ header \(\.h, \.hpp"):
        coverage([tmp_path])
    (tmp_path / "other.h").write_text("int x;\n")
    with pytest.raises(HeaderFolderError, match=r"declare no scamp5_\*/vs_\* name; give"):
        coverage([tmp_path])
