"""`lccopt check` shows the track it resolved, and warns where a strengthened sleeper's support
no longer fits the standard one (the two are separate keys: halving "the subgrade" is two
edits, and forgetting the second leaves the strengthened sleepers 2.5 x as stiff)."""

from __future__ import annotations

import re

from tests.conftest import CONFIGS


def _check(run_cli, *args):
    r = run_cli("check", *args, env={"COLUMNS": "80"})
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert all(len(line) <= 80 for line in lines[1:]), lines    # [0] names the file
    return lines


def _track(lines: list[str]) -> list[str]:
    start = lines.index("  track, one rail (pads and supports per rail seat):")
    end = next(i for i in range(start + 1, len(lines)) if lines[i].startswith("  zone:"))
    return lines[start:end]


def test_check_prints_the_resolved_track(run_cli):
    track = "\n".join(_track(_check(run_cli, CONFIGS / "reference.yaml")))
    for text in ("support: 45 MN/m, 96 kN s/m under each sleeper",
                 "pads: static not given, 1120 MN/m under the wheel, 120 kN s/m",
                 "designed pads x_r1-x_r3: 50-1200 MN/m under the wheel,",
                 "sleepers: 125.5 kg, 0.6 m apart, 100 m of ballast before the ERS",
                 "strengthened sleepers: 188.2 kg (1.5 x), support 56.25 MN/m (1.25 x)",
                 "120 kN s/m (1.25 x the standard)", "ERS: 6 + 6 m of slabs",
                 "on 500 MN/m/m (0.5 of it per rail), compound 27 MN/m/m",
                 "Type II strip 13.5 MN/m/m"):
        assert text in track, (text, track)
    assert "warning" not in track


def test_a_case_of_ones_own_shows_what_it_changed(run_cli, tmp_path):
    case = tmp_path / "mine.yaml"
    case.write_text(f"extends: {CONFIGS / 'reference.yaml'}\nname: mine\ntrack:\n"
                    "  railpad: {stiffness: 600 MN/m}\n  ers: {slab_lengths: [7.2]}\n"
                    "  layout: {sleeper_spacing: 600 mm}\n")
    track = "\n".join(_track(_check(run_cli, case)))
    assert "pads: static not given, 600 MN/m under the wheel, 120 kN s/m" in track, track
    assert "ERS: 7.2 m of slab," in track, track


def test_a_support_changed_in_one_key_only_is_warned_about(run_cli):
    ref = CONFIGS / "reference.yaml"
    lines = _check(run_cli, ref, "--set", "track.support.stiffness=22.5 MN/m")
    text = "\n".join(lines)
    assert "support: 22.5 MN/m" in text and "support 56.25 MN/m (2.5 x)" in text
    warning = " ".join(" ".join(lines).split())
    assert re.search(r"warning: strengthened_sleeper\.support_stiffness 56\.25 MN/m is 2\.5 x "
                     r"support\.stiffness 22\.5 MN/m", warning), warning
    assert "support_damping" not in warning          # its damping was left alone: 1.25 x
    # both keys halved: no warning
    lines = _check(run_cli, ref, "--set", "track.support.stiffness=22.5 MN/m",
                   "--set", "track.strengthened_sleeper.support_stiffness=28.125 MN/m")
    assert not any("warning" in line for line in lines), lines
    # a stiffer subgrade under standard sleepers only: the strengthened ones now softer
    lines = _check(run_cli, ref, "--set", "track.support.stiffness=90 MN/m",
                   "--set", "track.support.damping=200 kN s/m")
    warning = " ".join(" ".join(lines).split())
    assert "support_stiffness 56.25 MN/m is 0.625 x support.stiffness 90 MN/m" in warning
    assert "support_damping 120 kN s/m is 0.6 x support.damping 200 kN s/m" in warning
