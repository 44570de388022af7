"""A design written by its variables' names, as status prints it (--design "x_r1=540 MN/m,
x_n=0"): the same design as the positional form, the others at the reference, and one clear
message for each kind of bad value."""

import numpy as np
import pytest

from lccopt.config import load_case, parse_design
from tests.conftest import CONFIGS

CASE = load_case(CONFIGS / "reference.yaml")


def test_a_design_as_status_prints_it_is_the_positional_one():
    named = parse_design("x_r1=539.6 MN/m, x_r2=158.6 MN/m, x_r3=50 MN/m, x_n=0, x_s1=0.7 m,\n"
                         "     x_s2=0.7 m, x_s3=0.3 m, x_l=0 m", CASE)
    np.testing.assert_allclose(named, parse_design("539.6,158.6,50,0,0.7,0.7,0.3,0", CASE))
    np.testing.assert_allclose(parse_design("x_r1=158600 kN/m, x_s1=70 cm, x_l=1.2 m", CASE)
                               [[0, 4, 7]], [158.6e6, 7, 12])


def test_variables_left_out_keep_their_reference_values():
    partial = parse_design("x_n=3", CASE)
    assert partial[3] == 3
    np.testing.assert_array_equal(np.delete(partial, 3), np.delete(CASE.reference, 3))


def test_a_pad_in_n_per_m_is_kept_to_the_last_digit():
    """A design copied in SI is that design, not one a rounding away (MN/m and back)."""
    pads = [539558244.514084, 158577803.97069946, 1197636854.0833058]
    x = parse_design(", ".join(f"x_r{i + 1}={p!r}" for i, p in enumerate(pads)), CASE)
    assert list(x[:3]) == pads


@pytest.mark.parametrize("text, words", [
    ("x_q1=3", "x_q1 is not a design variable of this case (its variables: x_r1, x_r2"),
    ("x_r1=539.6", "x_r1 = 0.0005396 MN/m is outside [50, 1200] MN/m (a bare number is in N/m: "
                   "write 539.6 MN/m?)"),
    ("x_r1=2000 MN/m", "outside [50, 1200] MN/m"),
    ("x_r1=500 MN", "unknown unit 'MN' (did you mean 'MN/m'?)"),
    ("x_n=2.5", "must be a whole number"),
    ("x_n=2 m", "takes a plain number"),
    ("x_s1=0.75 m", "x_s1 = 0.75 m is not a multiple of 0.1 m"),
    ("x_n=many", "expected a number or a number with its unit, got 'many'"),
    ("x_n=3, x_n=4", "x_n is given twice"),
    ("x_n=1," * 50, "x_n is given twice"),
    ("x_r1 540 MN/m, x_n=0", "expected name=value pairs, like 'x_r1=540 MN/m, x_n=0', got "
                             "'x_r1 540 MN/m'"),
])
def test_bad_values_say_what_is_wrong(text, words):
    with pytest.raises(ValueError) as err:
        parse_design(text, CASE)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_simulate_takes_it_and_a_bad_one_exits_2(tmp_path, run_cli):
    bad = run_cli("simulate", CONFIGS / "reference.yaml", "--design", "x_s3=0.2 m", "--no-plots",
                  "--out", tmp_path / "sim")
    assert bad.returncode == 2
    assert bad.stderr.strip().splitlines() == [
        "lccopt: error: --design: x_s3 = 0.2 m is outside [0.3, 0.7] m"]
