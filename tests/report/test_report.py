"""`lccopt report` on a small real multi-objective run (real simulator, cheap mesh), as a user
runs it."""

from __future__ import annotations

import base64
import json
import re
import shutil

import h5py
import pytest

from .helpers import FIGURES, lccopt, png_size, write_case

# seconds a test: a real optimisation, then its report
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """One real run: F_max and E_max (ASF), budget 12, two workers; then `lccopt report`."""
    base = tmp_path_factory.mktemp("report")
    case = write_case(base, "rep-moo", budget=12, initial=5)
    proc = lccopt("optimise", case, "--runs", base / "runs", "--workers", 2)
    assert proc.returncode == 0, proc.stderr[-2000:]
    run = base / "runs" / "rep-moo"
    proc = lccopt("report", run)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return run, proc


def test_every_figure_is_a_sensible_png(run_dir):
    run, proc = run_dir
    for name in FIGURES:
        p = run / "report" / f"{name}.png"
        assert p.is_file(), f"{name}.png missing; stdout: {proc.stdout}"
        w, h = png_size(p)
        assert 500 <= w <= 2000 and 250 <= h <= 1500, (name, w, h)
        assert 10_000 < p.stat().st_size < 1_000_000, (name, p.stat().st_size)
    assert "7 figures" in proc.stdout


def test_summary_best_values_equal_results_h5(run_dir):
    run, _ = run_dir
    with h5py.File(run / "results.h5", "r") as f:
        best = dict(f["best"].attrs)
        best_x = f["best/x"][()]
        ref = dict(f["reference/objectives"].attrs)
        names = [n.decode() if isinstance(n, bytes) else n for n in f["evaluations"].attrs["names"]]
        n_eval = int(f.attrs["n_evaluations"])
    s = json.loads((run / "report" / "summary.json").read_text())
    assert s["evaluations"] == n_eval == 12 and s["state"] == "finished"
    assert s["best"]["id"] == best["id"]
    assert s["best"]["value"] == best["value"]
    for k in ("F_rms", "F_max", "E_rms", "E_max"):
        assert s["best"]["objectives"][k] == best[k]
        assert s["reference"]["objectives"][k] == ref[k]
    assert [s["best"]["x"][n] for n in names] == best_x.tolist()

    from lccopt.report.data import fnum, pct

    md = (run / "report" / "report.md").read_text()
    assert f"evaluation **#{best['id']}**" in md
    for k in ("F_max", "E_max"):  # the objectives table row: name, unit, reference, best, change
        row = next(l for l in md.splitlines() if l.startswith(f"| **{k}** |"))
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert cells[2] == fnum(ref[k]) and cells[3] == fnum(best[k]), row
        assert cells[4] == pct(best[k], ref[k]), row
    # the design table has the best design's value of every variable
    for n in names:
        assert any(l.startswith(f"| `{n}` |") for l in md.splitlines())


def test_html_is_self_contained_and_embeds_every_figure(run_dir):
    run, _ = run_dir
    text = (run / "report" / "report.html").read_text()
    assert text.startswith("<!DOCTYPE html>")
    embedded = re.findall(r'<img alt="([^"]+)" src="data:image/png;base64,([^"]+)"', text)
    assert sorted(a for a, _ in embedded) == sorted(f"{n}.png" for n in FIGURES)
    for alt, data in embedded:
        assert base64.b64decode(data) == (run / "report" / alt).read_bytes()
    assert not re.search(r'src="(?!data:)', text), "the HTML refers to an external file"
    md = (run / "report" / "report.md").read_text()
    for n in FIGURES:
        assert f"]({n}.png)" in md


def test_format_option_picks_the_summary(run_dir, tmp_path):
    run, _ = run_dir
    copy = tmp_path / "copy"
    shutil.copytree(run, copy, ignore=shutil.ignore_patterns("report"))
    proc = lccopt("report", copy, "--format", "md")
    assert proc.returncode == 0, proc.stderr
    assert (copy / "report" / "report.md").is_file()
    assert not (copy / "report" / "report.html").exists()
    proc = lccopt("report", copy, "--format", "html")
    assert proc.returncode == 0, proc.stderr
    assert (copy / "report" / "report.html").is_file()
    proc = lccopt("report", copy, "--format", "pdf")
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0 and "--format" in proc.stderr


