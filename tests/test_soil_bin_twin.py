"""warpdem's rigid soil bin against its Yade 2023.02a twin on the same bed (assembly A, ci scale, GA set 11, 0.62 m/s).

Reference: benchmarks/yade/soil_bin_twin_yade_A.npz, written by ``yade -n -x benchmarks/yade/soil_bin_twin.py A``
from benchmarks/yade/soil_bin_twin_spec_A.npz (the scene ``run_soil_bin`` builds, exported by
soil_bin_twin_export.py: bed after the starting trench, bin and tool triangles, materials, dt, cohesion on the
first step's contacts). The run here is ``run_soil_bin`` itself; its probe (soil_bin_twin_compare.Probe) checks
that the scene equals the exported one and counts the contacts in Yade's id space, so both engines' numbers come
from the same formulas. The bed and the tool's place are read from the spec (``spec_bed_and_tool``): a deposition
repeated on another CPU or Warp build comes out another bed, which the probe would refuse.

Tolerances:
- the first record (25 steps after the bonds were set): the same number of sphere-sphere contacts and bonds
  (chaos has not yet separated the runs: after one step the helper's comparison found the same contacts and
  forces to 3e-6 N), one contact's difference allowed for a bin-wall contact at the edge of a facet, where Yade
  counts a contact per facet and warpdem one (warpdem/contacts.py);
- the mean draught over the steady part: within two combined standard errors (each from its record's
  autocorrelation, ``analysis.steady_state``). One realization per engine; the same test over 16 realizations of
  the bed gave 122.6 +- 4.6 N (warpdem) against 126.3 +- 5.3 N (Yade), -0.5 combined SE
  (benchmarks/yade/soil_bin_twin_report.md).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest
from conftest import DEVICE

REF = Path(__file__).resolve().parents[1] / "benchmarks" / "yade"


@pytest.mark.skipif(DEVICE != "cpu", reason="the twin's probe and bed are CPU-built (a CUDA bed is another one)")
def test_soil_bin_twin_a_equals_yade() -> None:
    sys.path.insert(0, str(REF))
    import soil_bin_twin_compare as cmp

    spec = cmp.load(REF / "soil_bin_twin_spec_A.npz")
    yade = cmp.load(REF / "soil_bin_twin_yade_A.npz")
    w = cmp.run_soil_bin_twin("A", spec)
    recs = w["recs"]
    first = 1  # record 0 precedes the first step
    assert int(recs["step"][first]) == int(yade["step"][0])
    assert int(recs["c_ss"][first]) == int(yade["c_ss"][0])
    assert int(recs["coh_ss"][first]) == int(yade["coh_ss"][0])
    assert abs(int(recs["c_sf"][first]) - int(yade["c_sf"][0])) <= 1
    mine = w["steady"]
    theirs = cmp.steady(yade["time"], yade["draught"], spec)
    combined = math.hypot(mine.sem, theirs.sem)
    assert abs(mine.mean - theirs.mean) < 2.0 * combined, (mine.mean, theirs.mean, combined)
