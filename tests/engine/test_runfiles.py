"""The files of a run, a report and a simulation under attack, as an attacker would try them
with real processes and files: a run directory moved and replaced by a link while it runs,
links planted in output folders, the lock file deleted, a journal two writers damaged,
another run's results.h5, a full disk, HDF5 files that keep their data elsewhere, kill -9 at
the worst moments. Each gets the documented exit code and one line, nothing is written outside
the run or the --out folder named, and a resumed run ends as an uninterrupted one."""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from lccopt.engine.runner import optimise

from .conftest import (
    FAKE,
    REPO,
    assert_same_evaluations,
    cli,
    cli_run,
    journal_events,
    n_done,
    read_table,
    wait_for,
    write_case,
)

pytestmark = pytest.mark.slow

ENV = {"LCCOPT_EVALUATOR": FAKE}
SLOW = {**ENV, "LCCOPT_FAKE_DELAY": "0.15"}


def _uninterrupted(tmp_path: Path, case: Path, workers: int = 1) -> dict:
    return read_table(optimise(case, workers=workers, runs=tmp_path / "uninterrupted",
                               evaluator=FAKE, progress=False))


def _error_line(r) -> str:
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2, r.stderr
    assert lines and lines[-1].startswith("lccopt: error: "), r.stderr
    assert "Traceback" not in r.stderr and "Exception ignored" not in r.stderr, r.stderr
    return lines[-1]


def _tree(path: Path) -> list[str]:
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))


@pytest.fixture
def finished(tmp_path):
    case = write_case(tmp_path, "h", budget=10, initial=4, seed=3)
    run = optimise(case, workers=1, runs=tmp_path / "runs", evaluator=FAKE, progress=False)
    return case, run


# ------------------------------------------------------------------------ the run directory

def test_a_run_directory_swapped_for_a_link_mid_run_keeps_writing_where_it_went(tmp_path):
    case = write_case(tmp_path, "sw", budget=14, initial=5, seed=2)
    reference = _uninterrupted(tmp_path, case, workers=2)
    runs, elsewhere = tmp_path / "runs", tmp_path / "elsewhere"
    (elsewhere / "evals").mkdir(parents=True)   # where a re-resolved path would now write
    p = cli("optimise", case, "--workers", "2", "--runs", runs, env=SLOW)
    wait_for(lambda: n_done(runs / "sw") >= 3, what="three results")
    os.rename(runs / "sw", runs / "moved")
    (runs / "sw").symlink_to(elsewhere)
    out, err = p.communicate(timeout=180)
    assert p.returncode == 0, err
    assert _tree(elsewhere) == ["evals"], "nothing written through the link"
    assert "no longer leads to this run's directory" in err
    moved = runs / "moved"
    assert_same_evaluations(reference, read_table(moved))
    assert sorted(f.name for f in (moved / "evals").iterdir()) == [f"{i:06d}.h5"
                                                                   for i in range(14)]


def test_one_driver_whatever_happens_to_the_lock_file(tmp_path):
    case = write_case(tmp_path, "lk", budget=20, initial=5, seed=6)
    reference = _uninterrupted(tmp_path, case)
    runs = tmp_path / "runs"
    run = runs / "lk"
    p = cli("optimise", case, "--workers", "1", "--runs", runs,
            env={**ENV, "LCCOPT_FAKE_DELAY": "0.5"})
    wait_for(lambda: n_done(run) >= 2, what="two results")
    # the first driver held still while the others try (a slow machine could otherwise see
    # it finish first); it keeps its lock and carries on afterwards
    os.kill(p.pid, signal.SIGSTOP)
    try:
        (run / "lock").unlink()
        r = cli_run("status", run, env=ENV)
        assert r.returncode == 0 and ": running," in r.stdout, r.stdout + r.stderr
        line = _error_line(cli_run("resume", run, env=ENV))
        assert "in use by another lccopt process" in line, line
        (run / "lock").write_text("")      # a fresh lock file of nobody's
        line = _error_line(cli_run("resume", run, env=ENV))
        assert "in use by another lccopt process" in line, line
        assert p.poll() is None and n_done(run) < 20, "checked while the first driver ran"
    finally:
        os.kill(p.pid, signal.SIGCONT)
    out, err = p.communicate(timeout=180)
    assert p.returncode == 0, err
    assert_same_evaluations(reference, read_table(run))
    assert [e["seq"] for e in journal_events(run)] == list(range(len(journal_events(run))))


