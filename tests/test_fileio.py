"""Atomic writes: the target is replaced whole or not at all."""

import os

import pytest

from ppaloc.fileio import atomic_write, default_file_mode, write_bytes


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
