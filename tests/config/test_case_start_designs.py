"""optimisation.start_designs: designs written as status shows them, checked against the case's
variables, and one line naming file, line and key for each kind of bad one."""

import numpy as np
import pytest

from lccopt.config import load_case, parse_design
from lccopt.errors import CaseError
from tests.conftest import CONFIGS

REFERENCE = CONFIGS / "reference.yaml"


def case_with(tmp_path, starts: str, budget: int = 30):
    path = tmp_path / "c.yaml"
    path.write_text(f"extends: {REFERENCE}\nname: c\noptimisation:\n  objectives: [F_max]\n"
                    f"  budget: {budget}\n  start_designs:\n{starts}")
    return path


def test_values_with_units_bare_si_and_variables_left_out(tmp_path):
    case = load_case(case_with(tmp_path, (
        "    - {x_r1: 539.6 MN/m, x_r2: 158600 kN/m, x_r3: 5.0e7, x_n: 0, x_s1: 70 cm,\n"
        "       x_s2: 0.7 m, x_s3: 0.3, x_l: 1.2 m}\n"
        "    - {x_n: 3}\n")))
    first, second = case.start_designs
    np.testing.assert_allclose(first, [539.6e6, 158.6e6, 50e6, 0, 7, 7, 3, 12])
    expected = case.reference.copy()
    expected[3] = 3
    np.testing.assert_array_equal(second, expected)
    # the optimiser proposes them right after the reference design
    from lccopt.problem import Problem

    given = Problem.from_case(case).space().given
    np.testing.assert_allclose(given, [case.reference, first, second])


def test_the_reference_and_repeats_are_proposed_once(tmp_path):
    case = load_case(case_with(tmp_path, "    - {x_n: 8}\n    - {x_n: 2}\n    - {x_n: 2}\n"))
    assert len(case.start_designs) == 1 and case.start_designs[0][3] == 2


def test_a_case_without_start_designs_resolves_as_before(tmp_path):
    path = tmp_path / "plain.yaml"
    path.write_text(f"extends: {REFERENCE}\nname: plain\n")
    case = load_case(path)
    assert case.start_designs == () and "start_designs" not in case.resolved


@pytest.mark.parametrize("starts, key, words", [
    ("    - {x_q1: 3}\n", "start_designs[0].x_q1", "not a design variable of this case"),
    ("    - {x_r1: 539.6}\n", "start_designs[0].x_r1", "a bare number is in N/m: write 539.6 MN/m"),
    ("    - {x_r1: 2000 MN/m}\n", "start_designs[0].x_r1", "outside [50, 1200] MN/m"),
    ("    - {x_r1: 500 MN}\n", "start_designs[0].x_r1", "unknown unit 'MN'"),
    ("    - {x_n: 2.5}\n", "start_designs[0].x_n", "must be a whole number"),
    ("    - {x_n: 2 m}\n", "start_designs[0].x_n", "takes a plain number"),
    ("    - {x_s1: 0.75 m}\n", "start_designs[0].x_s1", "not a multiple of 0.1 m"),
    ("    - {x_n: [1]}\n", "start_designs[0].x_n", "expected a number"),
    ("    - {x_n: .nan}\n", "start_designs[0].x_n", "outside"),
    ("    - 5\n", "start_designs[0]", "expected a mapping of design variables"),
    ("    {x_n: 1}\n", "start_designs", "expected a list of designs"),
])
def test_bad_start_designs_name_file_line_and_key(tmp_path, starts, key, words):
    with pytest.raises(CaseError) as err:
        load_case(case_with(tmp_path, starts))
    message = str(err.value)
    line = 7 if "[" in key else 6          # the design's line, else the key's
    assert message.startswith(f"{tmp_path / 'c.yaml'}:{line}: optimisation.{key}: "), message
    assert words in message and "\n" not in message


