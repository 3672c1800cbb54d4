"""Fuzzing the configuration paths: any TOML file and any ``--param`` value ends in exit 0 or
1 with at most one line on stderr, never a traceback (exit 3) or a hang.

The commands' work is replaced by a recorder, so an input that happens to be valid costs
nothing; what is tested is everything before the work: parsing, merging and checking.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ppaloc.cli import main
from ppaloc.methods import METHODS

TINY = "synthetic:?places=12&size=32&sync=1&seed=2"
KEYS = [
    "dataset", "methods", "tolerance", "recall", "seed", "record_weights", "max_weight_values",
    "params", "out", "no_report", "quiet", "sizes", "queries", "warmup", "max_build_s",
    "method",
]  # fmt: skip
PARAM_KEYS = [
    "alpha", "gain", "gamma", "k", "ds", "size", "seed", "top_k", "radius", "mode",
    "n_particles", "length", "levels", "memory", "max_advance", "noise", "patch", "vmin",
]  # fmt: skip


def _toml_string(s: str) -> str:
    return (
        '"' + "".join(c if c.isalnum() or c in " .:?=&-_/" else f"\\u{ord(c):04x}" for c in s) + '"'
    )


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return (
            "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
        )
    if isinstance(v, str):
        return _toml_string(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return "{" + ", ".join(f"{_toml_string(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"


scalars = st.one_of(
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.sampled_from([0, 1, -1, 2, 8, 500, 501, 10**6, 2**63]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
    st.sampled_from(["", TINY, "synthetic:?places=1e9", "single-frame", "seqslam", "x", "A"]),
)
values = st.recursive(
    scalars,
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=6,
)
param_tables = st.dictionaries(
    st.sampled_from([*list(METHODS), "no-such"]),
    st.dictionaries(st.sampled_from(PARAM_KEYS), values, max_size=3),
    max_size=2,
)


def _document(top: dict, params: dict, section: str) -> str:
    lines = [f"{k} = {_toml_value(v)}" for k, v in top.items()]
    for method, table in params.items():
        lines.append(f"[{section}{method}]")
        lines += [f"{k} = {_toml_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


@pytest.fixture
def recorder(monkeypatch):
    """Replace the commands' work by a no-op: only the checks before it run."""
    import ppaloc.cli.commands as commands
    import ppaloc.datasets.registry as registry
    from ppaloc.errors import PpalocError

    calls = []
    for name in ("run_evaluate", "run_matrix", "run_bench", "run_localise"):
        monkeypatch.setattr(commands, name, lambda *a, _n=name, **k: calls.append(_n))

    def no_dataset(spec):  # run_map builds its localiser (checks its params) before this
        calls.append("load_dataset")
        raise PpalocError("stop")

    monkeypatch.setattr(registry, "load_dataset", no_dataset)
    return calls


def _assert_clean(code: int, err: str) -> None:
    assert code in (0, 1), err
    assert "internal error" not in err and "Traceback" not in err, err
    assert err.count("\n") <= 1, err


FUZZ = settings(
    max_examples=120,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@FUZZ
@given(
    top=st.dictionaries(st.sampled_from(KEYS), values, max_size=5),
    params=param_tables,
    command=st.sampled_from(["evaluate", "bench", "map"]),
)
def test_any_toml_file_exits_0_or_1(tmp_path, monkeypatch, capsys, recorder, top, params, command):
    monkeypatch.chdir(tmp_path)
    section = "params."
    if command == "map":
        params = {"": next(iter(params.values()), {})}  # one method's table
        text = _document({}, {}, "") + "[map]\n" + _document(top, {}, "")
        text += "[map.params]\n" + "\n".join(
            f"{k} = {_toml_value(v)}" for k, v in params[""].items()
        )
        argv = ["map", TINY, "--config", "c.toml"]
    else:
        text = _document(top, params, section)
        argv = [command, "--config", "c.toml"]
    Path("c.toml").write_text(text + "\n")
    code = main(argv)
    _assert_clean(code, capsys.readouterr().err)


param_text = st.one_of(
    st.text(max_size=20),
    st.builds(
        lambda k, v: f"{k}={v}",
        st.sampled_from(PARAM_KEYS),
        st.one_of(st.text(max_size=10), values.map(_toml_value)),
    ),
)


@FUZZ
@given(
    method=st.sampled_from(list(METHODS)),
    items=st.lists(param_text, min_size=1, max_size=3),
    command=st.sampled_from(["evaluate", "bench", "map", "localise"]),
)
def test_any_param_flag_exits_0_or_1(
    tmp_path, monkeypatch, capsys, recorder, method, items, command
):
    monkeypatch.chdir(tmp_path)
    flags = []
    for item in items:
        flags += ["--param", item if command in ("map", "localise") else f"{method}.{item}"]
    if command == "evaluate":
        argv = ["evaluate", "-d", TINY, "-m", method, *flags, "--out", "r"]
    elif command == "bench":
        argv = ["bench", "-m", method, "--sizes", "8", *flags]
    elif command == "map":
        argv = ["map", TINY, "-m", method, *flags, "--out", "m.npz"]
    else:
        argv = ["localise", "m.npz", "f.png", "-m", method, *flags]
    code = main(argv)
    _assert_clean(code, capsys.readouterr().err)
