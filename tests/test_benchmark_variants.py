"""The optimiser variants kept in benchmarks/variants (levers measured and not adopted) still
apply to the code, so that RESULTS-optimiser.md's commands can be run again; a patch whose
first line names a base commit ("Base: ... (commit abc1234)") applies to that commit."""
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PATCHES = sorted((ROOT / "benchmarks" / "variants").glob("*.patch"))


def _git_checkout() -> bool:
    if shutil.which("git") is None:
        return False
    r = subprocess.run(["git", "rev-parse", "--show-toplevel"], cwd=ROOT, capture_output=True, text=True)
    return r.returncode == 0 and Path(r.stdout.strip()).resolve() == ROOT


def test_there_are_variants():
    assert len(PATCHES) >= 5


@pytest.mark.skipif(not _git_checkout(), reason="needs git and a git checkout of lccopt")
@pytest.mark.parametrize("patch", PATCHES, ids=lambda p: p.name)
def test_each_variant_patch_applies_to_the_code(patch, tmp_path):
    base = re.match(r"Base: .*\(commit ([0-9a-f]{7,40})\)", patch.read_text(encoding="utf-8"))
    if base is None:
        r = subprocess.run(["git", "apply", "--check", str(patch)], cwd=ROOT, capture_output=True, text=True)
        assert r.returncode == 0, f"{patch.name} no longer applies: {r.stderr.strip()}"
        return
    commit = base.group(1)
    if subprocess.run(["git", "cat-file", "-e", f"{commit}^{{commit}}"], cwd=ROOT,
                      capture_output=True).returncode != 0:
        pytest.skip(f"{patch.name}: base commit {commit} not in this clone")
    env = {**os.environ, "GIT_INDEX_FILE": str(tmp_path / "index")}  # the base's tree, not ours
    subprocess.run(["git", "read-tree", commit], cwd=ROOT, env=env, check=True)
    r = subprocess.run(["git", "apply", "--cached", "--check", str(patch)], cwd=ROOT, env=env,
                       capture_output=True, text=True)
    assert r.returncode == 0, f"{patch.name} no longer applies to {commit}: {r.stderr.strip()}"
