"""Hostile dataset specs: every bad key value is one ``DataError`` naming the key and range.

Each case must be refused before any frame is rendered or read (fast, no hang).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.datasets import KINDS, load_dataset, parse_dataset_spec
from ppaloc.errors import DataError

CASES = [
    # synthetic: type, range and the documented maxima
    ("synthetic:?places=10&offset=1e308", "key 'offset' must be a number in [-20, 20]"),
    ("synthetic:?places=10&offset=-inf", "key 'offset' must be a finite number"),
    ("synthetic:?places=10&offset=nan", "key 'offset' must be a finite number"),
    ("synthetic:?size=99999999999999999999", "key 'size' must be an integer in [16, 1024]"),
    ("synthetic:?size=100000", "key 'size' must be an integer in [16, 1024]"),
    ("synthetic:?size=15", "key 'size' must be an integer in [16, 1024]"),
    ("synthetic:?size=-5", "key 'size' must be an integer in [16, 1024]"),
    ("synthetic:?size=64.5", "key 'size' must be an integer"),
    ("synthetic:?size=", "key 'size' must be an integer"),
    ("synthetic:?spacing=1e308", "key 'spacing' must be a number in [0.5, 100]"),
    ("synthetic:?spacing=0", "key 'spacing' must be a number in [0.5, 100]"),
    ("synthetic:?spacing=inf", "key 'spacing' must be a finite number"),
    ("synthetic:?extra=1000000000", "key 'extra' must be an integer in [0, 1000000]"),
    ("synthetic:?places=20&extra=21", "extra=21 must be an integer in [0, 20 = places]"),
    ("synthetic:?extra=-1", "key 'extra' must be an integer in [0, 1000000]"),
    ("synthetic:?places=1e30", "key 'places' must be an integer in [2, 1000000]"),
    ("synthetic:?places=1000001", "key 'places' must be an integer in [2, 1000000]"),
    ("synthetic:?places=0", "key 'places' must be an integer in [2, 1000000]"),
    ("synthetic:?places=-3", "key 'places' must be an integer in [2, 1000000]"),
    ("synthetic:?places=" + "9" * 5000, "key 'places' must be an integer"),
    ("synthetic:?places=１２", "key 'places' must be an integer"),
    ("synthetic:?places=2_0", "key 'places' must be an integer"),
    ("synthetic:?places=0x14", "key 'places' must be an integer"),
    ("synthetic:?places=1e3", "key 'places' must be an integer"),
    ("synthetic:?spacing=0x1p3", "key 'spacing' must be a number"),
    ("synthetic:?spacing=1_0.0", "key 'spacing' must be a number"),
    ("synthetic:?spacing=1e-320", "key 'spacing' must be a number in [0.5, 100]"),
    ("synthetic:?places=20&stops=100000", "stops=100000 must be an integer in [0, 20 = places]"),
    ("synthetic:?stops=-1", "key 'stops' must be an integer"),
    ("synthetic:?speed=1e300", "key 'speed' must be a number in [0.05, 10]"),
    ("synthetic:?speed=0", "key 'speed' must be a number in [0.05, 10]"),
    ("synthetic:?speed=-1", "key 'speed' must be a number in [0.05, 10]"),
    ("synthetic:?speed_var=2", "key 'speed_var' must be a number in [0, 0.9]"),
    ("synthetic:?seed=-1", "key 'seed' must be an integer"),
    ("synthetic:?seed=100000000000000000000000", "key 'seed' must be an integer in [0, "),
    ("synthetic:?turns=-1", "key 'turns' must be an integer"),
    ("synthetic:?places=20&turns=6", "turns=6: a route of 20 places takes 0 to"),
    ("synthetic:?world=moon", "key 'world' must be one of road, lab"),
    ("synthetic:?sync=yesplease", "key 'sync' must be 1 or 0"),
    ("synthetic:?query=", "key 'query' must be one of"),
    (
        "synthetic:?places=1000000&spacing=100",
        "is longer than the generator's 4000000 m",
    ),
    ("synthetic:?places=1000000&speed=0.05", "the query would need about"),
    ("synthetic:?places=28000&world=lab", "more than the generator's 30000000 turn-places"),
    ("synthetic:?places=25000&turns=6000", "at most 1200 turns on this route"),
    # the keys every kind takes
    ("synthetic:?tolerance=1000000000000", "key 'tolerance' must be an integer in [0, 1000]"),
    ("synthetic:?tolerance=-1", "key 'tolerance' must be an integer in [0, 1000]"),
    ("synthetic:?start=100000000000000000000000", "key 'start' must be an integer in [0, "),
    ("synthetic:?step=100000000000000000000000", "key 'step' must be an integer in [1, "),
    ("synthetic:?step=0", "key 'step' must be an integer >= 1"),
    ("synthetic:?patch_norm=100000", "key 'patch_norm' must be an integer in [2, 4096]"),
    ("synthetic:?patch_norm=1", "key 'patch_norm' must be an integer in [2, 4096]"),
    ("synthetic:?places=20&start=30", "keeps none of the 20 reference frames"),
    ("synthetic:?start=5&stop=2", "stop=2 must be greater than start=5"),
    # the spec string itself
    ("", "empty dataset spec"),
    ("   ", "empty dataset spec"),
    # not a str: was called empty
    (Path("synthetic"), "a dataset spec is a str, got PosixPath('synthetic')"),
    (b"synthetic:", "a dataset spec is a str, got b'synthetic:'"),
    (5, "a dataset spec is a str, got 5"),
    ("synthetic:?places=10&places=20", "key 'places' is given twice"),
    ("synthetic:?placez=10", "unknown key 'placez'"),
    ("synthetic:?places", "'places' is not key=value"),
    ("synthetic:?=3", "'=3' is not key=value"),
    ("moon:somewhere", "unknown dataset kind 'moon'"),
    ("folder:a\0b,c", "holds a NUL character"),
    ("folder:" + "a" * 20000 + ",b", "is too long"),
    ("folder:onlyone", "takes 2 path(s), got 1"),
    ("folder:a,", "has an empty path"),
    ("nordland:d?dark=300", "key 'dark' must be a number in [0, 255]"),
    ("vprbench:d?gt=" + "x" * 5000, "key 'gt' must be text of at most 4096 characters"),
    ("citycentre:d?split=0", "key 'split' must be an integer"),
    ("gardens-point:d?trust=maybe", "key 'trust' must be 1 or 0"),
]


@pytest.mark.parametrize(("spec", "fragment"), CASES, ids=[str(c[0])[:60] for c in CASES])
def test_hostile_spec_is_one_line_error(spec: str, fragment: str) -> None:
    with pytest.raises(DataError) as info:
        load_dataset(spec)
    message = str(info.value)
    assert fragment in message
    assert "\n" not in message
    assert len(message) < 600  # a huge value is not echoed back in full


def test_largest_accepted_values_load_lazily() -> None:
    # the bounds themselves are accepted, and a spec at them is quick (frames render lazily)
    ds = load_dataset("synthetic:?places=40&size=1024&stops=40&extra=40&spacing=100&speed=10")
    assert len(ds.reference) == 40
    assert load_dataset("synthetic:?places=20&seed=9223372036854775807&sync=1").query


_KEYS = ["places", "size", "spacing", "speed", "stops", "extra", "offset", "seed", "turns"]
_VALUES = ["", "0", "-1", "1e308", "nan", "inf", "2_0", "0x10", "9" * 30, "１", "x", "20", "0.5"]


@settings(max_examples=200, deadline=None)
@given(
    st.one_of(
        st.text(max_size=60),
        st.lists(
            st.tuples(
                st.sampled_from(_KEYS) | st.text(max_size=6),
                st.sampled_from(_VALUES) | st.text(max_size=8),
            ),
            max_size=4,
        ).map(lambda kv: "synthetic:?" + "&".join(f"{k}={v}" for k, v in kv)),
    )
)
def test_any_spec_text_parses_or_is_one_dataset_spec_error(text: str) -> None:
    try:
        spec = parse_dataset_spec(text)
    except DataError as exc:
        assert "\n" not in str(exc) and len(str(exc)) < 1000
    else:
        assert spec.kind in KINDS


@pytest.mark.parametrize(
    ("spec", "fragment"),
    [
        ("folder:REF?step=0", "key 'step' must be an integer >= 1, got '0'"),
        ("folder:REF?stp=1", "unknown key 'stp' for kind 'folder'"),
        ("folder:REF,REF,REF", "kind 'folder' takes 1 or 2 path(s), got 3"),
        ("video:REF.mp4?start=-1", "key 'start'"),
    ],
)
def test_a_bad_reference_alone_spec_names_its_own_mistake(spec: str, fragment: str, tmp_path):
    """``folder:REF_DIR`` is valid for a map: its bad key is the error, not a missing path."""
    from ppaloc.datasets.registry import load_reference

    with pytest.raises(DataError) as info:
        load_reference(spec.replace("REF", str(tmp_path)))
    assert fragment in str(info.value) and "takes 2 path(s)" not in str(info.value)


@pytest.mark.parametrize(
    ("name", "keys", "whole"),
    [("a,b", "", "a,b"), ("c?d", "", "c?d"), ("c?d", "?tolerance=1", "c?d")],
)
def test_a_folder_named_with_a_comma_or_question_mark_is_named_whole(
    tmp_path, monkeypatch, name, keys, whole
):
    # refused as a missing folder 'a', or as a key 'd' without a value, while it was there
    from ppaloc.errors import DatasetSpecError

    monkeypatch.chdir(tmp_path)
    (tmp_path / name).mkdir()
    spec = f"folder:{name}{keys}"
    with pytest.raises(DatasetSpecError) as info:
        load_dataset(spec)
    assert str(info.value) == (
        f"dataset spec {spec!r}: {whole!r} is one path, but a spec reads ',' as the cut between "
        "two paths and '?' as the start of its keys, so no path in a spec can hold them; give a "
        "link to it whose name has neither"
    )
