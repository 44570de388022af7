"""The default settings and integrator give the objectives of the method before issue 11
(benchmarks/support/legacy_newmark.py: its integrator at its settings, dt 0.2 ms, 10 m run-in, far
elements 0.3 m) within 0.5 %, and the two integrators agree to round-off at the same settings.
benchmarks/model/simulate_accuracy.py checks the first on 29 designs; this is a fast subset."""

import numpy as np
import pytest

from benchmarks.support.legacy_newmark import (
    REFERENCE_SETTINGS,
    evaluate_legacy,
    integrate_reference,
)
from lccopt.config import load_case
from lccopt.problem import evaluate

# seconds a test: full-length simulations
pytestmark = pytest.mark.slow

DESIGNS = {
    "reference": None,
    "paper MOO": [214e6, 155e6, 50e6, 5, 6, 7, 3, 0],
    "soft pads, Type II strip": [1015e6, 586e6, 196e6, 0, 6, 6, 7, 23],   # F_min at the zone's end
}


@pytest.mark.parametrize("name", list(DESIGNS))
def test_default_settings_match_the_method_before_issue_11(name):
    case = load_case("configs/reference.yaml")
    design = DESIGNS[name]
    x = case.reference if design is None else case.check_design(np.array(design, float))
    new = evaluate(case, x)
    old = evaluate_legacy(case.with_simulation(**REFERENCE_SETTINGS), x)
    assert new.info["n_steps"] < old.info["n_steps"] / 3      # fewer steps: most of the speed-up
    for key in ("F_max", "E_max"):
        assert new.objectives[key] == pytest.approx(old.objectives[key], rel=0.005), key
    for key in ("F_rms", "E_rms"):
        assert new.objectives[key] == pytest.approx(old.objectives[key], rel=0.001), key


def test_integrators_agree_to_round_off_at_the_same_settings():
    """The new loop (factored Sherman-Morrison, (p, q, u) state) is the same scheme."""
    from lccopt.vti.newmark import integrate
    from lccopt.vti.track import build_track
    from lccopt.vti.vehicle import build_vehicle

    case = load_case("configs/reference.yaml").with_simulation(run_in=2.0, run_out=1.0)
    x = case.reference.copy()
    x[:3] = [300e6, 100e6, 60e6]
    track = build_track(case.scenario(), case.track_design(x))
    veh = build_vehicle(case.scenario().vehicle)
    dt = case.simulation["time_step"]
    dofs = track.entry_sleeper_dof[:5]
    a = integrate(track, dt, veh.speed, 96.0, 400, vehicle=veh, record_dofs=dofs)
    b = integrate_reference(track, dt, veh.speed, 96.0, 400, vehicle=veh, record_dofs=dofs)
    scale = np.abs(b.contact_force).max()
    assert np.max(np.abs(a.contact_force - b.contact_force)) < 1e-9 * scale
    assert np.max(np.abs(a.dof_velocity - b.dof_velocity)) < 1e-8 * np.abs(b.dof_velocity).max()
