"""The paper's ringing rig built from its text (scenes/ringing_twin.py) in warpdem against Yade 2023.02a.

Reference: benchmarks/yade/ringing_twin_yade_reduced.npz, written by ``yade -n -x benchmarks/yade/ringing_twin.py
reduced`` from the same spec (benchmarks/yade/ringing_twin_spec.npz): the "stated" reading (eq. (1) moved to the
centre of mass, the load sphere's printed density, local damping on the spring spheres only), 4 and 32 springs,
0.3 s of settling and 0.6 s of ringing after the hit. The rig is held by contacts only: the tool (a free facet body,
rotation about x and translation in y and z) hangs on a fixed ball in a tube, leans on the spring column and
carries the load sphere on a plate; its damping comes from Coulomb friction at the ball (Yade and warpdem alike).

Tolerances: the issue's 2 % (frequency) and 5 % (damping ratio) of the Yade twin. Measured on the 2-core CPU (full
set, 32 runs, benchmarks/ringing_twin_compare.py): the engines differ by at most 0.01 % in f and 0.2 % in zeta; the
settled sensor displacement by < 0.2 %. The differences come from float32 contact forces and the order of force
sums, which the frictional stick-slip at the pivot amplifies a little; a tolerance at the issue's bound keeps the
test about the physics, not the round-off.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import DEVICE

from scenes import ringing
from scenes import ringing_twin as rt

REF = Path(__file__).resolve().parents[1] / "benchmarks" / "yade"


@pytest.fixture(scope="module")
def yade() -> dict[str, np.ndarray]:
    with np.load(REF / "ringing_twin_yade_reduced.npz") as f:
        return {k: f[k] for k in f.files}


def test_the_committed_yade_records_are_of_this_twin(yade: dict[str, np.ndarray]) -> None:
    # the Yade records stay valid only while scenes/ringing_twin.py builds the same rig
    spec = rt.twin_spec()
    for k in ("lower_vertices", "upper_vertices", "upper_faces", "com", "inertia_parallel_axis", "load_centre",
              "spring_centres", "support_centre", "hit_angvel_x", "dt"):
        np.testing.assert_array_equal(np.asarray(yade[k]), np.asarray(spec[k]), err_msg=k)


def test_ringing_twin_equals_yade(yade: dict[str, np.ndarray]) -> None:
    # through the public rig: `warpdem ringing --spring-model twin` (Table 2's genes, the spec of twin_spec(),
    # which the test above holds equal to the one Yade ran)
    springs = tuple(int(yade["springs"][c]) for c in yade["run_configs"])
    res = ringing.run_ringing(ringing.RingingConfig(springs=springs, spring_model="twin",
                                                    ring_time=float(yade["ring_time_used"])), device=DEVICE)
    for k, n in enumerate(springs):
        p = f"stated/{n}/"
        # statics after settling (load on the plate, column compressed): the sensor's displacement
        assert res.static_deflection[k] == pytest.approx(float(yade[p + "settled_sensor_dy"]), rel=0.02)
        fy, zy = rt.frequency_damping(yade[p + "time"], yade[p + "sensor_y"])
        assert np.isfinite([fy, zy]).all()
        assert res.frequency_hz[k] == pytest.approx(fy, rel=0.02)
        assert res.damping_ratio[k] == pytest.approx(zy, rel=0.05)