def test_a_journal_two_writers_damaged_carries_on_from_before_the_damage_on_request(tmp_path,
                                                                                     finished):
    case, run = finished
    reference = read_table(run)
    lines = (run / "journal.jsonl").read_bytes().splitlines(keepends=True)
    # a second writer that started from line 12 appended its own line 12 after the first's 14
    damaged = b"".join(lines[:14] + [lines[12]] + lines[14:])
    (run / "journal.jsonl").write_bytes(damaged)
    (run / "results.h5").unlink()
    r = cli_run("resume", run, env=ENV)
    line = _error_line(r)
    assert "line 15 is damaged" in line and "--repair-journal" in line, line
    assert (run / "journal.jsonl").read_bytes() == damaged, "nothing changed without asking"
    line = _error_line(cli_run("status", run, env=ENV))
    assert "line 15 is damaged" in line and "--repair-journal" in line, line
    r = cli_run("report", run, "--out", tmp_path / "rep", env=ENV)   # the lines before it
    assert r.returncode == 0 and "line 15 is damaged" in r.stderr, r.stderr
    r = cli_run("resume", run, "--repair-journal", "--workers", "1", env=ENV)
    assert r.returncode == 0, r.stderr
    assert "carrying on from the 14 lines before it" in r.stderr
    assert (run / "journal.damaged-1.jsonl").read_bytes() == damaged
    assert_same_evaluations(reference, read_table(run))
    assert cli_run("status", run, env=ENV).returncode == 0


def test_results_h5_of_another_run_is_never_mixed_in(tmp_path):
    a = optimise(write_case(tmp_path, "a", budget=8, initial=4, seed=1), workers=1,
                 runs=tmp_path / "runs", evaluator=FAKE, progress=False)
    b = optimise(write_case(tmp_path, "b", budget=8, initial=4, seed=9), workers=1,
                 runs=tmp_path / "runs", evaluator=FAKE, progress=False)
    mine = read_table(a)
    with h5py.File(a / "results.h5") as f, h5py.File(b / "results.h5") as g:
        assert f.attrs["journal_seq"] == g.attrs["journal_seq"]   # the same length of journal
        assert f.attrs["run_mark"] != g.attrs["run_mark"]
    shutil.copy(b / "results.h5", a / "results.h5")
    r = cli_run("report", a, "--out", tmp_path / "rep", env=ENV)
    assert r.returncode == 0, r.stderr
    summary = json.loads((tmp_path / "rep" / "summary.json").read_text())
    assert summary["name"] == "a" and summary["source"] == "journal.jsonl"
    assert "results.h5 is not this run's" in (tmp_path / "rep" / "report.md").read_text()
    best = int(mine["id"][np.nanargmin(mine["value"])])
    assert summary["best"]["id"] == best
    assert cli_run("resume", a, env=ENV).returncode == 0      # rebuilt from the journal
    assert_same_evaluations(mine, read_table(a))
    with h5py.File(a / "results.h5") as f:
        assert f.attrs["case_name"] == "a"


