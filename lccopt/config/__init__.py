"""The config layer: case files -> a validated, typed case and the simulator's inputs.

* ``reading``: YAML with the line of every key, ``extends``, reading input files safely;
* ``overrides``: ``--set KEY.PATH=VALUE``, applied as if a file had written it;
* ``kinds``, ``schema``, ``validate``: the kinds of value a key may hold, the schema of a
  case file written with them, and its validator; ``units``: the units a quantity may be
  written in;
* ``profiles``: measured rail profiles (CSV rows), held in the case as their rows;
* ``zones``: lengths tied to the layout (the force zone's end, the design space on the track);
* ``checks``: what needs physics or the layout (time step, mesh, the vehicle on the rail);
* ``build``: the simulator's typed inputs (``lccopt.vti.specs``) from a validated case;
* ``case``: :class:`Case`, :func:`load_case` and the design vector's parsing and display;
* ``describe``: a case in lines a person reads (``lccopt check``);
* ``reference``: docs/case-reference.md, generated from the schema.

Data flows one way: this layer imports the simulator's specs and numerical helpers, the
simulator imports nothing from here.
"""

from .case import Case, Condition, Variable, design_items, load_case, parse_design
from .schema import SAFE_NAME

__all__ = ["Case", "Condition", "Variable", "SAFE_NAME", "design_items", "load_case",
           "parse_design"]