def test_more_designs_than_the_budget(tmp_path):
    starts = "".join(f"    - {{x_n: {n}}}\n" for n in range(4))
    with pytest.raises(CaseError, match=r"c\.yaml:6: optimisation\.start_designs: 4 designs and "
                                        r"the reference design exceed the budget of 4"):
        load_case(case_with(tmp_path, starts, budget=4))


def test_check_prints_them_and_a_bad_one_exits_2(tmp_path, run_cli):
    good = case_with(tmp_path, "    - {x_r1: 540 MN/m, x_s3: 0.3 m}\n")
    out = run_cli("check", good)
    assert out.returncode == 0, out.stderr
    assert "start design 1: x_r1=540 MN/m, x_r2=1120 MN/m" in out.stdout
    bad = case_with(tmp_path, "    - {x_r1: 540 MN/m, x_s3: 0.2 m}\n")
    out = run_cli("check", bad)
    assert out.returncode == 2
    assert out.stderr.strip().splitlines() == [
        f"lccopt: error: {bad}:7: optimisation.start_designs[0].x_s3: x_s3 = 0.2 m is outside "
        f"[0.3, 0.7] m"]


def test_a_design_as_status_prints_it(tmp_path):
    """Copied from `lccopt status` (wrapped over two lines): the same as the mapping."""
    text = ('    - "x_r1=539.6 MN/m, x_r2=158.6 MN/m, x_r3=50 MN/m, x_n=0, x_s1=0.7 m,\n'
            '       x_s2=0.7 m, x_s3=0.3 m, x_l=0 m"\n')
    case = load_case(case_with(tmp_path, text))
    np.testing.assert_allclose(case.start_designs[0], [539.6e6, 158.6e6, 50e6, 0, 7, 7, 3, 0])
    with pytest.raises(CaseError, match=r"c\.yaml:7: optimisation\.start_designs\[0\]: expected "
                                        r"name=value pairs, like 'x_r1=540 MN/m, x_n=0', got "
                                        r"'x_r1 540 MN/m'"):
        load_case(case_with(tmp_path, '    - "x_r1 540 MN/m, x_n=0"\n'))
    with pytest.raises(CaseError, match=r"c\.yaml:7: optimisation\.start_designs\[0\]\.x_n: "
                                        r"x_n = -1 is outside"):
        load_case(case_with(tmp_path, '    - "x_r1=540 MN/m, x_n=-1"\n'))


def test_a_pad_in_n_per_m_is_kept_to_the_last_digit(tmp_path):
    """Another run's optimum written in SI is that design, not one a rounding away."""
    pads = [539558244.514084, 158577803.97069946, 1197636854.0833058]
    text = "    - {" + ", ".join(f"x_r{i + 1}: {p!r}" for i, p in enumerate(pads)) + "}\n"
    case = load_case(case_with(tmp_path, text))
    assert list(case.start_designs[0][:3]) == pads


def test_design_option_takes_a_design_as_status_prints_it():
    """--design "x_r1=540 MN/m, ..." (copied from status) is the same design as the
    positional form; a bare pad value is caught by its bounds and told how to write it."""
    case = load_case(REFERENCE)
    named = parse_design("x_r1=539.6 MN/m, x_r2=158.6 MN/m, x_r3=50 MN/m, x_n=0, x_s1=0.7 m,\n"
                         "     x_s2=0.7 m, x_s3=0.3 m, x_l=0 m", case)
    np.testing.assert_allclose(named, parse_design("539.6,158.6,50,0,0.7,0.7,0.3,0", case))
    partial = parse_design("x_n=3", case)
    assert partial[3] == 3 and np.array_equal(np.delete(partial, 3), np.delete(case.reference, 3))
    with pytest.raises(ValueError, match=r"a bare number is in N/m: write 539\.6 MN/m\?"):
        parse_design("x_r1=539.6", case)
    with pytest.raises(ValueError, match=r"x_q is not a design variable of this case"):
        parse_design("x_q=1", case)
