"""The spec parser: grammar, typing, messages; fuzzed to raise only DatasetSpecError."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.datasets import parse_dataset_spec
from ppaloc.errors import DatasetSpecError


def test_synthetic_spec_types_and_defaults():
    spec = parse_dataset_spec("synthetic:?places=120&query=night&seed=7&sync=1&spacing=2.5")
    assert spec.kind == "synthetic"
    assert spec.paths == ()
    assert spec.options["places"] == 120
    assert spec.options["query"] == "night"
    assert spec.options["ref"] == "summer"  # default filled in
    assert spec.options["sync"] is True
    assert spec.options["spacing"] == 2.5
    assert spec.options["step"] == 1
    assert spec.given == {"places", "query", "seed", "sync", "spacing"}


def test_bare_kind_and_two_paths():
    assert parse_dataset_spec("synthetic").kind == "synthetic"
    spec = parse_dataset_spec("FOLDER:a/ref, b/query?tolerance=2&start=3&stop=9&step=2")
    assert spec.kind == "folder"
    assert spec.paths == (Path("a/ref"), Path("b/query"))
    assert (spec.options["tolerance"], spec.options["start"], spec.options["stop"]) == (2, 3, 9)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "empty dataset spec"),
        ("hello", "has no kind"),
        ("nordland", "kind 'nordland' takes 1 path(s), got 0; e.g. nordland:"),
        ("mars:data", "unknown dataset kind 'mars'"),
        ("folder:only_one", "takes 2 path(s), got 1"),
        ("folder:a,", "empty path"),
        ("nordland:d?colour=red", "unknown key 'colour' for kind 'nordland'; valid keys:"),
        ("nordland:d?ref=summer&ref=winter", "key 'ref' is given twice"),
        ("nordland:d?ref=moon", "key 'ref' must be one of spring, summer, fall, winter"),
        ("synthetic:?places=many", "key 'places' must be an integer in [2, 1000000], got 'many'"),
        ("synthetic:?places=1", "key 'places' must be an integer in [2, 1000000]"),
        ("synthetic:?spacing=nan", "key 'spacing' must be a finite number in [0.5, 100]"),
        ("synthetic:?sync=maybe", "key 'sync' must be 1 or 0"),
        ("synthetic:?step=0", "key 'step' must be an integer >= 1"),
        ("synthetic:?places", "'places' is not key=value"),
        ("synthetic:?start=5&stop=5", "stop=5 must be greater than start=5"),
    ],
)
def test_malformed_specs_name_the_problem(text, message):
    with pytest.raises(DatasetSpecError) as info:
        parse_dataset_spec(text)
    assert message in str(info.value)


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=60))
def test_fuzz_parser_only_raises_spec_errors(text):
    try:
        spec = parse_dataset_spec(text)
    except DatasetSpecError:
        return
    assert spec.kind in {
        "folder", "nordland", "gardens-point", "vprbench", "citycentre", "video", "synthetic"
    }  # fmt: skip


_KEYS = st.fixed_dictionaries(
    {},
    optional={
        "places": st.integers(2, 10**6),
        "seed": st.integers(0, 2**31),
        "tolerance": st.integers(0, 50),
        "step": st.integers(1, 9),
        "query": st.sampled_from(["summer", "autumn", "winter", "night"]),
        "sync": st.booleans(),
        "spacing": st.floats(0.5, 100, allow_nan=False),
    },
)


@settings(max_examples=200, deadline=None)
@given(_KEYS, st.sampled_from(["synthetic:", "synthetic:?", "Synthetic : "]))
def test_fuzz_written_values_read_back(values, head):
    def fmt(v):
        return str(int(v)) if isinstance(v, bool) else repr(v) if isinstance(v, float) else str(v)

    query = "&".join(f"{k}={fmt(v)}" for k, v in values.items())
    text = head.rstrip("?") + ("?" + query if query else "")
    spec = parse_dataset_spec(text)
    for k, v in values.items():
        assert spec.options[k] == v
    assert spec.given == set(values)
