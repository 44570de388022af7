"""lccopt.safeio: special files are refused at once (no hang, no runaway read), links inside
a run directory are never followed, sizes are checked while reading."""

from __future__ import annotations

import os

import h5py
import numpy as np
import pytest

from lccopt import safeio


def test_inputs_must_be_regular_files_and_are_read_only_up_to_the_limit(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(safeio.UnsafeFile, match="FIFO"):
        safeio.read_input(fifo, 100)            # would block forever with a plain open()
    with pytest.raises(safeio.UnsafeFile, match="character device"):
        safeio.read_input("/dev/zero", 100)     # would fill the memory with a plain read()
    with pytest.raises(safeio.UnsafeFile, match="directory"):
        safeio.read_input(tmp_path, 100)
    big = tmp_path / "big"
    big.write_bytes(b"x" * 101)
    with pytest.raises(safeio.UnsafeFile, match="larger than 100 bytes"):
        safeio.read_input(big, 100)
    assert safeio.read_input(big, 101) == b"x" * 101
    link = tmp_path / "link"
    link.symlink_to(big)                        # a user's own link to an input is fine
    assert safeio.read_input(link, 1000) == b"x" * 101


def test_owned_files_are_never_opened_through_a_link(tmp_path):
    outside = tmp_path / "outside.txt"
    outside.write_text("precious")
    link = tmp_path / "run-lock"
    link.symlink_to(outside)
    for mode in ("rb", "ab", "a+"):
        with pytest.raises(safeio.UnsafeFile, match="symbolic link"):
            safeio.open_owned(link, mode)
    with pytest.raises(safeio.UnsafeFile, match="symbolic link"):
        safeio.read_owned(link)
    assert outside.read_text() == "precious"
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    for mode in ("rb", "ab", "a+"):
        with pytest.raises(safeio.UnsafeFile, match="FIFO"):
            safeio.open_owned(fifo, mode)
    hard = tmp_path / "hard"
    os.link(outside, hard)       # a hard link: the same file under two names
    for mode in ("ab", "a+"):
        with pytest.raises(safeio.UnsafeFile, match="hard links"):
            safeio.open_owned(hard, mode)
    assert outside.read_text() == "precious"
    new = tmp_path / "new"
    with safeio.open_owned(new, "ab") as fh:
        fh.write(b"ok")
    assert new.read_bytes() == b"ok"


def test_owned_directories_and_hdf5_files(tmp_path):
    real = tmp_path / "evals"
    real.mkdir()
    safeio.check_owned_dir(real)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    linked = tmp_path / "linked"
    linked.symlink_to(elsewhere)
    with pytest.raises(safeio.UnsafeFile, match="symbolic link"):
        safeio.check_owned_dir(linked)
    (tmp_path / "plain").write_text("")
    with pytest.raises(safeio.UnsafeFile, match="regular file"):
        safeio.check_owned_dir(tmp_path / "plain")
    h5 = real / "000000.h5"
    with h5py.File(h5, "w") as f:
        f["a"] = np.arange(3)
    with safeio.h5_open_owned(h5) as f:
        assert f["a"][()].tolist() == [0, 1, 2]
    os.mkfifo(real / "000001.h5")
    with pytest.raises(safeio.UnsafeFile, match="FIFO"):
        with safeio.h5_open_owned(real / "000001.h5"):
            pass
    assert safeio.is_regular_file(h5) and not safeio.is_regular_file(real / "000001.h5")
