"""lccopt.safeio, folder and safe_h5: special files are refused at once (no hang, no runaway
read), links inside a run directory are never followed, sizes are checked while reading."""

from __future__ import annotations

import os

import h5py
import numpy as np
import pytest

from lccopt import safe_h5, safeio
from lccopt.folder import Folder, open_owned, read_owned


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
            open_owned(link, mode)
    with pytest.raises(safeio.UnsafeFile, match="symbolic link"):
        read_owned(link)
    assert outside.read_text() == "precious"
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    for mode in ("rb", "ab", "a+"):
        with pytest.raises(safeio.UnsafeFile, match="FIFO"):
            open_owned(fifo, mode)
    hard = tmp_path / "hard"
    os.link(outside, hard)       # a hard link: the same file under two names
    for mode in ("ab", "a+"):
        with pytest.raises(safeio.UnsafeFile, match="hard links"):
            open_owned(hard, mode)
    assert outside.read_text() == "precious"
    new = tmp_path / "new"
    with open_owned(new, "ab") as fh:
        fh.write(b"ok")
    assert new.read_bytes() == b"ok"


def test_owned_directories_and_hdf5_files(tmp_path):
    real = tmp_path / "evals"
    real.mkdir()
    top = Folder.open(tmp_path)
    assert top.sub("evals").identity == (real.stat().st_dev, real.stat().st_ino)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (tmp_path / "linked").symlink_to(elsewhere)
    with pytest.raises(safeio.UnsafeFile, match="symbolic link"):
        top.sub("linked")
    (tmp_path / "plain").write_text("")
    with pytest.raises(safeio.UnsafeFile, match="regular file"):
        top.sub("plain")
    h5 = real / "000000.h5"
    with h5py.File(h5, "w") as f:
        f["a"] = np.arange(3)
    with safe_h5.h5_open_owned(h5) as f:
        assert safe_h5.h5_read(f["a"]).tolist() == [0, 1, 2]
    os.mkfifo(real / "000001.h5")
    with pytest.raises(safeio.UnsafeFile, match="FIFO"):
        with safe_h5.h5_open_owned(real / "000001.h5"):
            pass
    evals = top.sub("evals")
    assert evals.is_file("000000.h5") and not evals.is_file("000001.h5")


def test_a_folder_held_open_is_written_where_it_went_never_through_its_old_path(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    folder = Folder.open(run)
    folder.write("a.json", b"1")
    run.rename(tmp_path / "moved")
    (tmp_path / "elsewhere").mkdir()
    run.symlink_to(tmp_path / "elsewhere")
    folder.write("b.json", b"2")
    assert sorted(os.listdir(tmp_path / "moved")) == ["a.json", "b.json"]
    assert os.listdir(tmp_path / "elsewhere") == []
    assert not folder.still_at(run) and folder.still_at(tmp_path / "moved")


def test_a_failed_write_names_the_file_and_leaves_no_temporary_one(tmp_path):
    folder = Folder.open(tmp_path)
    (tmp_path / "results.h5").mkdir()
    with pytest.raises(safeio.UnsafeFile, match="results.h5: a directory"):
        folder.write("results.h5", b"x")
    (tmp_path / "ro").mkdir()
    sub = folder.sub("ro")
    os.chmod(tmp_path / "ro", 0o500)
    try:
        if os.geteuid() != 0:   # root writes anyway
            with pytest.raises(OSError) as info:
                sub.write("state.json", b"{}")
            assert info.value.filename == str(tmp_path / "ro" / "state.json")
    finally:
        os.chmod(tmp_path / "ro", 0o700)
    assert sorted(os.listdir(tmp_path)) == ["results.h5", "ro"]


@pytest.mark.parametrize("make, words", [
    (lambda f, o: f.create_dataset("d", shape=(3,), dtype="f8",
                                   external=[(str(o), 0, h5py.h5f.UNLIMITED)]),
     "stored in external files"),
    (lambda f, o: f.__setitem__("d", h5py.ExternalLink(str(o), "/d")), "link to another file"),
    (lambda f, o: (f.create_dataset("e", data=[1.0]), f.__setitem__("d", h5py.SoftLink("/e"))),
     "soft link"),
    (lambda f, o: f.create_dataset("d", shape=(10**11,), dtype="i8", chunks=(1000,),
                                   compression="gzip"), "too large to read"),
])
def test_hdf5_files_that_reach_outside_themselves_are_refused(tmp_path, make, words):
    other = tmp_path / "fifo"
    os.mkfifo(other)
    with h5py.File(tmp_path / "x.h5", "w") as f:
        make(f, other)
    with pytest.raises(safeio.UnsafeFile, match=words):
        with safe_h5.h5_open_owned(tmp_path / "x.h5") as f:
            safe_h5.h5_read(f["d"])
