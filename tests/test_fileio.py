"""Atomic writes: a file or a folder is replaced whole or not at all, even when killed."""

import errno
import os
import signal
import subprocess
import sys

import pytest

from ppaloc import fileio
from ppaloc.errors import PpalocError
from ppaloc.fileio import atomic_write, default_file_mode, update_folder, write_bytes


def test_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "results.json"
    target.write_text("old")
    with pytest.raises(RuntimeError, match="boom"), atomic_write(target, "w") as f:
        f.write("half of the new")
        raise RuntimeError("boom")
    assert target.read_text() == "old"
    assert os.listdir(tmp_path) == ["results.json"]


def test_write_bytes_creates_the_folder_with_the_ordinary_mode(tmp_path):
    path = write_bytes(tmp_path / "a" / "b.txt", "é")
    assert path.read_bytes() == "é".encode()
    assert path.stat().st_mode & 0o777 == default_file_mode()


def test_a_killed_write_leaves_no_temporary(tmp_path):
    # The child opens an atomic write and dies (SIGKILL) inside it.
    target = tmp_path / "map.npz"
    target.write_text("old")
    code = (
        "import os, signal, sys\n"
        "from ppaloc.fileio import atomic_write\n"
        "with atomic_write(sys.argv[1]) as f:\n"
        "    f.write(b'half')\n"
        "    f.flush()\n"
        "    os.kill(os.getpid(), signal.SIGKILL)\n"
    )
    done = subprocess.run([sys.executable, "-c", code, str(target)], check=False)
    assert done.returncode == -signal.SIGKILL
    assert target.read_text() == "old"
    assert os.listdir(tmp_path) == ["map.npz"]


def test_a_named_temporary_of_a_dead_process_is_removed_by_the_next_write(tmp_path):
    target = tmp_path / "a.csv"
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        check=True,
        capture_output=True,
        text=True,
    )
    stale = tmp_path / f".a.csv.{int(dead.stdout)}-0000.tmp"
    stale.write_text("left by a killed run")
    live = tmp_path / f".a.csv.{os.getpid()}-1111.tmp"
    live.write_text("being written now")
    write_bytes(target, "new")
    assert sorted(os.listdir(tmp_path)) == sorted(["a.csv", live.name])


def test_the_named_fallback_works_without_anonymous_files(tmp_path, monkeypatch):
    monkeypatch.setattr(fileio, "_open_anonymous", lambda folder: None)
    write_bytes(tmp_path / "x.txt", "named")
    assert (tmp_path / "x.txt").read_text() == "named"
    assert os.listdir(tmp_path) == ["x.txt"]


@pytest.mark.parametrize("anonymous", [True, False])
def test_a_write_through_a_link_replaces_the_file_it_names_and_keeps_the_link(
    tmp_path, monkeypatch, anonymous
):
    # the link itself was replaced by a file: --out /dev/stdout (stdout redirected to a
    # file) made /dev/stdout a regular file, as root, for every later process
    if not anonymous:
        monkeypatch.setattr(fileio, "_open_anonymous", lambda folder: None)
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "est.csv").write_text("old")
    link = tmp_path / "est.csv"
    link.symlink_to("data/est.csv")
    write_bytes(link, "new")
    assert link.is_symlink() and os.readlink(link) == "data/est.csv"
    assert (tmp_path / "data" / "est.csv").read_text() == "new"
    assert sorted(os.listdir(tmp_path)) == ["data", "est.csv"]
    assert os.listdir(tmp_path / "data") == ["est.csv"]


def test_a_link_in_a_folder_being_replaced_is_replaced_not_written_through(tmp_path):
    # show rebuilds report.md in a staging copy of the results folder: a report.md that was
    # a link to the user's notes wrote the notes over before the folder was in
    (tmp_path / "notes.md").write_text("my notes")
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "report.md").symlink_to("../notes.md")
    (tmp_path / "run" / "null").symlink_to(os.devnull)
    with update_folder(tmp_path / "run") as stage:
        write_bytes(stage / "report.md", "report")
        write_bytes(stage / "null", "x")
    assert (tmp_path / "notes.md").read_text() == "my notes"
    assert not (tmp_path / "run" / "report.md").is_symlink()
    assert (tmp_path / "run" / "report.md").read_text() == "report"
    assert (tmp_path / "run" / "null").read_text() == "x"


