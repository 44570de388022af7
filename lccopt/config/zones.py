"""Lengths tied to the layout: the evaluation zones, and the design space against the track.

The force zone ends at a point given relative to a named point of the layout
(``evaluation.force_zone_end: {at: exit_interface, offset: -2.0}``), so that a case with other
``slab_lengths`` needs no second edit. The older form ``force_zone_after_interface`` (a
length from the entry interface) still loads, with its meaning unchanged; a zone of either
form that ends outside the ERS is refused with the fix, never reinterpreted.

Each check takes the typed sections (``data``) and ``err(key_path, message)``, which makes the
one-line :class:`~lccopt.errors.CaseError` naming the key's file and line.
"""

from __future__ import annotations

from ..vti.specs import ELEMENT_UNIT, LayoutPoint
from .schema import DEFAULT_FORCE_ZONE_END

ZONE_KEY = ("evaluation", "force_zone_end")
OLD_ZONE_KEY = ("evaluation", "force_zone_after_interface")


def _default_text() -> str:
    d = DEFAULT_FORCE_ZONE_END
    return f"force_zone_end: {{at: {d['at']}, offset: {d['offset']:g}}}"


def force_zone_end(evaluation: dict) -> LayoutPoint:
    """The force zone's end of a validated ``evaluation:`` section, in either form."""
    old = evaluation.get("force_zone_after_interface")
    if old is not None:
        return LayoutPoint("entry_interface", float(old))
    end = evaluation.get("force_zone_end") or DEFAULT_FORCE_ZONE_END
    return LayoutPoint(end["at"], float(end.get("offset") or 0.0))


def interfaces(data: dict) -> tuple[float, float]:
    """(entry interface, exit interface) [m]: where the ERS begins and ends."""
    x_a = float(data["track"]["layout"]["entry_length"])
    return x_a, x_a + float(sum(data["track"]["ers"]["slab_lengths"]))


def zone_end_x(data: dict) -> float:
    """x [m] where the force zone ends."""
    point = force_zone_end(data["evaluation"])
    x_a, x_b = interfaces(data)
    return (x_a if point.at == "entry_interface" else x_b) + point.offset


def resolve_zone(data: dict, err) -> None:
    """One form of the force zone's end (the default when neither is written), ending on
    the ERS: past its far edge the zone would measure the exit transition, which no design
    variable of the entry side moves; before its near edge it would miss the crossing."""
    evaluation = data["evaluation"]
    if "force_zone_end" in evaluation and "force_zone_after_interface" in evaluation:
        raise err(OLD_ZONE_KEY, "give force_zone_end or force_zone_after_interface, not both "
                                "(force_zone_after_interface: null drops a base file's)")
    if "force_zone_after_interface" not in evaluation and "force_zone_end" not in evaluation:
        evaluation["force_zone_end"] = dict(DEFAULT_FORCE_ZONE_END)
    old = "force_zone_after_interface" in evaluation
    key = OLD_ZONE_KEY if old else ZONE_KEY + ("offset",)
    x_a, x_b = interfaces(data)
    end = zone_end_x(data)
    ers = x_b - x_a
    if end > x_b + 1e-9:
        written = (f"{evaluation['force_zone_after_interface']:g} m" if old
                   else _point_text(evaluation["force_zone_end"]))
        raise err(key, f"{written} ends {end - x_b:.3g} m past the {ers:g} m ERS, in the exit "
                       f"ballast; write {_default_text()} (it follows the layout)")
    if end < x_a - 1e-9:
        where = getattr(err, "where", None)
        lengths = where(("track", "ers", "slab_lengths")) if where else "track.ers.slab_lengths"
        raise err(key, f"{_point_text(evaluation['force_zone_end'])} ends {x_a - end:.3g} m "
                       f"before the entry interface: the force zone must reach the ERS, "
                       f"{ers:g} m long here ({lengths}); write force_zone_end: "
                       f"{{at: exit_interface, offset: O}} with O from -{ers:g} to 0 in the case")


def _point_text(end: dict) -> str:
    return f"{{at: {end['at']}, offset: {end.get('offset') or 0.0:g}}}"


def derive_strip_bounds(data: dict) -> None:
    """The Type II strip's bounds, when a case does not give them: the whole ERS, in 0.1 m
    elements (they then follow slab_lengths)."""
    strip = data["design"]["type_ii_strip"]
    if strip.get("bounds") is None:
        x_a, x_b = interfaces(data)
        strip["bounds"] = [0.0, float(int(round((x_b - x_a) / ELEMENT_UNIT)))]


def check_design_space(data: dict, variables, err) -> None:
    """The layout holds every design (the upper bounds of the counts and spans reach
    farthest): the Type II strip within the ERS; enough entry sleepers for the zone, the
    strengthened sleepers and the designed pads; the zone and run-in on the entry track."""
    layout = data["track"]["layout"]
    upper = {v.name: v.upper for v in variables}
    groups: dict[str, list] = {}
    for v in variables:
        groups.setdefault(v.group, []).append(v)
    x_a, x_b = interfaces(data)
    strip = groups["type_ii_strip"][0]
    if strip.upper * ELEMENT_UNIT > x_b - x_a + 1e-9:
        raise err(("design", "type_ii_strip", "bounds"),
                  f"upper bound {strip.upper * ELEMENT_UNIT:g} m is longer than the "
                  f"{x_b - x_a:g} m ERS: at most {x_b - x_a:g} m")
    spans = sum(upper[v.name] for v in groups["sleeper_spans"]) * ELEMENT_UNIT
    n_spans = len(groups["sleeper_spans"])
    n_sleepers = int((layout["entry_length"] - spans) // layout["sleeper_spacing"]) + n_spans
    zone = data["evaluation"]["sleepers"]
    if n_sleepers < zone:
        raise err(("evaluation", "sleepers"), f"{zone} zone sleepers, but the entry side "
                                              f"holds {n_sleepers} at the widest spans")
    n_strong = groups["strengthened_sleepers"][0].upper
    if n_sleepers < n_strong:
        raise err(("design", "strengthened_sleepers", "bounds"),
                  f"upper bound {n_strong:g}, but the entry side holds {n_sleepers} sleepers")
    n_pads = len(groups["railpad_stiffness"])
    if n_pads > n_sleepers:
        raise err(("design", "railpad_stiffness", "count"),
                  f"{n_pads} designed pads, but the entry side holds {n_sleepers} sleepers")
    need = zone * layout["sleeper_spacing"] + spans + data["simulation"]["run_in"]
    if need > layout["entry_length"] - 5.0:
        raise err(("evaluation", "sleepers"),
                  f"the zone of {zone} sleepers and run_in ({need:g} m at the widest spans) "
                  f"do not fit the {layout['entry_length']:g} m entry track with 5 m to spare")
