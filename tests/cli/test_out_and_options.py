"""Unusual output names and options given to the command: ``--out -`` means standard output
where the one file written is text and is refused in one line elsewhere, for every command
that has an ``--out``; each test here fails on the code before its fix."""

from __future__ import annotations

from pathlib import Path

import click
import numpy as np
import pytest
from PIL import Image

from ppaloc.cli import main
from ppaloc.cli.main import cli

TINY = "synthetic:?places=12&size=32&sync=1&seed=2"


def run(capsys, *args: object) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def _commands(group: click.Group, path: tuple[str, ...] = ()) -> dict[str, click.Command]:
    out: dict[str, click.Command] = {}
    for name, command in group.commands.items():
        if isinstance(command, click.Group):
            out.update(_commands(command, (*path, name)))
        else:
            out[" ".join((*path, name))] = command
    return out


#: Every command with an ``--out``: what it writes there, and the command line that gives
#: ``--out -`` (with whatever else it needs to get as far as its output check).
DASH = {
    "demo": ("folder", ["demo"]),
    "evaluate": ("folder", ["evaluate", "-d", TINY, "-m", "single-frame"]),
    "score": ("folder", ["score", "p.csv", "-d", TINY]),
    "bench": ("folder", ["bench", "-m", "single-frame", "--sizes", "64"]),
    "sweep": ("folder", ["sweep", "-m", "single-frame", "-d", TINY]),
    "cpp run": ("folder", ["cpp", "run", "p.cpp"]),
    "map": ("binary", ["map", TINY, "-m", "single-frame"]),
    "show": ("binary", ["show", "m.npz"]),
    "localise": ("text", ["localise", "m.npz", "f.png"]),
}


def test_every_command_with_an_out_says_what_a_dash_is():
    with_out = {
        name
        for name, command in _commands(cli).items()
        if any("--out" in p.opts for p in command.params)
    }
    assert with_out == set(DASH)


@pytest.mark.parametrize("name", [n for n, (kind, _) in DASH.items() if kind != "text"])
def test_out_dash_is_refused_where_a_folder_or_a_binary_file_is_written(
    tmp_path, monkeypatch, capsys, name
):
    # it used to be a folder or a file named '-' in the current folder
    monkeypatch.chdir(tmp_path)
    Path("p.csv").write_text("query,reference,score\n0,0,1\n")
    Path("p.cpp").write_text("int main() { return 0; }\n")
    kind, argv = DASH[name]
    code, out, err = run(capsys, *argv, "--out", "-")
    assert code == 1, err
    assert err.count("\n") == 1 and err.startswith("ppaloc: error: --out - is standard output")
    wanted = "a folder of several files; give a folder name" if kind == "folder" else "binary"
    assert wanted in err
    assert not Path("-").exists() and out == ""


def test_out_dash_in_a_config_file_is_refused_for_a_folder(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    Path("c.toml").write_text(f'dataset = "{TINY}"\nmethods = ["single-frame"]\nout = "-"\n')
    code, _, err = run(capsys, "evaluate", "--config", "c.toml")
    assert code == 1 and "--out - is standard output" in err
    assert not Path("-").exists()


@pytest.fixture
def map_and_frames(tmp_path, monkeypatch, capsys) -> list[str]:
    monkeypatch.chdir(tmp_path)
    code, _, err = run(capsys, "map", TINY, "-m", "single-frame", "-q", "--out", "m.npz")
    assert code == 0, err
    rng = np.random.default_rng(0)
    for i in range(3):
        Image.fromarray(rng.integers(0, 256, (32, 32), np.uint8)).save(f"f{i}.png")
    return ["m.npz", "f0.png", "f1.png", "f2.png"]


def test_localise_out_dash_is_standard_output(map_and_frames, capsys):
    code, out, err = run(capsys, "localise", *map_and_frames, "--out", "-")
    assert code == 0, err
    assert out.splitlines()[0].startswith("frame,path,node,reference_frame")
    assert len(out.splitlines()) == 4
    assert not Path("-").exists()
    Path("c.toml").write_text('[localise]\nout = "-"\n')  # the same from a config file
    code, again, err = run(capsys, "localise", *map_and_frames, "--config", "c.toml")
    assert code == 0, err
    assert again.splitlines()[0] == out.splitlines()[0] and not Path("-").exists()


def test_a_file_named_dash_is_still_written_as_dot_slash_dash(map_and_frames, capsys):
    code, out, err = run(capsys, "localise", *map_and_frames, "--out", "./-")
    assert code == 0, err
    assert out == "" and Path("-").read_text().startswith("frame,path,node")


def test_cpp_runs_out_is_checked_as_every_commands_before_the_build(tmp_path, capsys):
    # it was checked only for an earlier run's folder: a place that cannot be written
    # failed after the program was built and run (here: the compiler's error instead)
    program = tmp_path / "p.cpp"
    program.write_text("int main( {\n")
    code, _, err = run(capsys, "cpp", "run", program, "--out", "/proc/no-such/run")
    assert code == 1 and err.count("\n") == 1
    assert "--out /proc/no-such/run: cannot write in /proc" in err


def test_a_reader_that_stops_reading_the_csv_ends_the_run_quietly(map_and_frames):
    # `ppaloc localise ... | head -1`: click made the closed pipe exit code 1 without a
    # word, and with stdout buffered (no PYTHONUNBUFFERED) the flush at exit printed
    # "Exception ignored ... BrokenPipeError" and made it 120
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    code = "import sys; from ppaloc.cli import main; sys.exit(main())"
    argv = [sys.executable, "-c", code, "localise", *map_and_frames, "--out", "-"]
    with subprocess.Popen(
        argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True
    ) as proc:
        proc.stdout.close()  # before the first line: the write meets a closed pipe
        err = proc.stderr.read()
        assert proc.wait(timeout=300) == 0, err
    assert err == ""


@pytest.mark.parametrize(
    ("command", "out", "says"),
    [
        ("map", "route.png", "names an image, but it would hold a map (.npz); give a name "
         "ending in .npz"),
        ("map", "route.MP4", "names a video, but it would hold a map (.npz)"),
        ("localise", "est.npz", "names a map, but it would hold a CSV of estimates; give a "
         "name such as estimates.csv"),
        ("localise", "est.jpg", "names an image, but it would hold a CSV of estimates"),
    ],
)  # fmt: skip
def test_an_out_named_as_another_format_is_refused(
    map_and_frames, tmp_path, capsys, command, out, says
):
    # map --out x.png wrote a map (a zip) named as an image, which a folder of frames then
    # held as an unreadable image
    target = tmp_path / "o" / out
    target.parent.mkdir()
    args = ["map", TINY, "-q"] if command == "map" else ["localise", *map_and_frames]
    code, _, err = run(capsys, *args, "--out", target)
    assert code == 1 and err.startswith(f"ppaloc: error: --out {target} {says}")
    assert err.count("\n") == 1 and not target.exists()
