"""The track as built rather than as drawn: random fields over the sleepers, the case's
uncertainty: section, its realisations in the model and the robust statistics."""

from __future__ import annotations

import math
import re
import subprocess
from dataclasses import replace

import numpy as np
import pytest

from lccopt.config import load_case
from lccopt.config.uncertainty import fingerprint, uncertainty_lines
from lccopt.errors import CaseError
from lccopt.problem import evaluate
from lccopt.uncertainty import fields
from lccopt.uncertainty import statistics as stats
from lccopt.vti.passage import simulate_passage as simulate
from lccopt.vti.specs import TrackVariation
from lccopt.vti.track import build_track
from tests.conftest import CHEAP_SIMULATION, REFERENCE, lccopt_command, subprocess_env


def robust_case(tmp_path, section: str, objectives: str = "", name: str = "u") -> object:
    text = (f"extends: {REFERENCE}\nname: {name}\n" + CHEAP_SIMULATION + "uncertainty:\n"
            + section + (f"optimisation:\n  objectives: [{objectives}]\n  budget: 10\n"
                         if objectives else ""))
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return path


# -- random fields ---------------------------------------------------------------------------

def draws(x, ell, n=3000, stream=1):
    return np.array([fields.gaussian_field(x, ell, fields.generator(7, stream, r))
                     for r in range(n)])


@pytest.mark.parametrize("distribution", ["lognormal", "uniform"])
def test_factors_have_the_stated_mean_and_coefficient_of_variation(distribution):
    z = draws(np.arange(0, 30, 0.6), 0.0)
    f = fields.factors(z, distribution, 1.2, 0.3)
    assert f.mean() == pytest.approx(1.2, rel=0.01)
    assert f.std() / f.mean() == pytest.approx(0.3, rel=0.03)
    assert f.min() > 0


@pytest.mark.parametrize("ell", [0.0, 1.0, 3.0, 20.0])
def test_the_field_is_standard_with_rose_s_gaussian_correlation(ell):
    x = np.arange(0, 30, 0.6)
    z = draws(x, ell)
    assert z.var(axis=0).mean() == pytest.approx(1.0, abs=4 * math.sqrt(2 / len(z)))
    for lag in (1, 3, 8):
        rho = np.mean([np.corrcoef(z[:, i], z[:, i + lag])[0, 1] for i in range(0, 40, 5)])
        expected = math.exp(-math.pi / 4 * (lag * 0.6 / ell) ** 2) if ell else 0.0
        assert rho == pytest.approx(expected, abs=0.04), (ell, lag)


def test_a_coefficient_of_variation_of_0_gives_factors_of_exactly_1():
    z = draws(np.arange(0, 30, 0.6), 3.0, n=5)
    for d in fields.DISTRIBUTIONS:
        assert np.all(fields.factors(z, d, 1.0, 0.0) == 1.0)


def test_a_fraction_p_of_the_sleepers_hang():
    z = draws(np.arange(0, 30, 0.6), 2.0, n=2000)
    assert fields.hanging(z, 0.15).mean() == pytest.approx(0.15, abs=0.01)
    assert not fields.hanging(z, 0.0).any() and fields.hanging(z, 1.0).all()


# -- the case section ------------------------------------------------------------------------

SECTION = """\
  realisations: 3
  seed: 5
  support_stiffness: {correlation_length: 3 m}
  support_damping: {}
  pad_stiffness: {cov: 0.1, mean: 1.1}
  initial_void: {probability: 0.1, gap: 0.5 mm}
"""


