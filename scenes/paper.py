"""The paper's measured and reported tables (transcribed CSVs in ``scenes/data/``) and its stated parameters.

Tables: ``ringing`` (Table 2), ``soil_bin_measured`` (Table 3), ``soil_bin_dem`` (Table 7), ``ga_sets`` (Tables 4-6),
``direct_shear_lab`` (section 2.3). Each CSV starts with ``#`` comment lines recording transcription notes (two of
them record where the paper's own tables disagree with its equations).
"""

from __future__ import annotations

from importlib import resources

import numpy as np

_FILES = {
    "ringing": "ringing_test_table2.csv",
    "soil_bin_measured": "soil_bin_measured_table3.csv",
    "soil_bin_dem": "soil_bin_dem_table7.csv",
    "ga_sets": "soil_ga_parameter_sets_tables4to6.csv",
    "direct_shear_lab": "direct_shear_lab.csv",
}

SPRING_COUNTS = (4, 8, 12, 16, 20, 24, 28, 32)
"""the eight plate-spring configurations (number of DIN 2093 spring units)."""
WORKING_DEPTH = 0.150
"""tillage depth [m] (section 2.1.2)."""
SOIL_YOUNG, SOIL_POISSON, SOIL_DENSITY = 1e7, 0.4, 2700.0
"""particle Young's modulus [Pa], Poisson's ratio (Yade: ks/kn) and density [kg/m^3] of all assemblies."""
TOOL_YOUNG, TOOL_POISSON, TOOL_FRICTION = 1e9, 0.3, 40.0
"""sweep STL: Young's modulus [Pa], Poisson's ratio, friction angle [deg] (Table 1)."""
LOAD_FORCE, LOAD_RADIUS, LOAD_YOUNG, LOAD_FRICTION = 200.0, 0.015, 1e7, 60.0
"""ringing test load [N], loading sphere radius [m], Young's modulus [Pa], friction angle [deg] (Table 1).
Table 1 gives the loading sphere's density as 1.866e6 kg/m^3, "calculated to be 20 kg"; with r = 15 mm that density
gives 26.4 kg (259 N), so warpdem uses the stated load: mass = LOAD_FORCE / g."""
SPRING_SPHERE = {"radius": 0.02, "density": 100.0, "poisson": 0.3, "friction_angle": 5.0, "normal_cohesion": 2e4,
                 "shear_cohesion": 1e4, "eta_roll": 0.001}
"""the spheres that mimic the plate springs in the paper's spring model (Table 1); E and local damping per
configuration come from Table 2."""
RINGING_DT, SOIL_BIN_DT = 4.969e-6, 4.354e-6
"""the paper's time steps [s] for the ringing test and the soil bin."""
SAMPLE_RATE = 2400.0
"""strain-gauge sampling rate of the laboratory ringing test [Hz]."""
COHESION_ON_NEW_CONTACTS = False
"""the cohesion rule of both soil rigs (soil bin and shear box): bonds on the contacts present when the test starts
(Yade's setCohesionNow), none on contacts made later (setCohesionOnNewContacts). The paper does not say; chosen by
the evidence in docs/fidelity.md: run with all 15 GA sets, warpdem's shear box comes closer to the paper's own
shear-box friction angles with this rule (MAE 4.6 against 5.5 deg, ``benchmarks/cohesion_rule.py``); neither rule
reproduces the paper's shear-box cohesion, and in the soil bin the other rule adds 10 % draught, not the factor two
that separates warpdem from the paper's DEM."""


def table(name: str) -> dict[str, np.ndarray]:
    """One of the paper's tables as columns: name -> array (n_rows,). Text columns stay strings."""
    if name not in _FILES:
        raise ValueError(f"table must be one of {sorted(_FILES)}, got {name!r}")
    text = resources.files("scenes").joinpath("data", _FILES[name]).read_text()
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith("#")]
    header = lines[0].split(",")
    rows = [ln.split(",") for ln in lines[1:]]
    out: dict[str, np.ndarray] = {}
    for k, col in enumerate(header):
        vals = [r[k] for r in rows]
        try:
            out[col] = np.array([float(v) if v else np.nan for v in vals])
        except ValueError:
            out[col] = np.array(vals)
    return out


def ringing_row(springs: int) -> dict[str, float]:
    """Table 2's row for a spring configuration (4, 8, ..., 32)."""
    t = table("ringing")
    idx = np.nonzero(t["springs"] == springs)[0]
    if len(idx) == 0:
        raise ValueError(f"springs must be one of {SPRING_COUNTS}, got {springs!r}")
    return {k: float(v[idx[0]]) for k, v in t.items()}


# --- values the paper's text gives for its figures (no table holds them); the figures draw them as references
FFT_DRAUGHT_SPLIT_HZ = 10.0
"""[Hz] Section 3.5.2 (Fig. 17, the paper's DEM) and 3.2.2 (Fig. 8, the laboratory): with the passive tool the
draught's spectrum loses amplitude above this frequency (the text gives no peak frequency of the draught)."""
FFT_LAB_TOOL_MAX_HZ = 30.0
"""[Hz] Section 3.2.2 (Fig. 8): the laboratory's tool frequencies were below this for every spring setting."""
FFT_DEM_DISPLACEMENT_PEAK_HZ = {16: 8.34}
"""[Hz] per spring count: the peak of the paper's DEM displacement spectrum that its text quotes (section 3.5.2,
Fig. 18d); the text gives no other configuration's peak, nor the laboratory's (Fig. 9)."""
FIG19_TOOL_KE_TREND = {4: (0.0148, 1.8979), 8: (0.0298, 1.7718), 12: (0.0347, 1.4608), 16: (0.0562, 1.7386),
                       20: (0.0448, 1.2183), 24: (0.0742, 1.2593), 28: (0.0807, 1.4043), 32: (0.0528, 0.994)}
"""(slope, intercept) per spring count of the trend lines y = slope x + intercept of the tool's total kinetic energy
y [J] in the paper's DEM (Fig. 19's caption). The text does not state the unit of x; the figures read it as the
tool's travel [m] (the paper's Figs. 12 and 20 plot energies against the travel)."""