def test_a_kill_9_while_a_run_is_made_leaves_nothing_the_next_optimise_keeps(tmp_path):
    case = write_case(tmp_path, "mk", budget=4, initial=4)
    runs = tmp_path / "runs"
    # kill -9 at the last moment of the creation: the folder is whole but not yet renamed
    kill = ("import os, signal, sys; from lccopt.folder import Folder; real = Folder.rename\n"
            "def rename(self, a, b, into=None):\n"
            "    if '.creating-' in a: os.kill(os.getpid(), signal.SIGKILL)\n"
            "    return real(self, a, b, into)\n"
            "Folder.rename = rename\n"
            "from lccopt.cli import main; sys.exit(main())")
    p = subprocess.run([sys.executable, "-c", kill, "optimise", str(case), "--runs", str(runs),
                        "--workers", "1"], env={**os.environ, "PYTHONPATH": str(REPO), **ENV},
                       capture_output=True, timeout=120)
    assert p.returncode == -signal.SIGKILL
    left = [n for n in os.listdir(runs) if n.startswith(".mk.creating-")]
    assert len(left) == 1 and (runs / left[0] / "journal.jsonl").exists()
    # one being made by a live process (it holds the folder's lock) and one with a file of
    # someone else's: both kept
    busy, foreign = runs / ".mk.creating-busy0001", runs / ".mk.creating-other001"
    busy.mkdir()
    (busy / "run.json").write_text("{}")
    foreign.mkdir()
    (foreign / "thesis.tex").write_text("mine")
    holder = os.open(busy, os.O_RDONLY | os.O_DIRECTORY)
    fcntl.flock(holder, fcntl.LOCK_EX)
    try:
        r = cli_run("optimise", case, "--runs", runs, "--workers", "1", env=ENV)
        assert r.returncode == 0, r.stderr
    finally:
        os.close(holder)
    assert sorted(os.listdir(runs)) == [".mk.creating-busy0001", ".mk.creating-other001", "mk"]
    assert (foreign / "thesis.tex").read_text() == "mine"


def test_what_appears_at_the_run_path_while_the_workers_start_is_never_removed(tmp_path):
    """The runs folder changes while optimise waits for its workers (after its first look):
    another process makes a folder or a link where the run goes, or swaps the run --force was
    to replace for a link or a folder of the user's. Each is refused with one line and exit 2;
    nothing is removed, and nothing is written into a link's target."""
    case = write_case(tmp_path, "w", budget=3, initial=3)
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "thesis.tex").write_text("precious")

    def plant_a_link(run):
        run.symlink_to(victim)

    def plant_a_folder(run):
        run.mkdir()
        (run / "notes.txt").write_text("mine")

    def swap_for_a_link(run):
        run.rename(run.with_name("moved"))
        run.symlink_to(victim)

    def swap_for_a_folder(run):
        run.rename(run.with_name("moved"))
        plant_a_folder(run)

    attacks = [(plant_a_link, False, "already exists"), (plant_a_folder, False, "already exists"),
               (swap_for_a_link, True, "not a run directory inside"),
               (swap_for_a_folder, True, "not an lccopt run directory")]
    made = optimise(case, workers=1, runs=tmp_path / "made", evaluator=FAKE, progress=False)
    started = []
    for k, (attack, force, _) in enumerate(attacks):
        runs = tmp_path / f"runs{k}"
        runs.mkdir()
        if force:   # a real run for --force to replace (what the first look sees)
            shutil.copytree(made, runs / "w")
    for k, (attack, force, _) in enumerate(attacks):
        runs = tmp_path / f"runs{k}"
        mark = tmp_path / f"mark{k}"
        started.append(cli("optimise", case, "--runs", runs, "--workers", "1",
                           *(["--force"] if force else []),
                           env={"LCCOPT_EVALUATOR": "tests.engine.slowstart:evaluate",
                                "LCCOPT_SLOW_START": "1.5", "LCCOPT_SLOW_MARK": str(mark)}))
    for k, ((attack, force, said), p) in enumerate(zip(attacks, started)):
        wait_for(lambda: (tmp_path / f"mark{k}").exists() or p.poll() is not None)
        assert p.poll() is None, p.communicate()
        attack(tmp_path / f"runs{k}" / "w")
    done = [p.communicate(timeout=120) for p in started]
    assert _tree(victim) == ["thesis.tex"] and (victim / "thesis.tex").read_text() == "precious"
    for k, ((attack, force, said), p, (out, err)) in enumerate(zip(attacks, started, done)):
        run = tmp_path / f"runs{k}" / "w"
        if attack in (plant_a_link, swap_for_a_link):
            assert run.is_symlink(), attack.__name__
        else:
            assert _tree(run) == ["notes.txt"], (attack.__name__, _tree(run))
            assert (run / "notes.txt").read_text() == "mine"
        if force:   # the run that was there is where the attacker moved it, whole
            assert len(read_table(tmp_path / f"runs{k}" / "moved")["id"]) == 3
        got = _error_line(subprocess.CompletedProcess(p.args, p.returncode, out, err))
        assert said in got, (attack.__name__, got)


