"""The diagnosis on data warpdem did not produce: Yade's soil bin with a hidden effect (issue #39, item 5).

Reference: Yade 2023.02a runs of the passive soil-bin twin (benchmarks/yade/passive_twin_table_<effect>/: Table 3's
format, 8 spring counts, 9 realizations each, their conservative standard errors per row), each data set with one
effect that Yade simulated and warpdem's baseline lacks: a 3 deg mounting pitch, a 1.5 mm stack preload, 20 N m of
pivot friction, none (clean), 3 kg of extra mass, which moves no steady mean beyond its SE (a null case), or 10 N m
of pivot friction, which clears 3 conservative SE at no spring count (no name, or pivot_friction). The
diagnosis (benchmarks/yade/passive_twin_diagnose.py: every soil-bin mechanism a candidate, every point the mean of 4
warpdem realizations of the twin's bed) must name the hidden effect, and nothing where the data cannot show one.
Only the names are asserted: the sizes came out 25 % (pitch), 12 % (preload) and 51 % (friction) under the hidden
ones on one H100. The 20 N m set was named pivot_friction in one run, narrowly over two indistinguishable ones, and
got no name in a rerun from scratch (its leaders at their bounds): for it, too, no name or the right one is accepted
(docs/case-studies.md).
Thousands of soil-bin runs per data set: CUDA only (minutes on one H100, hours on the CI's 2 cores). With
WARPDEM_TWIN_DIAGNOSIS_DIR naming a folder, the diagnoses checkpoint there and resume (or reuse the points of
``passive_twin_diagnose.py all --out`` that folder).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from conftest import DEVICE

pytestmark = pytest.mark.skipif(DEVICE == "cpu", reason="thousands of soil-bin runs per data set: CUDA only")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "yade"))


ROUNDS = 2
"""one grid round and one Levenberg-Marquardt round (as the CI's soil-bin diagnosis)."""
REALIZATIONS = 4
"""warpdem runs per point (the Yade data: 9): their standard error is added to the data's in quadrature."""


@pytest.fixture(scope="module")
def diagnosed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """Every data set diagnosed once, the runs shared (the same scene: only the data differ)."""
    import passive_twin_diagnose as ptd

    given = os.environ.get("WARPDEM_TWIN_DIAGNOSIS_DIR")  # checkpoints of a run of passive_twin_diagnose.py
    out = Path(given) if given else tmp_path_factory.mktemp("twin_diagnosis")
    found, rig = {}, None
    for effect in ("pitch", "preload", "friction20", "clean", "mass", "friction"):
        found[effect], rig = ptd.diagnose(effect, DEVICE, out, rounds=ROUNDS, realizations=REALIZATIONS, runs_from=rig)
    return found


@pytest.mark.parametrize(("effect", "causes"), [
    ("clean", [()]), ("mass", [()]), ("pitch", [("mount_pitch",)]), ("preload", [("stack_preload",)]),
    # 20 N m: named pivot_friction in one CUDA run, no name in another (its leaders at their bounds; docs/
    # case-studies.md): at 4 realizations a point the name is a draw. 10 N m clears 3 conservative SE at no spring
    # count. Either way: no name, or the right one, but no other
    ("friction20", [(), ("pivot_friction",)]), ("friction", [(), ("pivot_friction",)])])
def test_the_diagnosis_names_yades_hidden_effect(diagnosed: dict[str, object], effect: str, causes: list) -> None:
    d = diagnosed[effect]
    assert d.cause in causes, (effect, d.verdict, d.cause, d.ranking[:4], d.at_bound)
