"""Lengths tied to the layout: the force zone ends at a named point of the layout, so that a
case with another slab length needs no second edit; a zone that would end outside the ERS is
refused with the fix (never reinterpreted); the design space must fit the layout; older cases
(force_zone_after_interface) load with their meaning, and their resolved copies unchanged."""

import h5py
import pytest

from lccopt.config import load_case
from lccopt.config.zones import interfaces, zone_end_x
from lccopt.errors import CaseError
from tests.conftest import CHEAP_SIMULATION, CONFIGS, ROOT

REFERENCE = CONFIGS / "reference.yaml"
GOLDEN = ROOT / "tests" / "data" / "golden"

ONE_SLAB = f"""\
extends: {REFERENCE}
name: one-slab
track:
  ers:
    slab_lengths: [9.0]
"""
OLD_ZONE = "evaluation:\n  force_zone_end: null\n  force_zone_after_interface: 12.0\n"


def write(tmp_path, text, name="c.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def error(path) -> str:
    with pytest.raises(CaseError) as exc:
        load_case(path)
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


def test_the_reference_zone_ends_2_m_before_the_far_edge_of_the_ers():
    case = load_case(REFERENCE)
    assert case.evaluation["force_zone_end"] == {"at": "exit_interface", "offset": -2.0}
    assert zone_end_x(case.data) == pytest.approx(100.0 + 12.0 - 2.0)


def test_a_nine_metre_slab_moves_the_zone_end_with_it(tmp_path, run_cli):
    case = write(tmp_path, ONE_SLAB + CHEAP_SIMULATION)
    r = run_cli("check", case)
    assert r.returncode == 0, r.stderr
    assert ("force to 2 m before the exit interface,\n        7 m past the entry slab edge"
            in r.stdout)
    # and the Type II strip's range with it: the whole ERS, by default
    assert "x_l [0, 9] m in 0.1 m steps" in r.stdout
    r = run_cli("simulate", case, "--out", tmp_path / "out", "--no-plots")
    assert r.returncode == 0, r.stderr
    assert "7 m past the entry slab edge" in r.stdout
    with h5py.File(tmp_path / "out" / "simulation.h5") as f:
        info = f["info"].attrs
        assert info["interface_exit"] == pytest.approx(109.0)
        assert info["zone_end"] == pytest.approx(107.0)
        force = f["histories/contact_force"][()]
        pos = f["histories/wheel_position"][()]
        zone = f["histories/in_force_zone"][()].astype(bool)
        f_max = f["objectives"].attrs["F_max"]
    # the zone is on the slab: every force counted was measured before the exit interface
    assert pos[zone].max() <= 107.0 + 1e-9 and pos[zone].max() > 106.0
    # the objective is that of the stored forces (and the forces at the zone's ends)
    assert f_max >= force[zone].max() - force[zone].min() - 1e-6


def test_an_older_zone_that_ends_in_the_exit_ballast_is_refused_with_the_fix(tmp_path, run_cli):
    case = write(tmp_path, ONE_SLAB + OLD_ZONE)
    r = run_cli("check", case)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1
    line = lines[0]
    assert f"{case}:8: evaluation.force_zone_after_interface: 12 m ends 3 m past the 9 m ERS" \
        in line
    assert "write force_zone_end: {at: exit_interface, offset: -2}" in line
    r = run_cli("simulate", case, "--out", tmp_path / "out")
    assert r.returncode == 2 and not (tmp_path / "out").exists()


def test_the_older_form_keeps_its_meaning_and_its_resolved_text(tmp_path):
    case = load_case(write(tmp_path, f"extends: {REFERENCE}\nname: old\n" + OLD_ZONE))
    assert zone_end_x(case.data) == pytest.approx(112.0)        # 12 m from the entry side
    assert "force_zone_end" not in case.resolved
    assert case.scenario().zones.force_zone_end.at == "entry_interface"
    # a run's resolved copy written before force_zone_end existed reads back to the same text,
    # so its fingerprint holds and the run can be resumed from its copy
    for run in ("scalar-F_max", "composite-asf", "sleeper-energies"):
        copy = GOLDEN / run / "case.yaml"
        assert load_case(copy, resolved=True).resolved == copy.read_text()


def test_a_resolved_case_resolves_to_itself(tmp_path):
    for name in ("reference.yaml", "traffic.yaml", "moo.yaml"):
        first = load_case(CONFIGS / name).resolved
        again = load_case(write(tmp_path, first, name), resolved=True).resolved
        assert again == first


@pytest.mark.parametrize("zone, key, words", [
    ("  force_zone_end: {at: exit_interface, offset: 1.0}\n", "evaluation.force_zone_end.offset",
     "{at: exit_interface, offset: 1} ends 1 m past the 12 m ERS, in the exit ballast"),
    ("  force_zone_end: {at: entry_interface, offset: -1.0}\n", "evaluation.force_zone_end.offset",
     "ends 1 m before the entry interface: the force zone must reach the ERS"),
    ("  force_zone_end: {at: far_edge}\n", "evaluation.force_zone_end.at",
     "must be one of entry_interface, exit_interface"),
    ("  force_zone_after_interface: 5.0\n", "evaluation.force_zone_after_interface",
     "give force_zone_end or force_zone_after_interface, not both"),
])
def test_a_zone_outside_the_ers_is_refused_naming_the_key(tmp_path, zone, key, words):
    p = write(tmp_path, f"extends: {REFERENCE}\nname: z\nevaluation:\n" + zone)
    msg = error(p)
    assert msg.startswith(f"{p}:4: {key}: ") or msg.startswith(f"{p}:") and f" {key}: " in msg
    assert words in msg, msg


def test_a_short_ers_under_the_inherited_zone_says_where_and_what_to_write(tmp_path):
    """A 1.5 m slab under the reference's zone end (2 m before the far edge): the line names
    the base file's key, where the user's own file set the slab, and the fix, which works."""
    p = write(tmp_path, f"extends: {REFERENCE}\nname: z\ntrack:\n  ers:\n"
                        f"    slab_lengths: [1.5 m]\n")
    msg = error(p)
    assert " evaluation.force_zone_end.offset: {at: exit_interface, offset: -2} ends 0.5 m " \
           "before the entry interface" in msg, msg
    assert f"1.5 m long here ({p}:5); write force_zone_end: {{at: exit_interface, offset: O}} " \
           "with O from -1.5 to 0 in the case" in msg, msg
    p.write_text(p.read_text() + "evaluation:\n  force_zone_end: {at: exit_interface, "
                                 "offset: -1.5}\n", encoding="utf-8")
    data = load_case(p).data
    assert zone_end_x(data) == pytest.approx(interfaces(data)[0])   # the entry interface


def test_check_warns_of_a_zone_that_may_miss_the_force_peak_past_the_entry(run_cli, tmp_path):
    """A 2 m slab under the default zone end (2 m before the far edge) measures nothing of
    the ERS; a zone ending 0.5 m into a 12 m ERS can miss the peak at 0.63 m; 3 m is enough
    (1/beta of the paper's rail on its compound: 0.92 m). Warned, not refused: still valid."""
    for text, words in [
            ("track:\n  ers:\n    slab_lengths: [2 m]\n",
             ["reaches 0 m into the ERS", "0.92 m", "on a 2 m ERS the exit interface's reach"]),
            ("evaluation:\n  force_zone_end: {at: entry_interface, offset: 0.5}\n",
             ["reaches 0.5 m into the ERS", "may lie outside it, and F_max with it ("]),
            ("track:\n  ers:\n    slab_lengths: [3 m]\n", [])]:
        write(tmp_path, f"extends: {REFERENCE}\nname: z\n" + text)
        r = run_cli("check", "c.yaml")
        assert r.returncode == 0, r.stderr
        out = " ".join(r.stdout.split())
        assert ("warning: the force zone" in out) == bool(words), out
        assert all(w in out for w in words), out
        assert all(len(line) <= 80 for line in r.stdout.splitlines()), r.stdout


def test_the_zone_may_end_anywhere_on_the_ers(tmp_path):
    for at, offset, x in [("entry_interface", 0.0, 100.0), ("entry_interface", 12.0, 112.0),
                          ("exit_interface", 0.0, 112.0), ("exit_interface", -11.5, 100.5)]:
        p = write(tmp_path, f"extends: {REFERENCE}\nname: z\nevaluation:\n  force_zone_end: "
                            f"{{at: {at}, offset: {offset}}}\n" + CHEAP_SIMULATION)
        case = load_case(p)
        assert zone_end_x(case.data) == pytest.approx(x)
        from lccopt.problem import evaluate
        ev = evaluate(case, case.reference)
        assert ev.info["zone_end"] == pytest.approx(x)
        inside = ev.histories["wheel_position"][ev.histories["in_force_zone"].astype(bool)]
        assert inside.max() <= x + 1e-9


@pytest.mark.parametrize("extra, key, words", [
    ("design:\n  type_ii_strip:\n    bounds: [0 m, 12 m]\n", "design.type_ii_strip.bounds",
     "upper bound 12 m is longer than the 9 m ERS: at most 9 m"),
    ("evaluation:\n  sleepers: 200\n", "evaluation.sleepers",
     "200 zone sleepers, but the entry side holds 166 at the widest spans"),
    ("evaluation:\n  sleepers: 160\n", "evaluation.sleepers",
     "do not fit the 100 m entry track with 5 m to spare"),
    ("design:\n  strengthened_sleepers:\n    bounds: [0, 170]\n",
     "design.strengthened_sleepers.bounds", "upper bound 170, but the entry side holds 166"),
])
def test_the_design_space_must_fit_the_layout(tmp_path, extra, key, words):
    msg = error(write(tmp_path, ONE_SLAB + extra))
    assert f" {key}: " in msg and words in msg, msg