# ------------------------------------------------------------------------ readers

def test_every_reader_follows_one_rule_for_links(tmp_path, finished):
    case, run = finished
    shutil.move(run / "evals", tmp_path / "evals-moved")
    (run / "evals").symlink_to(tmp_path / "evals-moved")
    for args in (("status", run), ("report", run, "--out", tmp_path / "rep"), ("resume", run)):
        line = _error_line(cli_run(*args, env=ENV))
        assert "evals" in line and "symbolic link" in line, (args, line)
    assert not (tmp_path / "rep").exists() or not os.listdir(tmp_path / "rep")
    (run / "evals").unlink()
    shutil.move(tmp_path / "evals-moved", run / "evals")

    # a hard link is the same file under two names: read by every reader, never written to
    copy = tmp_path / "journal-backup.jsonl"
    os.link(run / "journal.jsonl", copy)
    os.link(run / "results.h5", tmp_path / "results-backup.h5")
    os.link(run / "evals" / "000000.h5", tmp_path / "ref-backup.h5")
    assert cli_run("status", run, env=ENV).returncode == 0
    assert cli_run("report", run, "--out", tmp_path / "rep", env=ENV).returncode == 0
    before = copy.read_bytes()
    line = _error_line(cli_run("resume", run, "--budget", "12", env=ENV))
    assert "journal.jsonl" in line and "hard links" in line, line
    assert copy.read_bytes() == before


def _external_dataset(path: Path, target: Path, virtual: bool = False) -> None:
    """An evaluation file whose /design keeps its data in ``target`` (external storage, or a
    virtual dataset)."""
    with h5py.File(path, "w") as f:
        if virtual:
            layout = h5py.VirtualLayout(shape=(8,), dtype=float)
            layout[:] = h5py.VirtualSource(str(target), "design", shape=(8,))
            f.create_virtual_dataset("design", layout)
        else:
            f.create_dataset("design", shape=(8,), dtype=float,
                             external=[(str(target), 0, h5py.h5f.UNLIMITED)])
        f.create_group("objectives")
        f.create_group("histories")
        f.create_group("info").attrs["id"] = 0


@pytest.mark.parametrize("virtual", [False, True], ids=["external-storage", "virtual-dataset"])
def test_hdf5_files_that_keep_their_data_elsewhere_are_refused_never_read(tmp_path, finished,
                                                                          virtual):
    case, run = finished
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)                     # HDF5 would wait on it forever
    (run / "evals" / "000000.h5").unlink()
    _external_dataset(run / "evals" / "000000.h5", fifo, virtual)
    with h5py.File(run / "results.h5", "a") as f:   # and results.h5 itself
        del f["reference/x"]
        if virtual:
            layout = h5py.VirtualLayout(shape=(8,), dtype=float)
            layout[:] = h5py.VirtualSource(str(fifo), "x", shape=(8,))
            f["reference"].create_virtual_dataset("x", layout)
        else:
            f["reference"].create_dataset("x", shape=(8,), dtype=float,
                                          external=[(str(fifo), 0, h5py.h5f.UNLIMITED)])
    r = cli_run("report", run, "--out", tmp_path / "rep", env=ENV, timeout=120)
    assert r.returncode == 0, r.stderr
    text = (tmp_path / "rep" / "report.md").read_text()
    what = "virtual dataset" if virtual else "stored in external files"
    assert "results.h5 is unreadable" in text and what in text
    assert "000000.h5 refused" in text
    assert json.loads((tmp_path / "rep" / "summary.json").read_text())["source"] == \
        "journal.jsonl"
    r = cli_run("resume", run, env=ENV, timeout=120)       # simulated again, no budget spent
    assert r.returncode == 0, r.stderr
    assert "#0" in r.stderr
    with h5py.File(run / "evals" / "000000.h5") as f:
        assert f["design"].id.get_create_plist().get_external_count() == 0


