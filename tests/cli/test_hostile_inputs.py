"""Hostile command lines and configuration files: each is one line naming the bad value and
what is accepted, exit 1, and is refused before any work (so every case is fast)."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np
import pytest

from ppaloc.cli import main

TINY = "synthetic:?places=12&size=32&sync=1&seed=2"
EV = ["evaluate", "-d", TINY, "-m", "single-frame", "--no-report", "-q"]
MAP = ["map", TINY, "-m", "single-frame", "-q"]
BASE_TOML = f'dataset = "{TINY}"\nmethods = ["single-frame"]\nno_report = true\n'

# (command line, config file text or None, fragment of the one-line message)
CASES: list[tuple[list[str], str | bytes | None, str]] = [
    # ground-truth moves are booleans, whatever the motion model
    (
        [*EV[:4], "weighted-node-lbp", "--param", "weighted-node-lbp.oracle_moves=nan"],
        None,
        "oracle_moves=nan must be a list of booleans",
    ),
    (
        [*MAP[:2], "-m", "weighted-node-lbp", "--param", "oracle_moves=1979-05-27", "--out", "m"],
        None,
        "oracle_moves=datetime.date(1979, 5, 27) must be a list of booleans",
    ),
    (
        [*EV[:4], "weighted-node-lbp", "--param", "weighted-node-lbp.oracle_moves=[2, 1]"],
        None,
        "oracle_moves=[2, 1] must be a list of booleans",
    ),
    (["cpp", "run", "p.cpp", "--timeout", "inf", "--out", "r"], None, "timeout=inf must be"),
    (["cpp", "run", "p.cpp", "--frames", "100000000", "--out", "r"], None, "must be in [1, 2000]"),
    (["cpp", "run", "p.cpp", "--host", "0.0.0.0", "--out", "r"], None, "--host is for the live"),
    (["cpp", "run", "p.cpp", "--live", "--port", "70000", "--out", "r"], None, "--port 70000 must"),
    # cpp run's paths are checked as every command's: '' was the current folder (-I '' ran)
    (["cpp", "run", "", "--out", "r"], None, "PROGRAM '' is empty"),
    (["cpp", "run", "p.cpp", "-I", "", "--out", "r"], None, "-I '' is empty"),
    (["cpp", "run", "p.cpp", "--image", "", "--out", "r"], None, "--image '' is empty"),
    (["cpp", "run", "p.cpp", "--image", "/tmp", "--out", "r"], None, "--image /tmp is a folder"),
    # flags
    ([*EV, "-m", "particle-filter", "--seed", "-1", "--out", "r"], None, "seed=-1 must be"),
    ([*EV, "--seed", "9" * 30, "--out", "r"], None, "seed=9999"),
    ([*EV, "--tolerance", "-1", "--out", "r"], None, "tolerance=-1 must be an integer in"),
    ([*EV, "--tolerance", "100000", "--out", "r"], None, "tolerance=100000 must be"),
    ([*EV, "--out", ""], None, "--out '' is empty"),
    ([*EV, "--out", " "], None, "--out ' ' is empty"),
    ([*EV, "--out", "x" * 5000], None, "at most 4096"),
    ([*EV, "--out", "/etc/passwd/x"], None, "lies under /etc/passwd, which is a file"),
    ([*EV, "--out", "n" * 300], None, "--out has a name of 300 bytes between slashes"),
    ([*MAP, "--out", "n" * 300 + ".npz"], None, "a name of 304 bytes between slashes"),
    (["localise", "m" * 300 + ".npz", "f.png"], None, "MAP_PATH has a name of 304 bytes"),
    (["localise", "m.npz", "f" * 300], None, "FRAMES has a name of 300 bytes"),
    (["evaluate", "-d", "folder:" + "a/" * 2100 + "x,b"], None, "File name too long"),
    (["evaluate", "-d", "nordland:" + "d" * 300], None, "a name of 300 bytes between slashes"),
    ([*EV, "--out", "/etc/passwd"], None, "--out /etc/passwd is a file"),
    ([*EV, "--out", "/proc/no-such/x"], None, "cannot write in /proc"),
    ([*MAP, "--out", ""], None, "--out '' is empty"),
    ([*MAP, "--out", "/tmp"], None, "--out /tmp is a folder"),
    ([*MAP, "--out", "/etc/passwd/m.npz"], None, "which is a file, not a folder"),
    ([*MAP, "--out", "m.npz", "--param", "top_k=x"], None, "top_k='x' must be an integer"),
    ([*MAP, "--out", "m.npz", "--param", "top_k=0"], None, "top_k=0 must be in [1, 10000]"),
    ([*MAP, "--out", "m.npz", "--param", "radius=nan"], None, "radius=nan must be an integer"),
    ([*MAP, "--out", "m.npz", "--param", "radius=inf"], None, "radius=inf must be an integer"),
    ([*MAP, "--out", "m.npz", "--param", "size=[0, 0]"], None, "size=[0, 0] must be in"),
    ([*MAP, "--out", "m.npz", "--param", "size=[32]"], None, "must be a list of 2 integers"),
    ([*MAP, "--out", "m.npz", "--param", "nosuch=1"], None, "unknown parameter 'nosuch'"),
    (
        ["map", TINY, "-m", "weighted-node-lbp", "-q", "--out", "m.npz", "--param", "x.gain=2"],
        None,
        "unknown parameter 'x.gain'; the parameters here are the method's own: give gain=...",
    ),
    ([*MAP, "--out", "m.npz", "--param", "=1"], None, "must look like KEY=VALUE"),
    ([*MAP, "--out", "m.npz", "--param", "top_k"], None, "must look like KEY=VALUE"),
    ([*MAP, "--out", "m.npz", "--param", "top_k=" + "[" * 3000], None, "must be an integer"),
    ([*MAP, "--out", "m.npz", "--param", "record_weights=2"], None, "must be true or false"),
    (
        ["map", TINY, "-m", "weighted-node-lbp", "--param", "alpha=8", "--out", "m.npz"],
        None,
        "alpha=8 is a parameter of preset 'paper'",
    ),
    (
        ["map", TINY, "-m", "weighted-node-paper-lbp", "--param", "alpha=x", "--out", "m.npz"],
        None,
        "alpha='x' must be a number",
    ),
    (
        ["map", TINY, "-m", "weighted-node-paper-lbp", "--param", "alpha=-1e308", "--out", "m"],
        None,
        "alpha=-1e+308 must be a number in [-1e+06, 1e+06]",
    ),
    ([*EV, "--param", "weighted-node-lbp.alpha=x", "--out", "r"], None, "alpha='x' must be"),
    ([*EV, "--param", "weighted-node-lbp.gain=99", "--out", "r"], None, "gain=99 must be in"),
    ([*EV, "--param", "seqslam.ds=100000", "--out", "r"], None, "ds=100000 must be in [0, 500]"),
    ([*EV, "--param", "seqslam.ds=-1", "--out", "r"], None, "ds=-1 must be in [0, 500]"),
    ([*EV, "--param", "seqslam.ds=1.5", "--out", "r"], None, "ds=1.5 must be an integer"),
    ([*EV, "--param", "seqslam.mode=x", "--out", "r"], None, "mode='x' must be one of"),
    ([*EV, "--param", "particle-filter.seed=-1", "--out", "r"], None, "seed=-1 must be in"),
    ([*EV, "--param", "particle-filter.n_particles=1e12", "--out", "r"], None, "must be an"),
    ([*EV, "--param", "able-m.length=100000", "--out", "r"], None, "length=100000 must be"),
    ([*EV, "--param", "no-such.alpha=1", "--out", "r"], None, "unknown method 'no-such'"),
    ([*EV, "--param", ".alpha=1", "--out", "r"], None, "must look like METHOD.KEY=VALUE"),
    (["bench", "-m", "single-frame", "--sizes", "100000000"], None, "must be an integer in"),
    (["bench", "-m", "single-frame", "--sizes", "1"], None, "sizes=1 must be an integer in"),
    (["bench", "-m", "single-frame", "--sizes", "-5"], None, "must be comma-separated"),
    (["bench", "-m", "single-frame", "--sizes", "8,x"], None, "must be comma-separated"),
    (["bench", "-m", "single-frame", "--sizes", ","], None, "must list 1 to 64 map sizes"),
    (["bench", "-m", "single-frame", "--sizes", "8", "--max-build-s", "nan"], None, "nan"),
    (["bench", "-m", "single-frame", "--sizes", "8", "--max-build-s", "-1"], None, "-1.0 must"),
    (["bench", "-m", "single-frame", "--sizes", "8", "--max-build-s", "inf"], None, "inf must"),
    (["bench", "-m", "single-frame", "--sizes", "8", "--queries", "0"], None, "queries=0"),
    (["bench", "-m", "single-frame", "--sizes", "8", "--seed", "-1"], None, "seed=-1"),
    (["bench", "-m", "single-frame", "--sizes", "8", "--out", ""], None, "--out '' is empty"),
    (["demo", "--out", "/etc/passwd/d"], None, "which is a file, not a folder"),
    (["demo", "--bench-sizes", "100000000", "--out", "d"], None, "sizes=100000000"),
    (["show", "nothing-here", "--out", ""], None, "--out '' is empty"),
    (["localise", "m.npz", "f.png", "--out", ""], None, "--out '' is empty"),
    (["localise", "", "f.png"], None, "MAP_PATH '' is empty"),
    (["evaluate", "--config", ""], None, "--config '' is empty"),
    (["evaluate", "--config", "/tmp"], None, "--config /tmp is a folder"),
    # configuration files
    (
        ["evaluate", "--config", "c.toml"],
        BASE_TOML + "out = 5",
        "out = 5 in c.toml must be a string",
    ),
    (["evaluate", "--config", "c.toml"], BASE_TOML + 'out = ""', "--out '' is empty"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + 'out = "a\\u0000b"', "holds a NUL"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + "out = []", "out = [] in c.toml must be"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + 'quiet = "yes"', "quiet = 'yes' in c.toml"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + "quiet = 1", "must be true or false"),
    (["evaluate", "--config", "c.toml", "-q"], BASE_TOML + 'quiet = "no"', "quiet = 'no'"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + 'tolerance = "2"', "must be an integer"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + "tolerance = nan", "must be an integer"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + "tolerance = 1e9", "must be an integer"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + "seed = -1", "seed=-1 in c.toml must be"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + "seed = true", "seed=True in c.toml"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + 'recall = "Z"', "recall='Z' must be"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + 'record_weights = "no"', "true or false"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + "max_weight_values = -5", "must be an"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + "params = 5", "params = 5 in c.toml"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + "params = {a = 1}", "table of tables"),
    (
        ["evaluate", "--config", "c.toml"],
        BASE_TOML + '[params.single-frame]\ntop_k = "x"',
        "top_k='x' must be an integer",
    ),
    (
        ["evaluate", "--config", "c.toml"],
        BASE_TOML + '[params.weighted-node-paper-lbp]\nalpha = "x"',
        "alpha='x' must be a number",
    ),
    (["evaluate", "--config", "c.toml"], BASE_TOML + "[params.nosuch]\na = 1", "'nosuch'"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + "evaluate = 5", "must be a table"),
    (["evaluate", "--config", "c.toml"], BASE_TOML + "sed = 1", "unknown configuration key 'sed'"),
    (["evaluate", "--config", "c.toml"], "dataset = []", "lists no dataset"),
    (["evaluate", "--config", "c.toml"], "dataset = [5]", "dataset=5 in c.toml must be"),
    (
        ["evaluate", "--config", "c.toml"],
        f'dataset = "{TINY}"\nmethods = 5',
        "must be a list of strings",
    ),
    (["evaluate", "--config", "c.toml"], 'dataset = "synthetic:?places=1e9"', "'places' must"),
    (["evaluate", "--config", "c.toml"], b"out = '\xe9t\xe9'", "is not UTF-8 text"),
    (["evaluate", "--config", "c.toml"], b"\xff\xfe\x00o", "is not UTF-8 text"),
    (["evaluate", "--config", "c.toml"], "a = " + "[" * 5000 + "]" * 5000, "nests"),
    (["evaluate", "--config", "c.toml"], "dataset = ", "is not valid TOML"),
    (["evaluate", "--config", "missing.toml"], None, "does not exist"),
    (["bench", "--config", "c.toml"], "sizes = [0]", "sizes=0 in c.toml must be an integer"),
    (["bench", "--config", "c.toml"], 'sizes = "64"', "must be a list of integers"),
    (["bench", "--config", "c.toml"], "sizes = [true]", "must be a list of integers"),
    (["bench", "--config", "c.toml"], "max_build_s = nan", "max_build_s=nan"),
    (["bench", "--config", "c.toml"], 'max_build_s = "x"', "must be a number"),
    (["bench", "--config", "c.toml"], "queries = 1e9", "must be an integer"),
    (["bench", "--config", "c.toml"], "warmup = -1", "warmup=-1 in c.toml"),
    (["bench", "--config", "c.toml"], "sizes = [8]\nout = 4", "out = 4 in c.toml"),
    (["map", TINY, "--config", "c.toml"], "[map]\nout = 5", "out = 5 in c.toml"),
    (["map", TINY, "--config", "c.toml"], "[map]\nmethod = 5", "method = 5 in c.toml"),
    (["map", TINY, "--config", "c.toml"], "[map]\nparams = 5", "params in c.toml must be"),
    (["map", TINY, "--config", "c.toml"], "map = 3", "map = 3 in c.toml must be a table"),
    (
        ["map", TINY, "--out", "m.npz", "--config", "c.toml"],
        '[map]\nmethod = "single-frame"\n[map.params]\ntop_k = "x"',
        "top_k='x' must be an integer",
    ),
    (["sweep", "--config", "c.toml", "--out", "s"], "[sweep]\nworkers = 100000", "workers="),
    (["sweep", "--config", "c.toml", "--out", "s"], "[sweep]\nseed = -1", "seed=-1"),
    (["sweep", "--config", "c.toml", "--out", "/etc/passwd/s"], "[sweep]\nseed = 1", "a file"),
    # a file's path written as a folder's: it became a file named 'maps' (the / dropped)
    ([*MAP, "--out", "maps/"], None, "--out maps/ ends in '/', which names a folder; give a"),
    ([*MAP, "--config", "c.toml"], 'out = "maps/"', "--out maps/ ends in '/', which names"),
    (["localise", "m.npz", "f.png", "--out", "est/"], None, "--out est/ ends in '/', which"),
]


@pytest.mark.parametrize(
    ("argv", "toml", "fragment"), CASES, ids=[f"{i:03d}" for i in range(len(CASES))]
)
def test_hostile_input_is_one_line_exit_1(tmp_path, monkeypatch, capsys, argv, toml, fragment):
    monkeypatch.chdir(tmp_path)
    if toml is not None:
        Path("c.toml").write_bytes(toml if isinstance(toml, bytes) else toml.encode())
    code = main(argv)
    _, err = capsys.readouterr()
    assert code == 1, err
    assert err.startswith("ppaloc: error: ") and err.count("\n") == 1, err
    assert fragment in err
    assert not Path("r").exists() and not Path("m.npz").exists()  # refused before any work


@pytest.mark.parametrize(
    "argv",
    [
        [*MAP, "--out", "pipe"],
        [*EV, "--out", "pipe"],
        ["localise", "m.npz", "f.png", "--out", "pipe"],
        ["show", "r", "--out", "pipe"],
    ],
)
def test_a_device_or_pipe_is_never_replaced(tmp_path, monkeypatch, capsys, argv):
    # an atomic write replaces its target: a pipe (or /dev/null, as root) would be destroyed
    monkeypatch.chdir(tmp_path)
    os.mkfifo("pipe")
    assert main(argv) == 1
    assert "is a device, pipe or socket" in capsys.readouterr().err
    assert stat.S_ISFIFO(os.stat("pipe").st_mode)


def test_nul_in_a_dataset_spec_is_one_line(capsys):
    assert main(["map", "folder:a\0b,c", "--out", "m.npz"]) == 1
    assert "holds a NUL character" in capsys.readouterr().err


def test_localise_with_a_map_of_the_wrong_kind_names_the_right_fix(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["map", TINY, "-m", "weighted-node-lbp", "--out", "lbp.npz", "-q"]) == 0
    from PIL import Image

    Image.new("L", (32, 32)).save("f.png")
    capsys.readouterr()
    assert main(["localise", "lbp.npz", "f.png", "-m", "weighted-node-lowres"]) == 1
    err = capsys.readouterr().err
    assert "holds 'lbp' nodes but method 'weighted-node-lowres' needs 'lowres' nodes" in err
    assert "--method weighted-node-lbp" in err
    assert "representation='lbp'" not in err


def test_live_with_a_map_no_sensor_method_reads_names_only_a_map_to_build(
    tmp_path, monkeypatch, capsys
):
    monkeypatch.chdir(tmp_path)
    assert main(["map", TINY, "--out", "patch.npz", "-q"]) == 0  # the host's patch place
    from PIL import Image

    Image.new("L", (32, 32)).save("f.png")
    capsys.readouterr()
    argv = ["localise", "patch.npz", "f.png", "-m", "onsensor-lowres", "--live"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "holds 'patch' nodes but method 'onsensor-lowres' needs 'lowres' nodes" in err
    assert "build a map for onsensor-lowres with `ppaloc map" in err
    assert "weighted-node-patch" not in err  # --live shows the sensor: no host method will do
    assert main(argv[:-1]) == 1  # without --live the host's method is a way out too
    assert "localise it with --method weighted-node-patch" in capsys.readouterr().err


def test_param_on_map_and_localise_merges_key_by_key(tmp_path, monkeypatch, capsys):
    # --param KEY=VALUE crashed in the parameter merge even with a valid value
    monkeypatch.chdir(tmp_path)
    Path("c.toml").write_text("[map.params]\ntop_k = 3\n[localise.params]\ntop_k = 4\n")
    argv = ["map", TINY, "-m", "single-frame", "--param", "radius=2", "--out", "m.npz", "-q"]
    assert main([*argv, "--config", "c.toml"]) == 0, capsys.readouterr().err
    from PIL import Image

    Image.new("L", (32, 32)).save("f.png")
    assert main(["localise", "m.npz", "f.png", "--param", "top_k=2", "--out", "e.csv"]) == 0
    assert Path("e.csv").read_text().count("\n") == 2


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["map", "folder:loop", "--out", "m.npz"], "the dataset's input loop"),
        (["map", "folder:loop/ref", "--out", "m.npz"], "the dataset's input loop/ref"),
        ([*EV[:5], "-d", "folder:loop,loop", "--out", "r"], "the dataset's input loop"),
        (["score", "p.csv", "-d", "folder:loop,loop", "--out", "r"], "the dataset's input loop"),
        ([*MAP, "--out", "loop"], "--out loop"),
        ([*MAP, "--out", "loop/m.npz"], "--out loop/m.npz"),
        ([*EV, "--out", "loop"], "--out loop"),
        (["evaluate", "--config", "loop"], "config file loop"),
        (["localise", "m.npz", "loop"], "frame loop"),
        (["show", "loop"], "the path loop"),
    ],
)
def test_a_symlink_loop_is_named(tmp_path, monkeypatch, capsys, argv, named):
    monkeypatch.chdir(tmp_path)
    os.symlink("loop2", "loop")
    os.symlink("loop", "loop2")
    Path("p.csv").write_text("query,reference,score\n0,0,1\n")
    assert main(["map", TINY, "-m", "single-frame", "-q", "--out", "m.npz"]) == 0
    code = main(argv)
    _, err = capsys.readouterr()
    assert code == 1, err
    assert err.startswith(f"ppaloc: error: {named} ") and err.count("\n") == 1, err
    assert "symlink loop" in err


SWEEP_TOML = f'datasets = ["{TINY}"]\nmethods = ["single-frame"]\n'


@pytest.mark.parametrize(
    ("argv", "toml"),
    [
        (["evaluate", "--seed", "9" * 30, "--out", "r"], BASE_TOML),
        (["evaluate", "--tolerance", "-4", "--out", "r"], BASE_TOML),
        (["bench", "--seed", "-3", "--out", "r"], 'methods = ["single-frame"]\n'),
        (["sweep", "--tolerance", "-3", "--out", "r"], SWEEP_TOML),
    ],
)
def test_a_bad_flag_beside_a_config_file_is_not_blamed_on_the_file(
    tmp_path, monkeypatch, capsys, argv, toml
):
    # the message named c.toml for a value that only the flag gave
    monkeypatch.chdir(tmp_path)
    Path("c.toml").write_text(toml)
    assert main([*argv, "--config", "c.toml"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and " must be an integer in [" in err, err
    assert "c.toml" not in err
    assert not Path("r").exists()


@pytest.mark.parametrize(
    ("argv", "toml", "message"),
    [
        (["map", TINY, "-m", "", "--out", "m.npz"], "[map]\n", "--method '' is empty: give a"),
        (["sweep", "--scheduler", "", "--out", "r"], SWEEP_TOML, "--scheduler '' is empty: give"),
        (["map", TINY, "--out", "m.npz"], '[map]\nmethod = ""\n', "method = '' is empty in c.toml"),
    ],
)
def test_an_empty_name_is_blamed_on_where_it_was_given(
    tmp_path, monkeypatch, capsys, argv, toml, message
):
    # an empty --method or --scheduler beside a config file was "method = '' is empty in
    # c.toml", a file that did not hold it
    monkeypatch.chdir(tmp_path)
    Path("c.toml").write_text(toml)
    assert main([*argv, "--config", "c.toml"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert not Path("r").exists() and not Path("m.npz").exists()


@pytest.mark.parametrize("command", ["evaluate", "score", "sweep"])
def test_a_dataset_whose_name_is_not_utf8_is_refused_before_the_run(
    tmp_path, monkeypatch, capsys, command
):
    # a folder named in Latin-1 bytes (any bytes make a Linux name): the run did its work,
    # then failed writing results.csv (an internal error, exit 3), nothing kept
    from PIL import Image

    monkeypatch.chdir(tmp_path)
    folder = os.fsdecode(b"caf\xe9")
    os.mkdir(folder)
    for i in range(3):
        Image.fromarray(np.full((16, 16), 40 * i, np.uint8)).save(f"{folder}/f{i}.png")
    Path("p.csv").write_text("query,reference,score\n0,0,1\n1,1,1\n2,2,1\n")
    spec = f"folder:{folder},{folder}"
    argv = {
        "evaluate": ["evaluate", "-d", spec, "-m", "single-frame", "-q", "--no-report"],
        "score": ["score", "p.csv", "-d", spec, "-q", "--no-report"],
        "sweep": ["sweep", "-d", spec, "-m", "single-frame", "-q", "--no-report"],
    }[command]
    assert main([*argv, "--out", "r"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "dataset spec 'folder:caf\\udce9,caf\\udce9' names a file or folder whose name " in err
    assert "is not UTF-8 text" in err and not Path("r").exists()


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("synth\udce9tic:?places=12", "unknown dataset kind 'synth\\udce9tic'"),
        ("synthetic:?places=1\udce9", "key 'places' must be an integer"),
    ],
)
def test_a_spec_of_bytes_that_are_not_utf8_elsewhere_is_named_as_its_parser_names_it(
    tmp_path, monkeypatch, capsys, spec, message
):
    # such bytes in the kind or a value were blamed on a file or folder's name, and the fix
    # given was to rename it or link to it
    monkeypatch.chdir(tmp_path)
    assert main(["evaluate", "-d", spec, "-m", "single-frame", "-q", "--out", "r"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "file or folder" not in err, err