@pytest.mark.parametrize("anonymous", [True, False])
@pytest.mark.parametrize("through_a_link", [False, True])
def test_a_file_that_is_replaced_keeps_its_permissions(
    tmp_path, monkeypatch, anonymous, through_a_link
):
    # the new file took the default mode: a private (0600) file became world-readable, and
    # a file written through a link lost the mode it had
    if not anonymous:
        monkeypatch.setattr(fileio, "_open_anonymous", lambda folder: None)
    (tmp_path / "data").mkdir()
    target = tmp_path / "data" / "est.csv"
    target.write_text("old")
    target.chmod(0o600)
    name = tmp_path / "est.csv" if through_a_link else target
    if through_a_link:
        name.symlink_to("data/est.csv")
    write_bytes(name, "new")
    assert target.read_text() == "new"
    assert target.stat().st_mode & 0o777 == 0o600
    write_bytes(tmp_path / "data" / "fresh.csv", "new")  # a new file: the ordinary mode
    assert (tmp_path / "data" / "fresh.csv").stat().st_mode & 0o777 == default_file_mode()


@pytest.mark.parametrize("through_a_link", [False, True])
def test_a_pipe_is_never_replaced_by_a_write(tmp_path, through_a_link):
    # show est.csv writes est.png beside it, a name no --out check saw: a pipe there (or a
    # link to one, or to /dev/null) was replaced by the PNG
    pipe = tmp_path / "pipe"
    os.mkfifo(pipe)
    target = tmp_path / "est.png"
    if through_a_link:
        target.symlink_to("pipe")
    else:
        target = pipe
    with pytest.raises(PpalocError, match="is a device, pipe or socket, not a file; writing"):
        write_bytes(target, "png")
    assert pipe.is_fifo() and target.is_fifo()


@pytest.mark.parametrize("exchange", [True, False])
def test_new_folder_replaces_the_whole_folder(tmp_path, monkeypatch, exchange):
    if not exchange:
        monkeypatch.setattr(fileio, "_exchange", lambda a, b: False)
    out = tmp_path / "run"
    out.mkdir()
    (out / "old-method.npz").write_text("old")
    (out / "bench.json").write_text("kept")
    with fileio.new_folder(out, carry=["bench.json"]) as stage:
        (stage / "results.json").write_text("new")
        assert (out / "old-method.npz").exists()  # the old folder is whole until the end
    assert sorted(os.listdir(out)) == ["bench.json", "results.json"]
    assert os.listdir(tmp_path) == ["run"]


def test_a_failed_transaction_keeps_the_old_folder(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "results.json").write_text("old")
    with pytest.raises(RuntimeError), fileio.new_folder(out) as stage:
        (stage / "results.json").write_text("half")
        raise RuntimeError("interrupted")
    assert (out / "results.json").read_text() == "old"
    assert os.listdir(tmp_path) == ["run"]


def test_update_folder_starts_from_the_current_files(tmp_path):
    out = tmp_path / "run"
    (out / "arrays").mkdir(parents=True)
    (out / "arrays" / "a.npz").write_text("a")
    (out / "results.json").write_text("r")
    with fileio.update_folder(out) as stage:
        assert (stage / "arrays" / "a.npz").read_text() == "a"
        write_bytes(stage / "report.html", "<html>")
        write_bytes(stage / "results.json", "changed in the stage only")
        assert (out / "results.json").read_text() == "r"  # linked files are replaced, not edited
    assert sorted(p.name for p in out.rglob("*")) == [
        "a.npz",
        "arrays",
        "report.html",
        "results.json",
    ]