def test_a_link_to_another_file_inside_an_hdf5_file_is_refused(tmp_path, finished):
    case, run = finished
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with h5py.File(run / "results.h5", "a") as f:
        del f["evaluations"]
        f["evaluations"] = h5py.ExternalLink(str(fifo), "/evaluations")
    r = cli_run("report", run, "--out", tmp_path / "rep", env=ENV, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "a link to another file at /evaluations" in (tmp_path / "rep" / "report.md").read_text()


# ------------------------------------------------------------------------ output folders

def _report(run, out=None, *more, env=ENV):
    args = ["report", run] + (["--out", out] if out is not None else []) + list(more)
    return cli_run(*args, env=env)


def test_report_out_never_writes_through_a_link(tmp_path, finished):
    case, run = finished
    out, victim = tmp_path / "out", tmp_path / "victim.txt"
    victim.write_text("precious")
    out.mkdir()
    (out / "search-history.png").symlink_to(victim)
    line = _error_line(_report(run, out))
    assert "search-history.png" in line and "--force" in line
    assert _report(run, out, "--force").returncode == 0
    assert victim.read_text() == "precious"
    assert not (out / "search-history.png").is_symlink()
    assert (out / "search-history.png").read_bytes()[:4] == b"\x89PNG"
    # the run's own report/ is replaced whole: a planted link inside it is dropped with it
    assert _report(run).returncode == 0
    (run / "report" / "search-history.png").unlink()
    (run / "report" / "search-history.png").symlink_to(victim)
    (run / "report" / "conditions.png").write_bytes(b"an old figure")
    assert _report(run).returncode == 0
    assert victim.read_text() == "precious"
    assert not (run / "report" / "search-history.png").is_symlink()
    assert not (run / "report" / "conditions.png").exists()
    assert not [n for n in os.listdir(run) if n.startswith(".lccopt-")]


def _staged_png(folder: Path) -> bool:
    return any(p.suffix == ".png" and p.stat().st_size > 0
               for d in folder.glob(".lccopt-report-*.tmp") for p in d.iterdir())


def test_a_report_is_written_whole_or_not_at_all(tmp_path, finished):
    case, run = finished
    out = tmp_path / "out"
    # kill -9 in the middle: nothing of it among the report's files, and the next report
    # (no --force needed) removes what it left
    p = cli("report", run, "--out", out, env=ENV)
    wait_for(lambda: out.exists() and _staged_png(out), timeout=120, what="a staged figure")
    p.kill()
    p.communicate()
    assert [n for n in os.listdir(out) if not n.startswith(".lccopt-report-")] == []
    assert _report(run, out).returncode == 0
    assert all(f.stat().st_size > 0 for f in out.iterdir()), _tree(out)
    assert not list(out.glob(".lccopt-*"))

    # two reports into one folder: the second is refused while the first writes
    first = cli("report", run, "--out", tmp_path / "two", env=ENV)
    wait_for(lambda: (tmp_path / "two").exists() and list((tmp_path / "two").glob(".lccopt-*")),
             timeout=120, what="the first report's staging folder")
    line = _error_line(_report(run, tmp_path / "two", "--force"))
    assert "another lccopt command is writing into" in line, line
    o, e = first.communicate(timeout=120)
    assert first.returncode == 0, e

    # Ctrl-C: exit 130 and nothing written; the run's own report stays the old one, whole
    assert _report(run).returncode == 0
    old = {f.name: f.read_bytes() for f in (run / "report").iterdir()}
    p = cli("report", run, env=ENV)
    wait_for(lambda: _staged_png(run), timeout=120, what="a staged figure")
    p.send_signal(signal.SIGINT)
    o, e = p.communicate(timeout=60)
    assert "Traceback" not in e
    now = {f.name: f.read_bytes() for f in (run / "report").iterdir()}
    if p.returncode == 130:
        assert now == old
    else:   # the signal came after the new report was in place: too late to stop anything
        assert p.returncode == 0, e
        assert sorted(now) == sorted(old) and all(now.values()), sorted(now)
    assert not [n for n in os.listdir(run) if n.startswith(".lccopt-")]


# One command's files moved into place, in a process of its own with the command line's
# signal handling: argv[1] the folder, argv[2] what happens before the files move.
_COMMIT = """
import os, signal, sys
from pathlib import Path
from lccopt.errors import stop_on_signals
from lccopt.outdir import Output

class Finaliser:   # Ctrl-C raised inside a finaliser, where it cannot propagate
    def __del__(self):
        signal.raise_signal(signal.SIGINT)   # its handler runs at once, inside __del__

stop_on_signals()
out, before = Path(sys.argv[1]), sys.argv[2]
try:
    with Output.into(out, ["a.txt"], (), False, "report") as output:
        (output.root / "a.txt").write_bytes(b"whole")
        if before == "finaliser":
            Finaliser()
except KeyboardInterrupt:
    print("interrupted")
    sys.exit(130)
signal.raise_signal(signal.SIGINT)   # once the files are in place: nothing left to stop
print("done")
"""


@pytest.mark.parametrize("before", ["nothing", "finaliser"])
def test_an_interruption_leaves_nothing_or_comes_after_the_files_are_in_place(tmp_path, before):
    """An interruption a finaliser swallowed (Python cannot raise it there) stops the command
    before its files move, not after; a stopping signal once they are in place ends nothing."""
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-c", _COMMIT, str(out), before], capture_output=True,
                       text=True, timeout=60, cwd=REPO)
    assert "Traceback" not in r.stderr, r.stderr
    if before == "finaliser":
        assert (r.returncode, r.stdout.strip()) == (130, "interrupted"), r.stderr
        assert not out.exists() or os.listdir(out) == []
    else:
        assert (r.returncode, r.stdout.strip()) == (0, "done"), r.stderr
        assert os.listdir(out) == ["a.txt"] and (out / "a.txt").read_bytes() == b"whole"


