"""Write a golden journal: a short run of a bundled case with the tests' stand-in evaluator,
cut in two (the journal of a run stopped at proposal CUT, and the rest of that run).

    python tests/data/golden/make_golden.py NAME CASE SEED BUDGET WORKERS CUT [--worst F E]

writes tests/data/golden/NAME/{case.yaml, run.json, journal.jsonl, continuation.jsonl}.
tests/engine/test_reproducible.py resumes each stopped run and checks that it proposes the
continuation bit for bit. See README.md here for the runs committed and the code that made them.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
# The floating point every x86-64 CPU with AVX2 repeats (OpenBLAS's Haswell kernels, numpy's
# X86_V3 loops): the tests replay the runs with the same (tests/engine/conftest.py).
PINNED = {"OPENBLAS_CORETYPE": "Haswell",
          "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
          "OPENBLAS_NUM_THREADS": "1"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("name")
    ap.add_argument("case", help="a case of configs/, e.g. single-F_max")
    ap.add_argument("seed", type=int)
    ap.add_argument("budget", type=int)
    ap.add_argument("workers", type=int)
    ap.add_argument("cut", type=int, help="the stopped run's journal ends before proposal CUT")
    ap.add_argument("--worst", nargs=2, type=float, help="the ASF's worst values (two objectives)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        case = Path(tmp) / f"{args.name}.yaml"
        text = (f"extends: {ROOT / 'configs' / (args.case + '.yaml')}\nname: {args.name}\n"
                f"optimisation:\n  seed: {args.seed}\n  budget: {args.budget}\n")
        if args.worst:
            text += f"  asf:\n    worst: [{args.worst[0]}, {args.worst[1]}]\n"
        case.write_text(text, encoding="utf-8")
        env = {**os.environ, "PYTHONPATH": str(ROOT),
               "LCCOPT_EVALUATOR": "tests.engine.fakesim:evaluate", **PINNED}
        main_ = "import sys; from lccopt.cli import main; sys.exit(main())"
        r = subprocess.run([sys.executable, "-c", main_, "optimise", str(case), "--workers",
                            str(args.workers), "--runs", tmp],
                           env=env, capture_output=True, text=True)
        if r.returncode != 0:
            raise SystemExit(r.stderr)
        run = Path(tmp) / args.name
        lines = (run / "journal.jsonl").read_text(encoding="utf-8").splitlines(keepends=True)
        cut = next(i for i, line in enumerate(lines)
                   if (e := json.loads(line))["event"] == "asked" and e["id"] == args.cut)
        out = HERE / args.name
        out.mkdir(exist_ok=True)
        for f in ("case.yaml", "run.json"):
            shutil.copy(run / f, out / f)
        (out / "journal.jsonl").write_text("".join(lines[:cut]), encoding="utf-8")
        (out / "continuation.jsonl").write_text("".join(lines[cut:]), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