def test_out_writes_elsewhere_and_never_cleans_a_users_folder(run_dir, tmp_path):
    """--out DIR: the report goes there, RUN/report stays as it was, and files of the user's
    folder (even ones named like lccopt's figures) are left alone."""
    run, _ = run_dir
    copy = tmp_path / "copy"
    shutil.copytree(run, copy, ignore=shutil.ignore_patterns("report"))
    mine = tmp_path / "mine" / "deeper"
    mine.mkdir(parents=True)
    (mine / "sensitivity.png").write_bytes(b"a user's own file")
    (mine / "notes.txt").write_text("keep me")
    proc = lccopt("report", copy, "--out", mine / "report", "--format", "html")
    assert proc.returncode == 0, proc.stderr
    assert (mine / "report" / "report.html").is_file()
    assert (mine / "report" / "contact-force.png").is_file()
    assert not (copy / "report").exists()
    assert (mine / "sensitivity.png").read_bytes() == b"a user's own file"
    assert (mine / "notes.txt").read_text() == "keep me"


def test_interrupted_run_is_reported_from_the_journal(run_dir, tmp_path):
    """results.h5 gone (killed before its first rebuild) and the journal cut mid-run with a torn
    last line: the report rebuilds the table from the committed journal lines."""
    run, _ = run_dir
    copy = tmp_path / "cut"
    shutil.copytree(run, copy, ignore=shutil.ignore_patterns("report"))
    (copy / "results.h5").unlink()
    lines = (copy / "journal.jsonl").read_text().splitlines(keepends=True)
    done = [i for i, l in enumerate(lines) if '"event":"evaluated"' in l or '"event":"failed"' in l]
    keep = lines[:done[7] + 1]  # 8 evaluations committed
    (copy / "journal.jsonl").write_text("".join(keep) + '{"seq":999,"event":"eval')
    proc = lccopt("report", copy)
    assert proc.returncode == 0, proc.stderr
    s = json.loads((copy / "report" / "summary.json").read_text())
    assert s["evaluations"] == 8 and s["state"] == "interrupted" and s["source"] == "journal.jsonl"
    md = (copy / "report" / "report.md").read_text()
    assert "lccopt resume" in md and "8 of 12 evaluations" in md
    for name in FIGURES:   # 8 points cannot fit a surrogate of 8 variables: a note, no figure
        assert (copy / "report" / f"{name}.png").is_file() == (name != "sensitivity"), name
    assert "No sensitivity figure: too few successful evaluations" in md


def test_missing_histories_file_leaves_a_note(run_dir, tmp_path):
    run, _ = run_dir
    copy = tmp_path / "nofile"
    shutil.copytree(run, copy, ignore=shutil.ignore_patterns("report"))
    best = json.loads((run / "report" / "summary.json").read_text())["best"]["id"]
    (copy / "evals" / f"{best:06d}.h5").unlink()
    proc = lccopt("report", copy)
    assert proc.returncode == 0, proc.stderr
    md = (copy / "report" / "report.md").read_text()
    assert f"evals/{best:06d}.h5 is missing" in md
    assert (copy / "report" / "track-layout.png").is_file()  # rebuilt from the case, no file needed


@pytest.mark.parametrize("kind", ["missing", "file", "empty", "garbage"])
def test_missing_or_broken_run_directory_exit_2_one_line(tmp_path, kind):
    target = tmp_path / "run"
    if kind == "file":
        target.write_text("not a directory")
    elif kind == "empty":
        target.mkdir()
    elif kind == "garbage":
        target.mkdir()
        (target / "results.h5").write_bytes(b"this is not HDF5")
        (target / "journal.jsonl").write_text("not json\nnor this\n")
    proc = lccopt("report", target)
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    err = proc.stderr.strip()
    assert err.startswith("lccopt: error: ") and "\n" not in err, err
    assert str(target) in err and "Traceback" not in proc.stderr
    assert not (target / "report").exists()