def _simulate(case, out, *more):
    return cli_run("simulate", case, "--out", out, *more, env={"LCCOPT_EVALUATOR": ""})


def test_simulate_out_follows_the_rules_of_report_out(tmp_path):
    case = write_case(tmp_path, "sim", budget=4, initial=4)
    out, victim = tmp_path / "S", tmp_path / "victim.txt"
    victim.write_text("precious")
    out.mkdir()
    (out / "displacement.png").write_text("my figure")
    line = _error_line(_simulate(case, out))
    assert "displacement.png" in line and "--force" in line, line
    assert (out / "displacement.png").read_text() == "my figure"
    (out / "displacement.png").unlink()
    (out / "contact_force.png").symlink_to(victim)
    line = _error_line(_simulate(case, out))
    assert "contact_force.png" in line, line
    r = _simulate(case, out, "--force")
    assert r.returncode == 0, r.stderr
    assert victim.read_text() == "precious"
    assert sorted(os.listdir(out)) == ["contact_force.png", "displacement.png", "simulation.h5",
                                       "sleeper_energy.png"]
    assert not (out / "contact_force.png").is_symlink()


def test_simulate_out_never_writes_into_a_linked_condition_folder(tmp_path):
    from .test_conditions import THREE, conditions_case

    case = conditions_case(tmp_path, THREE, name="tr")
    out, elsewhere = tmp_path / "S", tmp_path / "elsewhere"
    out.mkdir()
    elsewhere.mkdir()
    (out / "v80").symlink_to(elsewhere)
    line = _error_line(_simulate(case, out))
    assert "v80" in line and "--force" in line, line
    r = _simulate(case, out, "--force")
    assert r.returncode == 0, r.stderr
    assert os.listdir(elsewhere) == []
    assert (out / "v80").is_dir() and not (out / "v80").is_symlink()
    assert sorted(os.listdir(out / "v80")) == ["contact_force.png", "displacement.png",
                                               "sleeper_energy.png"]
    assert sorted(os.listdir(out)) == ["simulation.h5", "v140", "v160", "v80"]


