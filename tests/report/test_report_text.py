"""The report's words for traffic runs and for a run whose best is the reference design."""

from __future__ import annotations

import json
import re

import pytest

from lccopt.engine.runner import optimise
from tests.engine.conftest import FAKE, cli_run, write_case

CONDITIONS = """\
conditions:
  - {name: slow, speed: 22.222222222222222}
  - {name: fast, speed: 44.44444444444444}
"""


@pytest.mark.slow
def test_a_traffic_report_names_the_condition_that_sets_each_worst_case(tmp_path):
    # the stand-in's objectives grow with speed: 'fast' sets both worst cases
    case = write_case(tmp_path, "tr", budget=8, initial=4, worst=(90000.0, 9.0), extra=CONDITIONS)
    run = optimise(case, workers=2, runs=tmp_path, evaluator=FAKE, progress=False)
    r = cli_run("report", run)
    assert r.returncode == 0, r.stderr
    text = (run / "report" / "report.md").read_text()
    assert "F_max (worst case, set by fast)" in text, text
    assert "E_max (worst case, set by fast)" in text, text
    assert "In condition fast (which sets the best design's worst E_max)" in text, text


@pytest.mark.slow
def test_a_best_design_equal_to_the_reference_is_said_to_be_unchanged(tmp_path):
    case = write_case(tmp_path, "same", objectives=("F_max",), budget=6, initial=4)
    run = optimise(case, workers=1, runs=tmp_path, evaluator=FAKE, progress=False)
    journal = run / "journal.jsonl"
    lines = [json.loads(line) for line in journal.read_text().splitlines()]
    for ev in lines:   # every design but the reference made worse than it
        if ev["event"] == "evaluated" and ev["id"] > 0:
            ev["value"] = ev["objectives"]["F_max"] = 1e9
    journal.write_text("".join(json.dumps(ev, separators=(",", ":")) + "\n" for ev in lines))
    (run / "results.h5").unlink()
    r = cli_run("report", run)
    assert r.returncode == 0, r.stderr
    text = (run / "report" / "report.md").read_text()
    assert "F_max is unchanged at" in text, text
    assert "The best design is the reference design" in text, text
    assert "rises from" not in text and "+0.0 %" not in text   # an equal value is "0 %"


@pytest.mark.slow
def test_the_summary_names_every_variable_on_a_bound_and_every_objective_made_worse(tmp_path):
    """A best design with a pad on its upper bound (a bound the case chose: widen it), no
    strengthened sleeper and a Type II strip over the whole ERS (fixed limits), that is better
    in F_max but worse in F_rms and E_max: the summary says all of it, on the terminal too."""
    case = write_case(tmp_path, "bnd", objectives=("F_max",), budget=6, initial=4)
    run = optimise(case, workers=1, runs=tmp_path, evaluator=FAKE, progress=False)
    journal = run / "journal.jsonl"
    lines = [json.loads(line) for line in journal.read_text().splitlines()]
    ref = next(ev for ev in lines if ev["event"] == "evaluated" and ev["id"] == 0)["objectives"]
    for ev in lines:
        if ev["event"] == "asked" and ev["id"] == 1:
            ev["x"] = [1200e6, 1120e6, 1120e6, 0.0, 6.0, 6.0, 4.0, 120.0]
        if ev["event"] == "evaluated" and ev["id"] > 0:
            best = ev["id"] == 1
            ev["objectives"] = {"F_rms": ref["F_rms"] * 1.1, "E_rms": ref["E_rms"],
                                "F_max": 1000.0 if best else 1e9, "E_max": ref["E_max"] * 1.5}
            ev["value"] = ev["objectives"]["F_max"]
    journal.write_text("".join(json.dumps(ev, separators=(",", ":")) + "\n" for ev in lines))
    (run / "results.h5").unlink()
    r = cli_run("report", run)
    assert r.returncode == 0, r.stderr
    # a fixed limit says why on the terminal too, else it reads as advice to widen it
    on = " ".join(r.stdout.split("on a bound:")[1].split("worse than")[0].split())
    assert on == ("x_r1 (upper), x_n (lower: no strengthened sleeper), "
                  "x_l (upper: the strip covers the whole ERS)"), r.stdout
    assert "  worse than the reference: F_rms +10.0 %, E_max +50.0 %" in r.stdout, r.stdout
    assert all(len(line) <= 80 for line in r.stdout.splitlines()[:-1]), r.stdout  # [-1]: path
    md = (run / "report" / "report.md").read_text()
    bounds = next(p for p in md.split("\n\n") if p.startswith("**On a bound:**"))
    assert "3 of the best design's 8 variables" in bounds, bounds
    for text in ("`x_r1` = 1200 MN/m (upper bound)", "`x_n` = 0 sleepers (lower bound)",
                 "`x_l` = 12.0 m (upper bound)",
                 "widen `design.railpad_stiffness.bounds` (x_r1; railpads are 20-2000 MN/m)",
                 "`x_n` (no strengthened sleeper: there cannot be fewer)",
                 "`x_l` (the strip covers the whole ERS)"):
        assert text in bounds, (text, bounds)
    assert "sleeper_spans" not in bounds and "x_s" not in bounds   # inside their bounds
    why = md.split("## Why it is better")[1]
    worse = next(p for p in why.split("\n\n") if p.startswith("**What got worse:**"))
    assert "F_rms rises" in worse and "+10.0 %, not an objective of this run" in worse, worse
    assert "E_max rises" in worse and "+50.0 %" in worse, worse
    assert "F_max" not in worse and "E_rms" not in worse, worse      # better, and unchanged
    s = json.loads((run / "report" / "summary.json").read_text())
    assert s["on_bound"] == {"x_r1": "upper", "x_n": "lower", "x_l": "upper"}
    assert s["worse"] == ["F_rms", "E_max"]
    # the table of the best design marks the bounds; the searched table says how each moves
    assert re.search(r"\| `x_r1` \|.*\| 1200 \(upper bound\) \|", md), md
    assert re.search(r"\| `x_s1` \| span sleeper 2 to sleeper 3 \| m \| 0.3 … 0.7 \| "
                     r"in 0.1 m steps \|", md), md
    assert re.search(r"\| `x_n` \|.*\| whole number \|", md), md
    assert re.search(r"\| `x_r1` \|.*\| continuous, log scale \|", md), md


