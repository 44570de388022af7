"""``lccopt`` with Strategy settings overridden: how a lever is measured through the engine.

    python benchmarks/variant_cli.py --set KEY=VALUE [--set ...] -- optimise CASE [options]

Runs lccopt's command line in this process with the optimiser's default settings changed
(``lccopt.optim.strategy._default_settings``; the values are Python literals), so a variant
of the optimiser runs through the real engine: the same schedule, workers and journal as
``lccopt optimise``. benchmarks/paper_seeds.py uses it for ``--set``. Benchmark only: a run
made this way journals the optimiser generation of the code, not the variant, so resume it
with the same ``--set`` (paper_seeds.py does).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def parse_settings(items: list[str]) -> dict:
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"--set {item!r}: expected KEY=VALUE")
        try:
            out[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            out[key] = value  # a bare word: a string setting
    return out


def main(argv: list[str]) -> int:
    if "--" not in argv:
        raise SystemExit(__doc__)
    cut = argv.index("--")
    sets = [a for a in argv[:cut] if a != "--set"]
    settings = parse_settings(sets)

    from lccopt.optim import strategy
    from lccopt.optim.space import DesignSpace

    defaults = strategy._default_settings
    unknown = set(settings) - set(defaults(DesignSpace(["x"], [0.0], [1.0], [False])))
    if unknown:
        raise SystemExit(f"unknown Strategy settings: {sorted(unknown)}")

    def patched(space):
        return {**defaults(space), **settings}

    strategy._default_settings = patched
    from lccopt.cli import main as cli_main

    return cli_main(argv[cut + 1:])


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