def test_same_seed_same_realisations_another_seed_others_and_more_keep_the_first(tmp_path):
    a, b = (load_case(robust_case(tmp_path, SECTION)) for _ in range(2))
    assert a.realisations == 3 and fingerprint(a.variations) == fingerprint(b.variations)
    for va, vb in zip(a.variations, b.variations):
        for name in ("support_stiffness", "support_damping", "pad_stiffness", "void"):
            for pa, pb in zip(getattr(va, name), getattr(vb, name)):
                np.testing.assert_array_equal(pa, pb)
    other = load_case(robust_case(tmp_path, SECTION.replace("seed: 5", "seed: 6"), name="o"))
    assert fingerprint(other.variations) != fingerprint(a.variations)
    more = load_case(robust_case(tmp_path, SECTION.replace("realisations: 3", "realisations: 5"),
                                 name="m"))
    assert fingerprint(more.variations[:3]) == fingerprint(a.variations)
    v = a.variations[0]
    # damping follows stiffness sleeper by sleeper (the same field, the same cov)
    np.testing.assert_array_equal(v.support_damping[0], v.support_stiffness[0])
    assert v.pad_stiffness[0].mean() == pytest.approx(1.1, rel=0.05)
    # as many entry values as any design can have sleepers (the shortest spans give the
    # most), one for every exit sleeper
    x = a.lower.copy()
    track = build_track(a.scenario(), a.track_design(x))
    assert v.support_stiffness[0].size >= len(track.entry_sleeper_x)
    assert v.support_stiffness[1].size == len(track.exit_sleeper_x)


def test_the_seed_defaults_to_the_optimisation_seed(tmp_path):
    base = SECTION.replace("  seed: 5\n", "")
    a = load_case(robust_case(tmp_path, base, "F_max", name="a"))
    text = robust_case(tmp_path, base, "F_max", name="b").read_text() + "  seed: 9\n"
    (tmp_path / "b.yaml").write_text(text)
    b = load_case(tmp_path / "b.yaml")
    c = load_case(robust_case(tmp_path, SECTION.replace("seed: 5", "seed: 9"), name="c"))
    assert fingerprint(b.variations) == fingerprint(c.variations)
    assert fingerprint(a.variations) != fingerprint(b.variations)


@pytest.mark.parametrize("section, objectives, key, words", [
    ("  realisations: 3\n  support_stiffness: {cov: -0.1}\n", "",
     "uncertainty.support_stiffness.cov", "must be >= 0"),
    ("  realisations: 0\n  support_stiffness: {}\n", "", "uncertainty.realisations",
     "must be >= 2"),
    ("  realisations: 100000\n  support_stiffness: {}\n", "", "uncertainty.realisations",
     "must be <= 500"),
    ("  realisations: 3\n  support_stifness: {}\n", "", "uncertainty.support_stifness",
     "did you mean 'support_stiffness'"),
    ("  realisations: 3\n  support_stiffness: {distribution: uniform, cov: 0.55}\n", "",
     "uncertainty.support_stiffness.cov", "too wide for a uniform factor"),
    ("  realisations: 3\n  support_stiffness: {distribution: normal}\n", "",
     "uncertainty.support_stiffness.distribution", "must be one of lognormal, uniform"),
    ("  realisations: 3\n  pad_stiffness: {mean: 1.1}\n", "", "uncertainty.pad_stiffness",
     "missing key 'cov'"),
    ("  realisations: 3\n", "", "uncertainty", "no quantity varies"),
    ("  realisations: 3\n  settlement_coefficient: {cov: 0.2}\n", "",
     "uncertainty.settlement_coefficient", "needs a degradation: section"),
    ("  realisations: 3\n  support_stiffness: {}\n", "q90(F_mx)", "optimisation.objectives",
     "unknown name 'q90(F_mx)'"),
    # a newcomer's guesses: the statistics' forms are named, and the closest one
    ("  realisations: 3\n  support_stiffness: {}\n", "q90(F_mx)", "optimisation.objectives",
     "(did you mean 'q90(F_max)'?)"),
    ("  realisations: 3\n  support_stiffness: {}\n", "p_beat(F_max)",
     "optimisation.objectives", "mean(...), q1(...) to q99(...) or p_worse(...) (did you "
     "mean 'p_worse(F_max)'?)"),
    ("  realisations: 3\n  support_stiffness: {}\n", "Fmax", "optimisation.objectives",
     "(did you mean 'F_max'?)"),
    ("  realisations: 3\n  support_stiffness: {}\n", "q90(years_to_limit)",
     "optimisation.objectives", "reported, not minimised"),
    ("  realisations: 3\n  support_stiffness: {}\n", "mean(max_void)",
     "optimisation.objectives", "needs a degradation: section"),
])
def test_bad_uncertainty_input_is_one_line_naming_file_line_and_key(tmp_path, section,
                                                                    objectives, key, words):
    path = robust_case(tmp_path, section, objectives)
    with pytest.raises(CaseError) as e:
        load_case(path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"{path}:{key_line(path, key)}: {key}: "), msg
    assert words in msg, msg