# ------------------------------------------------------------------------ a full disk

def _tmpfs(path: Path, size_kb: int) -> Path | None:
    path.mkdir(exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_kb}k", "tmpfs", str(path)],
                       capture_output=True)
    return path if r.returncode == 0 else None


def _umount(path: Path) -> None:
    subprocess.run(["umount", "-l", str(path)], capture_output=True)


@pytest.fixture
def small(tmp_path):
    """A tmpfs of 2 MB (needs root and mount); skipped where the machine does not allow it."""
    if os.geteuid() != 0:
        pytest.skip("needs root to mount a small file system")
    path = _tmpfs(tmp_path / "small", 2048)
    if path is None:
        pytest.skip("cannot mount a tmpfs here")
    yield path
    _umount(path)


def _fill(small: Path, free_kb: int) -> None:
    """Leave about ``free_kb`` of the file system free."""
    st = os.statvfs(small)
    with open(small / "filler", "wb") as fh:
        fh.write(b"\0" * max(0, st.f_bavail * st.f_frsize - free_kb * 1024))


def test_a_full_disk_during_optimise_is_one_line_exit_2_and_resumes_to_the_same_end(tmp_path,
                                                                                      small):
    case = write_case(tmp_path, "full", budget=30, initial=6, seed=4)
    reference = _uninterrupted(tmp_path, case)
    # the 410-490 kB file systems: the disk fills at another file each time
    for free in (90, 130, 170, 210):
        runs = small / f"runs{free}"
        _fill(small, free)
        r = cli_run("optimise", case, "--workers", "1", "--runs", runs, env=ENV)
        line = _error_line(r)
        assert "No space left on device" in line and ".tmp" not in line, line
        assert str(runs / "full") in line, line
        run = runs / "full"
        (small / "filler").unlink()
        assert not [e for e in journal_events(run) if e["event"] == "failed"]
        done = cli_run("resume", run, "--workers", "1", env=ENV)
        assert done.returncode == 0, done.stderr
        assert_same_evaluations(reference, read_table(run))
        shutil.rmtree(runs)


def test_a_full_disk_under_report_and_simulate_names_the_file_and_leaves_nothing(tmp_path,
                                                                                  finished,
                                                                                  small):
    case, run = finished
    _fill(small, 60)
    out = small / "rep"
    line = _error_line(_report(run, out))
    assert "No space left on device" in line and str(out) in line and ".tmp" not in line, line
    assert not out.exists() or os.listdir(out) == []
    out = small / "sim"
    line = _error_line(_simulate(case, out))
    assert "No space left on device" in line and str(out) in line and ".tmp" not in line, line
    assert not out.exists() or os.listdir(out) == []


def test_an_immutable_results_h5_is_named_never_its_temporary_file(tmp_path, finished):
    case, run = finished
    if os.geteuid() != 0 or shutil.which("chattr") is None:
        pytest.skip("needs root and chattr")
    if subprocess.run(["chattr", "+i", str(run / "results.h5")]).returncode != 0:
        pytest.skip("this file system has no immutable files")
    try:
        line = _error_line(cli_run("resume", run, "--budget", "12", "--workers", "1", env=ENV))
    finally:
        subprocess.run(["chattr", "-i", str(run / "results.h5")])
    assert f"{run / 'results.h5'}: Operation not permitted" in line and ".tmp" not in line, line
    assert not [n for n in os.listdir(run) if n.endswith(".tmp")]
    r = cli_run("resume", run, "--workers", "1", env=ENV)
    assert r.returncode == 0, r.stderr
    assert len(read_table(run)["id"]) == 12