def test_paper_phases_accounts_for_every_evaluation(run_dir):
    """benchmarks/paper/paper_phases.py on a real run: its phases add up to the run's evaluations
    and its best value is results.h5's."""
    import subprocess
    import sys

    from .helpers import REPO

    run, _ = run_dir
    with h5py.File(run / "results.h5", "r") as f:
        ev = f["evaluations"]
        n, best = len(ev["id"]), float(ev["value"][()][ev["status"][()] == b"ok"].min())
    proc = subprocess.run([sys.executable, "-m", "benchmarks.paper.paper_phases", str(run),
                           "--reference", "1", "--best", str(best)], capture_output=True,
                           text=True, timeout=120, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    line = proc.stdout.splitlines()[0].split()
    assert line[0] == run.name and float(line[1]) == pytest.approx(best, rel=1e-4)
    phases = [p for p in line[2:] if re.fullmatch(r"[FB]\d+:\S+", p)]
    assert phases[0].startswith("F") and sum(int(p[1:p.index(":")]) for p in phases) == n
    assert re.search(r"fresh phases that got below it: [1-9]\d* of [1-9]", proc.stdout)


def test_pads_searched_on_a_log_scale_are_placed_in_ratios(run_dir, monkeypatch, tmp_path):
    # configs/reference.yaml searches the pads on a log scale; best-vs-reference places each
    # value in its range as the optimiser saw it: the reference pad of 1120 MN/m in [50, 1200]
    # sits at ln(1120/50)/ln(1200/50) = 0.979 of the way, not (1120-50)/(1200-50) = 0.930.
    import numpy as np

    from lccopt.report import design
    from lccopt.report.data import load_run

    run, _ = run_dir
    data = load_run(run)
    assert [v.log for v in data.variables] == [True] * 3 + [False] * 5
    drawn = {}
    monkeypatch.setattr(design, "save_figure",
                        lambda fig, path: drawn.setdefault("fig", fig) and path)
    design.fig_best_vs_reference(data, data.best_index(), data.ref_index(), tmp_path)
    a2 = drawn["fig"].axes[1]
    ref = a2.collections[1].get_offsets()      # after the range lines: the reference diamonds
    np.testing.assert_allclose(ref[:3, 0], np.log(1120 / 50) / np.log(1200 / 50), rtol=1e-9)
    np.testing.assert_allclose(ref[3, 0], 8 / 20, rtol=1e-9)   # x_n = 8 in [0, 20]: linear


def test_contact_force_is_drawn_from_the_slab_edge_in_the_colours_its_caption_names(
        run_dir, monkeypatch, tmp_path):
    """One convention along the track: contact-force.png measures from the entry slab edge, as
    the track drawing and the settlement figures do (not the model's absolute metres); the
    caption in report.md names the colour the zone strip is drawn in."""
    import numpy as np
    from matplotlib.colors import to_hex

    from lccopt.report import along_track
    from lccopt.report.data import OKABE_ITO, load_run, read_history

    run, _ = run_dir
    data = load_run(run)
    bi, ri = data.best_index(), data.ref_index()
    (hb, ib, _), (hr, ir, _) = read_history(data, bi, None), read_history(data, ri, None)
    drawn = {}
    monkeypatch.setattr(along_track, "save_figure",
                        lambda fig, path: drawn.setdefault("fig", fig) and path)
    along_track.fig_contact_force(data, (hb, ib), (hr, ir), bi, tmp_path)
    ax = drawn["fig"].axes[0]
    assert "from the entry slab edge" in ax.get_xlabel()
    lo, hi = ax.get_xlim()
    edge = ib["interface_entry"]                         # 100 m into the model's track
    assert edge > 50 and lo < 0 < hi and hi < ib["interface_exit"] - edge + 5, (lo, hi)
    curve = next(li for li in ax.lines if li.get_label().startswith("reference design:"))
    curve = curve.get_xdata()
    np.testing.assert_allclose(curve, np.asarray(hr["wheel_position"]) - edge)
    zone = [p for p in ax.patches if p.get_label() == "force evaluation zone"][0]
    md = (run / "report" / "report.md").read_text()
    caption = next(line for line in md.splitlines() if line.startswith("*Wheel-rail contact"))
    named = re.search(r"(\w+) strip: evaluation zone", caption).group(1)
    assert to_hex(zone.get_facecolor()).lower() == OKABE_ITO[named].lower(), (named, caption)
    assert "orange" not in caption