def key_line(path, key: str) -> int:
    """The line of the file where the key's last part is written."""
    last = key.split(".")[-1]
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1)
                if f"{last}:" in line)


@pytest.mark.parametrize("section, key", [
    ("  realisations: 3\n  support_stiffness:\n    correlation_length: 3 m\n    cov: -0.1\n",
     "uncertainty.support_stiffness.cov"),
    ("  realisations: 0\n  support_stiffness: {}\n", "uncertainty.realisations"),
    ("  realisations: 100000\n  support_stiffness: {}\n", "uncertainty.realisations"),
    ("  realisations: 3\n  ballast_stiffness: {}\n", "uncertainty.ballast_stiffness"),
    ("  realisations: 400\n  support_stiffness: {}\n", "uncertainty.realisations"),
])
def test_check_refuses_bad_uncertainty_in_one_line_and_exits_2(tmp_path, section, key):
    """As a user meets it: a negative spread, 0 or absurdly many realisations, an unknown
    quantity, more realisations than the cost cap allows (the paper's 1.5 us steps)."""
    path = robust_case(tmp_path, section)
    if "400" in section:
        path.write_text(path.read_text().replace(CHEAP_SIMULATION,
                                                 "simulation: {time_step: 1.5e-6}\n"))
    r = subprocess.run(lccopt_command() + ["check", str(path)], capture_output=True, text=True,
                       env=subprocess_env())
    assert r.returncode == 2, r
    line, = r.stderr.strip().splitlines()
    assert line.startswith(f"lccopt: error: {path}:{key_line(path, key)}: {key}: "), line
    assert r.stdout == ""


def test_a_robust_objective_without_the_section_and_check_exits_2(tmp_path):
    path = tmp_path / "n.yaml"
    path.write_text(f"extends: {REFERENCE}\nname: n\noptimisation:\n  objectives: [q90(F_max)]\n"
                    f"  budget: 10\n")
    r = subprocess.run(lccopt_command() + ["check", str(path)], capture_output=True, text=True,
                       env=subprocess_env())
    assert r.returncode == 2, r
    line, = r.stderr.strip().splitlines()
    assert line.startswith(f"lccopt: error: {path}:4: optimisation.objectives: q90(F_max)"), line
    assert "needs an uncertainty: section" in line


def test_too_many_realisations_for_a_design_are_refused_with_how_many_fit(tmp_path):
    path = robust_case(tmp_path, "  realisations: 500\n  support_stiffness: {}\n")
    # the paper's simulation at 1.5 us steps: 460,000 steps of 2,700 dofs, 501 times
    path.write_text(path.read_text().replace(CHEAP_SIMULATION, "simulation: {time_step: 1.5e-6}\n"))
    with pytest.raises(CaseError, match=r"uncertainty\.realisations: 500 realisations .* at "
                                        r"most \d+ realisations here") as e:
        load_case(path)
    most = int(re.search(r"at most (\d+) realisations here", str(e.value)).group(1))
    assert 2 <= most < 500
    # the cap check prints is the one it enforces: `most` loads, one more does not
    path.write_text(path.read_text().replace("realisations: 500", f"realisations: {most}"))
    assert (f"    at most {most} realisations: the cost cap, about 6 hours of one core a "
            f"design") in uncertainty_lines(load_case(path))
    path.write_text(path.read_text().replace(f"realisations: {most}",
                                             f"realisations: {most + 1}"))
    with pytest.raises(CaseError, match=f"at most {most} realisations here"):
        load_case(path)


