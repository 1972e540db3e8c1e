"""fig_cohesion_reach.png from results_soil-bin.json and results_shear-box.json (this folder).

    python docs/runs/cohesion_reach/plot.py
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

HERE = Path(__file__).parent


def main() -> None:
    sb = json.loads((HERE / "results_soil-bin.json").read_text())["soil_bin"]
    sh = json.loads((HERE / "results_shear-box.json").read_text())["shear_box"]
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    travel = sb["bonds_vs_travel"]["travel_m"]
    for row, bonds in zip(sb["rows"], sb["bonds_vs_travel"]["bonds"], strict=True):
        a.plot(travel, bonds, marker=".", label=f"{row['normal_cohesion_pa']:.3g} Pa: "
                                               f"{row['draught_mean_n']:.0f} N")
    a.set_xlabel("tool travel [m]")
    a.set_ylabel("unbroken bonds (soil-soil)")
    a.set_title("cpu-scale soil bin, rigid sweep at 0.62 m/s")
    a.legend(title="normal cohesion: draught", fontsize=8)
    sigma = [5.0, 10.0, 20.0]
    for row in sh["rows"]:
        b.plot(sigma, row["peaks_kpa"], marker="o",
               label=f"{row['normal_cohesion_pa']:.3g} Pa: c {row['c_kpa']:.1f} kPa, {row['phi_deg']:.0f} deg")
    b.plot(sigma, [6.4 + s * 0.632 for s in sigma], "k--", label="laboratory: c 6.4 kPa, 32.3 deg")
    b.set_yscale("log")
    b.set_xlabel("normal stress [kPa]")
    b.set_ylabel("peak shear stress [kPa]")
    b.set_title(f"ci shear box, assembly {sh['assembly']}")
    b.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(HERE / "fig_cohesion_reach.png", dpi=110)


if __name__ == "__main__":
    main()
