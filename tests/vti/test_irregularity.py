"""Rail irregularity input (Eqs. A.12-A.13) and reporting of contact loss."""

import numpy as np
import pytest

from lccopt.config import load_case
from lccopt.problem import evaluate
from tests.conftest import CONFIGS

REFERENCE = (CONFIGS / "reference.yaml").read_text()


def case_with_profile(tmp_path, rows):
    np.savetxt(tmp_path / "profile.csv", np.array(rows), delimiter=",")
    text = REFERENCE.replace("  run_out: 3.0", "  run_out: 3.0\n  irregularity: profile.csv")
    (tmp_path / "c.yaml").write_text(text)
    return load_case(tmp_path / "c.yaml").with_simulation(run_in=2.0)


def test_a_smooth_dip_raises_the_force_and_a_deep_one_loses_contact(tmp_path):
    smooth = load_case(CONFIGS / "reference.yaml").with_simulation(run_in=2.0)
    base = evaluate(smooth, smooth.reference)
    assert base.info["contact_loss_steps"] == 0
    # a 0.4 mm cosine dip of 1 m length at 95 m (dip = downward = positive); with the paper's
    # 57 kN static wheel load and full unsprung mass, a 1 mm dip already lifts the wheel
    xs = np.linspace(94.5, 95.5, 41)
    dip = 0.2e-3 * (1 - np.cos(2 * np.pi * (xs - 94.5)))
    ev = evaluate(case_with_profile(tmp_path, np.c_[xs, dip]), smooth.reference)
    assert ev.objectives["F_max"] > 3 * base.objectives["F_max"]
    assert ev.info["contact_loss_steps"] == 0
    # before the dip nothing changed
    before = ev.histories["wheel_position"] < 94.4
    assert np.allclose(ev.histories["contact_force"][before],
                       base.histories["contact_force"][before])
    # a 10 mm dip over 0.2 m: the wheel flies; the force goes negative and it is reported
    xs = np.linspace(94.9, 95.1, 21)
    dip = 5e-3 * (1 - np.cos(2 * np.pi * (xs - 94.9) / 0.2))
    ev = evaluate(case_with_profile(tmp_path, np.c_[xs, dip]), smooth.reference)
    assert ev.info["contact_loss_steps"] > 0
    assert 94.9 < ev.info["contact_loss_first_position"] < 95.5
    assert ev.histories["contact_force"].min() <= 0


def test_bad_profile_file_is_a_case_error(tmp_path):
    from lccopt.errors import CaseError

    (tmp_path / "profile.csv").write_text("1,0.002\n0,0.003\n")       # positions not increasing
    (tmp_path / "c.yaml").write_text(
        REFERENCE.replace("  run_out: 3.0", "  run_out: 3.0\n  irregularity: profile.csv"))
    with pytest.raises(CaseError, match=r"simulation\.irregularity: .*profile\.csv: line 2: "
                                        r"position 0 m does not increase"):
        load_case(tmp_path / "c.yaml")
