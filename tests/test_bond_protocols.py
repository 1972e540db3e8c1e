"""The bed's bond protocols against Yade 2023.02a (benchmarks/yade/bond_protocols_yade.npz, written by
``yade -n -x benchmarks/yade/bond_protocols_twin.py``; the warpdem side is benchmarks/yade/bond_protocols_compare.py).

References and tolerances:
- two spheres bonded with a detection factor of 1.5 (Yade's distance bonding): which pairs keep a bond after the
  first step, and their normal force, against Yade's output and the closed form (a gap g is a tension kn g at once;
  a fragile bond holds while kn g <= an = Cn r^2, and so does a non-fragile one with unpMax = 0). The force to 1e-4
  relative (float32 against Yade's float64);
- a bed (assembly A's ci bed, 681 spheres, GA set 11, no tool; bonds on the first contacts, within a detection
  factor of 1.5, after settling, and yielding instead of breaking): the bonds made at the bonding step, counted exactly
  (touching, and within the detection factor: the same pairs), and the share of them still bonded 0.24 s later.
  That run is chaotic: Yade's own realizations of the bed (displaced by 1e-9 m) scatter by a standard deviation
  s; one warpdem realization must lie within 3 s sqrt(1 + 1/n) of Yade's mean of n (a 3-sigma bound for the
  difference of one draw and a mean of n with the same spread).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import DEVICE

import warpdem as wd

REF = Path(__file__).resolve().parents[1] / "benchmarks" / "yade"
sys.path.insert(0, str(REF))
import bond_protocols_compare as cmp  # noqa: E402

YADE = cmp.load(cmp.YADE)


@pytest.mark.parametrize("fragile", [True, False])
def test_two_spheres_bonded_at_a_distance_as_yade(fragile: bool) -> None:
    r, young, coh = 0.007, 1e7, 1e5
    ref = YADE["pairs_fragile" if fragile else "pairs_ductile"]
    ratios = YADE["pair_ratios"]
    mat = wd.Material(young=young, poisson=0.3, density=2600.0, friction_angle=float(np.degrees(0.5)),
                      normal_cohesion=coh, shear_cohesion=coh, moment_law=True, fragile=fragile)
    b = wd.ModelBuilder(gravity=(0.0, 0.0, 0.0))  # one world per centre distance
    b.add_material("m", mat)
    b.add_sphere((0.0, 0.0, 0.0), r, "m", blocked="xyzXYZ", name="fixed")
    b.add_sphere((0.0, 0.0, 2 * r), r, "m", name="free")
    model, state = b.finalize(DEVICE, n_worlds=len(ratios))
    pos = state.body_pos.numpy().reshape(len(ratios), 2, 3)
    pos[:, 1, 2] = ratios * 2 * r
    state.body_pos.assign(pos.reshape(-1, 3))
    sim = wd.Simulation(model, state, dt=1e-7, bond_detection_factor=float(YADE["detection"]))
    sim.set_cohesion_now()
    sim.step()
    bonds = wd.observers.cohesive_bonds("default")(sim)
    force = sim.data.body_force.numpy().reshape(len(ratios), 2, 3)[:, 1, 2]  # contact force on the free sphere
    kn, an = young * r, coh * r * r  # equal spheres: kn = E r; an = Cn min(r)^2
    gap = (ratios - 1.0) * 2 * r
    closed_form = (ratios <= 1.0) | (kn * gap <= an)
    np.testing.assert_array_equal(ref[:, 1].astype(bool), closed_form)  # Yade follows the closed form
    np.testing.assert_array_equal(bonds.astype(bool), closed_form)
    # Yade's normalForce is Fn n with n from sphere 1 to 2 (+z), and body 2 gets +Fn n: compression pushes it up
    np.testing.assert_allclose(force[closed_form], ref[closed_form, 2], rtol=1e-4)
    np.testing.assert_allclose(force[closed_form], kn * (-gap[closed_form]), rtol=1e-4)


@pytest.mark.skipif(DEVICE != "cpu", reason="the bed's chaos is compared with Yade's on the CPU build")
@pytest.mark.parametrize("protocol", ["touch", "distance", "settled", "ductile"])
def test_bed_bonds_as_yade(protocol: str) -> None:
    _bonds_as_yade(protocol, cmp.load(cmp.SPEC), YADE)


@pytest.mark.skipif(DEVICE != "cpu", reason="the bed's chaos is compared with Yade's on the CPU build")
@pytest.mark.parametrize("protocol", ["touch", "settled"])
def test_dense_bed_bonds_as_yade(protocol: str) -> None:
    """The same on the bed deposited without friction (``SoilBinConfig.deposit_friction`` 0: 815 spheres where the
    default bed holds 681; Yade's run: 4 realizations, ``BOND_TWIN_BED=A_dense``)."""
    spec_path, yade_path, _ = cmp.paths("A_dense")
    _bonds_as_yade(protocol, cmp.load(spec_path), cmp.load(yade_path))


def _bonds_as_yade(protocol: str, spec: dict[str, np.ndarray], yade: dict[str, np.ndarray]) -> None:
    w = cmp.run(protocol, spec, yade, DEVICE)
    coh = yade[f"{protocol}_coh_ss"]  # (realization, record)
    if not protocol.startswith("settled"):  # the first step's pairs (after settling the beds have drifted apart)
        assert int(w["coh_ss"][0]) == int(coh[0, 0])
        assert len(w["bond_gaps"]) == len(yade[f"{protocol}_bond_gaps"])
    share = coh[:, -1] / coh[:, 0]
    mine = w["coh_ss"][-1] / w["coh_ss"][0]
    n = len(share)
    bound = 3.0 * share.std(ddof=1) * np.sqrt(1.0 + 1.0 / n)
    assert abs(mine - share.mean()) < bound, (protocol, mine, share.mean(), bound)


def test_a_detection_factor_outside_its_range_is_refused() -> None:
    from scenes.shear_box import preset
    from scenes.soil_bin import SoilBinConfig

    b = wd.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    b.add_material("m", wd.Material(young=1e7, poisson=0.3, density=2600.0, friction_angle=30.0))
    b.add_sphere((0.0, 0.0, 0.0), 0.01, "m")
    model, state = b.finalize(DEVICE)
    with pytest.raises(wd.InputError, match="bond_detection_factor must be in \\[1, 3\\].*0.5"):
        wd.Simulation(model, state, dt=1e-5, bond_detection_factor=0.5)
    with pytest.raises(ValueError, match="bond_detection_factor must be in \\[1, 3\\].*nan"):
        SoilBinConfig(bond_detection_factor=float("nan"))
    with pytest.raises(ValueError, match="bond_detection_factor must be in \\[1, 3\\].*4"):
        preset("ci", "A", bond_detection_factor=4.0)