def test_check_prints_the_realisations_and_what_they_cost(tmp_path):
    path = robust_case(tmp_path, SECTION, "q90(F_max), E_max")
    r = subprocess.run(lccopt_command() + ["check", str(path)], capture_output=True, text=True,
                       env=subprocess_env())
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "uncertainty: 3 realisations of the track (seed 5)" in out
    assert "support_stiffness: lognormal, cov 0.25, correlation 3 m" in out
    assert "support_damping: lognormal, cov 0.25, support_stiffness's field" in out
    assert "pad_stiffness: lognormal, mean 1.1, cov 0.1, independent" in out
    assert "initial_void: 10% of the sleepers hang, gap 0.5 mm" in out
    assert "per design: 4 tracks (the drawing and 3 realisations) = 4 tasks" in out
    assert "budget 10: 40 tasks (4 x a deterministic run)" in out
    assert "at most 500 realisations: the section's limit" in out
    assert max(len(line) for line in out.splitlines()[1:]) <= 80


def test_a_realisation_reaches_the_settlement_prediction_s_sleepers(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(f"extends: {REFERENCE.parent / 'settlement.yaml'}\nname: s\nuncertainty:\n"
                    f"  realisations: 2\n  settlement_coefficient: {{cov: 0.2}}\n"
                    f"  initial_void: {{probability: 0.3, gap: 1 mm}}\n")
    case = load_case(path)
    drawn = case.degradation_spec()
    assert drawn.sleeper_gamma is None and drawn.initial_gap is None
    n = drawn.settling_sleepers
    for r, v in enumerate(case.variations):
        spec = case.part_case(-1, r).degradation_spec()
        assert spec.sleeper_gamma == tuple(v.settlement[0][:n])
        assert spec.initial_gap == tuple(v.void[0][:n])
        assert len(set(spec.sleeper_gamma)) == n and 0 < spec.initial_gap.count(0.0) < n
        # the same track in the paper's passages of the prediction
        assert spec.traffic[0].scenario.variation is v


# -- realisations in the model ---------------------------------------------------------------

@pytest.mark.slow
def test_a_stiffer_support_everywhere_is_the_drawing_with_a_stiffer_support(tmp_path):
    """A realisation's factors reach each sleeper's support: all at 1.3 is the same track as
    one whose support (strengthened sleepers' too) is drawn 1.3 times stiffer."""
    case = load_case(robust_case(tmp_path, "  realisations: 2\n  support_stiffness: {}\n"))
    x = case.reference
    ones = [np.full(p.size, 1.3) for p in case.variations[0].support_stiffness]
    varied = replace(case.scenario(), variation=TrackVariation(support_stiffness=tuple(ones)))
    sc = case.scenario()
    track = replace(sc.track, support=replace(sc.track.support,
                                              stiffness=1.3 * sc.track.support.stiffness),
                    strengthened_sleeper=replace(
                        sc.track.strengthened_sleeper,
                        support_stiffness=1.3 * sc.track.strengthened_sleeper.support_stiffness))
    a = simulate(varied, case.track_design(x)).objectives
    b = simulate(replace(sc, track=track), case.track_design(x)).objectives
    nominal = simulate(sc, case.track_design(x)).objectives
    for k in a:
        assert a[k] == pytest.approx(b[k], rel=1e-10), k
    assert a["F_max"] != pytest.approx(nominal["F_max"], rel=1e-3)


@pytest.mark.slow
def test_a_sleeper_hanging_over_a_deep_void_dissipates_nothing(tmp_path):
    case = load_case(robust_case(tmp_path, "  realisations: 2\n  support_stiffness: {}\n"))
    design = case.track_design(case.reference)
    entry, exit_ = (np.zeros(p.size) for p in case.variations[0].support_stiffness)
    nominal = simulate(case.scenario(), design)
    none = simulate(replace(case.scenario(), variation=TrackVariation(void=(entry, exit_))),
                    design)
    assert none.objectives == nominal.objectives       # no void: the linear model, bit for bit
    entry[4] = 0.01                                     # 10 mm: the wheel never closes it
    ev = simulate(replace(case.scenario(), variation=TrackVariation(void=(entry, exit_))),
                  design)
    energy = ev.histories["sleeper_energy"]
    assert energy[4] == 0.0 and np.all(np.delete(energy, 4) > 0)
    assert ev.info["void_sleepers"] == 1
    assert ev.objectives["E_max"] > nominal.objectives["E_max"]


@pytest.mark.slow
def test_realisations_with_no_spread_are_the_drawing_bit_for_bit(tmp_path):
    section = ("  realisations: 2\n  support_stiffness: {cov: 0}\n  support_damping: {cov: 0}\n"
               "  pad_stiffness: {cov: 0}\n  initial_void: {probability: 0.5, gap: 0}\n")
    case = load_case(robust_case(tmp_path, section))
    drawn = evaluate(case, case.reference).objectives
    for r in range(case.realisations):
        assert evaluate(case.part_case(-1, r), case.reference).objectives == drawn



SETTLEMENT_CHEAP = ("simulation: {time_step: 1.0e-3, element_length: 0.1, "
                    "far_element_length: 0.6, run_in: 2.0, run_out: 1.0}\n")


@pytest.mark.slow
def test_a_settlement_prediction_with_no_spread_is_the_drawing_s_and_a_spread_moves_it(
        tmp_path):
    """The settlement coefficient's and the initial voids' fields reach the prediction: at
    cov 0 and gaps of 0 every settlement objective is the drawing's bit for bit; with a 30 %
    spread of the coefficient and 1 mm voids under some sleepers the rail settles otherwise."""
    base = (f"extends: {REFERENCE.parent / 'vehicles' / 'virm-bogie.yaml'}\n"
            + SETTLEMENT_CHEAP + "degradation:\n  passages_per_year: 5.0e5\n"
            "  horizon_years: 1\n  settling_sleepers: 10\n  tolerance: 4 kN\n")
    flat = tmp_path / "flat.yaml"
    flat.write_text(base + "name: flat\nuncertainty:\n  realisations: 2\n"
                    "  settlement_coefficient: {cov: 0}\n"
                    "  initial_void: {probability: 0.5, gap: 0}\n")
    spread = tmp_path / "spread.yaml"
    spread.write_text(base + "name: spread\nuncertainty:\n  realisations: 2\n"
                      "  settlement_coefficient: {cov: 0.3}\n"
                      "  initial_void: {probability: 0.3, gap: 1 mm}\n")
    case = load_case(flat)
    x = case.reference
    drawn = evaluate(case, x).objectives
    assert set(drawn) >= {"level_d1_max", "max_void", "F_max"}
    assert evaluate(case.part_case(-1, 1), x).objectives == drawn
    other = load_case(spread)
    varied = evaluate(other.part_case(-1, 0), x).objectives
    assert evaluate(other, x).objectives == drawn        # the drawing is the same track
    assert varied["level_d1_max"] != pytest.approx(drawn["level_d1_max"], rel=1e-3)


# -- robust statistics -----------------------------------------------------------------------

def test_a_statistic_is_described_in_words_from_its_objective():
    from lccopt.vti.response import OBJECTIVE_DOC, objective_doc

    f = OBJECTIVE_DOC["F_max"]
    assert objective_doc("q90(F_max)") == f"90 % quantile over the realisations of the track of {f}"
    assert objective_doc("q5(F_max@v160)").startswith("5 % quantile over")
    assert objective_doc("mean(E_max@v160)") == \
        f"mean over the realisations of the track of {OBJECTIVE_DOC['E_max']}"
    assert objective_doc("p_worse(F_max)") == \
        f"probability that {f} is not below the reference design's, on a realisation of the track"
    assert objective_doc("F_max#3") == objective_doc("F_max@v160") == f
    assert stats.is_probability("p_worse(F_max@v160)") and not stats.is_probability("q90(F_max)")
    # a figure's axis: a probability has no unit to bracket
    from lccopt.report.data import with_unit
    from lccopt.vti.response import objective_display
    assert [with_unit(k, objective_display(k)[1]) for k in ("p_worse(F_max)", "q90(F_max)")] \
        == ["p_worse(F_max)", "q90(F_max) [kN]"]


def test_statistic_names_parse_and_their_values():
    assert stats.parse("q90(F_max)") == ("quantile", "F_max", 0.9)
    assert stats.parse("mean(E_max@fast)") == ("mean", "E_max@fast", None)
    assert stats.parse("p_worse(F_max)") == ("p_worse", "F_max", None)
    assert stats.parse("F_max") is None and stats.parse("q100(F_max)") is None
    assert stats.at_condition("q90(F_max)", "fast") == "q90(F_max@fast)"
    o = {f"F_max#{r}": v for r, v in enumerate([3.0, 1.0, 2.0, 4.0])}
    ref = {f"F_max#{r}": v for r, v in enumerate([2.0, 2.0, 2.0, 2.0])}
    assert stats.statistic("mean(F_max)", o, 4) == 2.5
    assert stats.statistic("q50(F_max)", o, 4) == 2.5
    assert stats.statistic("q90(F_max)", o, 4) == pytest.approx(3.7)
    assert stats.statistic("p_worse(F_max)", o, 4, ref) == 0.75      # ties are not better
    assert stats.statistic("p_worse(F_max)", ref, 4, ref) == 1.0
    same = {f"F_max#{r}": 0.1 + 0.2 for r in range(7)}
    assert stats.statistic("mean(F_max)", same, 7) == 0.1 + 0.2       # exact, not 0.30000000004


def test_a_paired_difference_of_tracks_shifted_by_c_is_c_exactly_and_its_interval_too():
    b = np.random.default_rng(3).lognormal(0.0, 0.25, 16) * 4e3
    for level in (None, 0.9, 0.5):
        assert stats.paired_difference(b - 250.0, b, level) == pytest.approx((-250,) * 3)
        assert stats.paired_difference(b, b, level) == (0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="same realisations"):
        stats.paired_difference(b[:15], b, 0.9)


def test_two_equal_designs_are_clearly_different_rarely_and_a_real_gain_is_seen():
    """The interval's promise on exchangeable pairs (the same distribution, correlated as two
    designs on one track are): one design 'clearly lower' about (1 - 0.95) / 2 of the time;
    a design 15 % lower on every track, with noise of its own, is seen on 16 tracks most
    of the time (about 80 %: benchmarks/robust/interval_calibration.py, docs/robust.md)."""
    rng = np.random.default_rng(11)
    lower = {0.0: 0, -0.15: 0}
    trials = 300
    for _ in range(trials):
        track = rng.standard_normal(16)
        a, b = (np.exp(0.25 * (0.95 * track + 0.31 * rng.standard_normal(16))) for _ in "ab")
        for gain in lower:
            d, low, high = stats.paired_difference(a * (1 + gain), b, 0.9)
            lower[gain] += high < 0
    assert lower[0.0] / trials < 0.05
    assert lower[-0.15] / trials > 0.6


def test_the_cost_of_a_design_fits_an_80_column_terminal_with_conditions_or_settlement(tmp_path):
    """The longest cost lines: a settlement prediction's simulations and several conditions."""
    settle = tmp_path / "s.yaml"
    settle.write_text(f"extends: {REFERENCE.parent / 'settlement.yaml'}\nname: s\nuncertainty:\n"
                      f"  realisations: 8\n  settlement_coefficient: {{cov: 0.2}}\n")
    lines = uncertainty_lines(load_case(settle))
    assert "    per design: 9 tracks (the drawing and 8 realisations):" in lines, lines
    assert any(re.fullmatch(r"      9 tasks, up to [\d,]+ simulations", ln) for ln in lines), lines
    traffic = tmp_path / "t.yaml"
    traffic.write_text(f"extends: {REFERENCE}\nname: t\nconditions:\n"
                       f"  - {{name: fast, speed: 200 km/h}}\n"
                       f"  - {{name: slow, speed: 60 km/h, direction: leave}}\n"
                       f"uncertainty:\n  realisations: 6\n  support_stiffness: {{cov: 0.3}}\n")
    lines = uncertainty_lines(load_case(traffic))
    assert lines[lines.index("    per design: 7 tracks (the drawing and 6 realisations)") + 1] \
        == "      x 2 conditions = 14 tasks", lines
    for case_lines in (uncertainty_lines(load_case(settle)), lines):
        assert max(len(line) for line in case_lines) <= 80, case_lines