def test_recover_folder_restores_the_old_folder_between_the_two_renames(tmp_path):
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        check=True,
        capture_output=True,
        text=True,
    )
    pid = int(dead.stdout)
    old = tmp_path / f".run.ppaloc-old-{pid}-abcd"
    old.mkdir()
    (old / "results.json").write_text("old")
    stage = tmp_path / f".run.ppaloc-new-{pid}-abcd"
    stage.mkdir()
    (stage / "results.json").write_text("new, maybe half")
    fileio.recover_folder(tmp_path / "run")
    assert os.listdir(tmp_path) == ["run"]
    assert (tmp_path / "run" / "results.json").read_text() == "old"


def test_source_date(monkeypatch):
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    assert fileio.source_date() is None
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    assert fileio.source_date().isoformat() == "2023-11-14T22:13:20+00:00"
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "yesterday")
    with pytest.raises(PpalocError, match="SOURCE_DATE_EPOCH='yesterday' is not a time"):
        fileio.source_date()


def test_a_folder_that_cannot_be_written_is_a_user_error(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    (locked / "run").mkdir()
    (locked / "run" / "results.json").write_text("old")
    locked.chmod(0o555)
    try:
        if os.access(locked, os.W_OK):  # root writes anyway: check through a missing parent
            target = tmp_path / "missing" / "run"
        else:
            target = locked / "run"
        with pytest.raises(PpalocError, match=r"cannot write .*run: its folder .* is not a writ"):
            with fileio.update_folder(target):
                pass
    finally:
        locked.chmod(0o755)
    assert (locked / "run" / "results.json").read_text() == "old"


@pytest.mark.parametrize(
    "check",
    [
        "ppaloc.evaluate.results:check_replaceable",
        "ppaloc.evaluate.sweep:check_sweep_folder",
        "ppaloc.cpp.run:check_output_folder",
    ],
)
def test_every_whole_folder_output_refuses_the_current_folder_and_its_parents(
    check, tmp_path, monkeypatch
):
    """Results, sweeps and C++ runs share one check (fileio.check_replaceable_folder)."""
    import importlib

    module, name = check.split(":")
    func = getattr(importlib.import_module(module), name)
    work = tmp_path / "work"
    (work / "sub").mkdir(parents=True)
    monkeypatch.chdir(work / "sub")
    for out in (".", "..", str(work)):
        with pytest.raises(PpalocError, match="is the current folder or holds it"):
            func(out)
    (tmp_path / "file").write_text("x")
    with pytest.raises(PpalocError, match="is a file"):
        func(tmp_path / "file")
    func(tmp_path / "absent")


def test_user_cache_is_the_variable_else_under_xdg_else_home(monkeypatch, tmp_path) -> None:
    from ppaloc.fileio import user_cache

    monkeypatch.setenv("PPALOC_TEST_CACHE", str(tmp_path / "mine"))
    assert user_cache("things", "PPALOC_TEST_CACHE") == tmp_path / "mine"
    monkeypatch.delenv("PPALOC_TEST_CACHE")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert user_cache("things", "PPALOC_TEST_CACHE") == tmp_path / "xdg" / "ppaloc" / "things"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert user_cache("things", "X") == tmp_path / "home" / ".cache" / "ppaloc" / "things"


def _interrupted_swap(monkeypatch) -> None:
    """Ctrl-C lands right after the two names were exchanged, before the old contents go."""
    real = fileio._exchange

    def exchange(a, b):
        done = real(a, b)
        os.kill(os.getpid(), signal.SIGINT)
        return done

    monkeypatch.setattr(fileio, "_exchange", exchange)


def test_ctrl_c_after_the_swap_finishes_the_transaction(tmp_path, monkeypatch):
    out = tmp_path / "run"
    out.mkdir()
    (out / "old.txt").write_text("old")
    _interrupted_swap(monkeypatch)
    before = signal.getsignal(signal.SIGINT)  # a pytest-xdist worker ignores SIGINT
    try:
        with fileio.new_folder(out) as stage:
            (stage / "new.txt").write_text("new")
    except KeyboardInterrupt:
        pytest.fail("interrupted, though the new folder was in place")
    assert os.listdir(tmp_path) == ["run"], "the old contents were left under a hidden name"
    assert os.listdir(out) == ["new.txt"]
    assert signal.getsignal(signal.SIGINT) is before  # the handler given back
    # a command that writes more folders is told, once, and stops after this one
    assert fileio.held_interrupt() and not fileio.held_interrupt()


def test_ctrl_c_after_a_nested_swap_stops_the_outer_transaction(tmp_path, monkeypatch):
    out = tmp_path / "matrix"
    (out / "01-a").mkdir(parents=True)
    (out / "01-a" / "old.txt").write_text("old")
    with pytest.raises(KeyboardInterrupt), fileio.update_folder(out) as stage:
        _interrupted_swap(monkeypatch)
        with fileio.new_folder(stage / "01-a") as inner:
            (inner / "new.txt").write_text("new")
        pytest.fail("the interrupt was lost")
    assert os.listdir(tmp_path) == ["matrix"] and os.listdir(out / "01-a") == ["old.txt"]


def _disk_full(*_args):
    raise OSError(errno.ENOSPC, "No space left on device")


def test_a_full_disk_names_the_file_being_written_and_leaves_no_temporary(tmp_path, monkeypatch):
    # the system's error named no file (or the hidden temporary), which the command could
    # only report as an internal error
    target = tmp_path / "map.npz"
    target.write_text("old")
    monkeypatch.setattr(fileio.os, "fsync", _disk_full)
    with pytest.raises(OSError) as err:
        write_bytes(target, "new")
    assert (err.value.errno, err.value.filename) == (errno.ENOSPC, str(target))
    assert target.read_text() == "old"
    assert os.listdir(tmp_path) == ["map.npz"]


def test_a_failed_copy_into_a_named_temporary_is_removed(tmp_path, monkeypatch):
    # where the unnamed file cannot be linked (EXDEV on some mounts) its bytes are copied
    # into a named temporary; a full disk during the copy left that half copy behind
    calls = []

    def fsync(fd):
        calls.append(fd)
        if len(calls) > 1:  # the unnamed file's own fsync passes, the copy's fails
            _disk_full()

    def link(*_args):
        raise OSError(errno.EXDEV, "Invalid cross-device link")

    monkeypatch.setattr(fileio.os, "fsync", fsync)
    monkeypatch.setattr(fileio.os, "link", link)
    target = tmp_path / "a.csv"
    with pytest.raises(OSError) as err:
        write_bytes(target, "new")
    assert err.value.filename == str(target)
    assert os.listdir(tmp_path) == []


def test_an_error_in_a_staged_folder_names_the_file_in_the_target(tmp_path):
    out = tmp_path / "run"
    with pytest.raises(OSError) as err, fileio.new_folder(out) as stage:
        raise OSError(errno.ENOSPC, "No space left on device", str(stage / "arrays" / "a.npz"))
    assert err.value.filename == str(out / "arrays" / "a.npz")
    assert os.listdir(tmp_path) == []


def test_an_error_of_the_callers_own_work_is_left_as_it_is(tmp_path):
    # only a write's errors (a full disk) are the file's; the caller's own error stays its own
    failure = OSError(errno.EINVAL, "Invalid argument")
    with pytest.raises(OSError) as err, atomic_write(tmp_path / "a.csv") as f:
        f.write(b"row\n")
        raise failure
    assert err.value is failure
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("loop", ["itself", "two links"])
def test_a_write_through_a_link_loop_is_refused_and_keeps_the_links(tmp_path, loop):
    # the loop's own name was taken as the file it named, and the link replaced by a file
    link = tmp_path / "report.html"
    if loop == "itself":
        link.symlink_to("report.html")
    else:
        link.symlink_to("other")
        (tmp_path / "other").symlink_to("report.html")
    with pytest.raises(PpalocError, match=r"symbolic link that leads into a loop") as info:
        with fileio.atomic_write(link, "w") as f:
            f.write("x")
    assert str(info.value) == (
        f"cannot write {link}: it is a symbolic link that leads into a loop (links that lead "
        "back to themselves), which writing would replace with a file; remove the link or "
        "point it at a file"
    )
    assert link.is_symlink() and sorted(p.name for p in tmp_path.iterdir() if p.is_file()) == []