def test_the_most_loaded_sleeper_is_named_once_when_it_does_not_change():
    import numpy as np

    from lccopt.report.comparison import history_facts

    best = ({"sleeper_energy": np.array([1.0, 0.5, 0.4])}, {})
    ref = ({"sleeper_energy": np.array([2.0, 0.5, 0.1])}, {})
    text = history_facts(best, ref)[0]
    assert "instead of number" not in text and "sleeper 1 stays the most loaded" in text, text
    moved = ({"sleeper_energy": np.array([0.4, 0.9, 0.4])}, {})
    text = history_facts(moved, ref)[0]
    assert "the most loaded zone sleeper is number 2 (0.9000 J) instead of number 1" in text, text
    same_other = ({"sleeper_energy": np.array([0.4, 0.9, 0.4])}, {})
    ref2 = ({"sleeper_energy": np.array([0.4, 1.9, 0.4])}, {})
    text = history_facts(same_other, ref2)[0]
    assert "sleeper 2 stays the most loaded of the zone (0.9000 J instead of 1.900 J)" in text


def test_a_force_highest_at_the_windows_end_is_not_called_a_peak():
    import numpy as np

    from lccopt.report.comparison import history_facts
    from lccopt.report.data import pct

    x = np.linspace(90.0, 110.0, 2001)
    info = {"interface_entry": 100.0}
    rising = 1e5 + 1e3 * (x - 100.0)                          # still rising 3 m past the edge
    bump = 1e5 + 2e3 * np.exp(-((x - 100.7) / 0.3) ** 2)      # a peak 0.7 m past it
    text = history_facts(({"wheel_position": x, "contact_force": rising}, info),
                         ({"wheel_position": x, "contact_force": bump}, info))[-1]
    assert "103.0 kN, at the window's end, 3.00 m after the slab edge (still rising there)" \
        in text, text
    assert "against 102.0 kN 0.70 m after the slab edge for the reference design" in text, text
    assert pct(0.99999, 1.0) == "0.0 %" and pct(1.0, 1.0) == "0 %" and pct(1.1, 1.0) == "+10.0 %"


def test_a_plain_objective_of_a_run_over_realisations_is_named_as_drawn():
    """In a robust run E_max is the drawn track's value and q90(E_max) the optimised one: a
    best design worse as drawn must not read as worse at what the run minimised."""
    from types import SimpleNamespace

    from lccopt.commands.report import report_lines
    from lccopt.report.comparison import worse_text

    worse = [("E_max", 0.861, 4.428)]
    robust = SimpleNamespace(realisations=6, objectives=["q90(E_max)"])
    text = worse_text(robust, worse + [("q90(E_max)", 17.0, 18.0)])
    assert "E_max on the track as drawn rises from 0.8610 to 4.428 J" in text, text
    assert "q90(E_max) rises" in text, text
    drawn = SimpleNamespace(realisations=0, objectives=["E_max"])
    assert worse_text(drawn, worse).startswith("**What got worse:** E_max rises"), worse
    run = SimpleNamespace(
        name="r", n=20, budget=20, state="finished", objectives=["q90(E_max)"], realisations=6,
        ref_objectives={"q90(E_max)": 20.35, "E_max": 0.861}, variables=[])
    summary = {"best": {"id": 19, "objectives": {"q90(E_max)": 17.44, "E_max": 4.428}},
               "on_bound": {}, "worse": ["E_max"], "seconds": 1.0}
    lines = report_lines(SimpleNamespace(run=run, summary=summary, figures=[], files=[],
                                         path="out"))
    assert "  worse than the reference: E_max as drawn +414.3 %" in lines, lines


def test_a_passage_figure_says_which_side_the_vehicle_comes_from():
    """The designed side is always drawn on the left: a vehicle leaving the ERS comes from the
    right (a leave case's figures said "from the left")."""
    from lccopt.report.plotting import wheel_position_label

    assert wheel_position_label({"direction": "enter"}).endswith("comes from the left)")
    assert wheel_position_label({"direction": "leave"}).endswith("comes from the right)")
    assert wheel_position_label({}).endswith("comes from the left)")   # older evaluations


def test_axes_show_whole_values_not_an_offset():
    """F_rms around a 110 kN static load spread by 0.02 kN: the ticks read 110.41, not 0.01
    under a "+1.104e2" an engineer can miss."""
    from lccopt.report.plotting import pyplot

    plt = pyplot()
    fig, ax = plt.subplots()
    ax.plot([0, 1], [110.405, 110.428])
    fig.canvas.draw()
    assert ax.yaxis.get_major_formatter().get_offset() == ""
    assert all(float(t.get_text().replace("\u2212", "-")) > 110 for t in ax.get_yticklabels()
               if t.get_text())
    plt.close(fig)
