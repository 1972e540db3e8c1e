"""The ringing twin in warpdem against Yade 2023.02a: frequency and damping of every reading and configuration.

    yade -n -x benchmarks/yade/ringing_twin.py          # Yade's records (benchmarks/yade/ringing_twin_yade.npz)
    python benchmarks/ringing_twin_compare.py [--device cpu] [--readings stated,...]

Both engines build the rig from benchmarks/yade/ringing_twin_spec.npz (written by ``scenes.ringing_twin.twin_spec``).
Writes benchmarks/yade/ringing_twin_compare.md (table: f and zeta of both engines, their differences, Table 2's
calibrated values) and ringing_twin_compare.png (the records overlaid).
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from scenes import ringing_twin as rt

HERE = Path(__file__).resolve().parent / "yade"


def _fmt(x: float, spec: str) -> str:
    return "–" if x is None or not math.isfinite(x) else format(x, spec)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--readings", default=",".join(rt.READINGS))
    a = ap.parse_args()
    spec = dict(np.load(HERE / "ringing_twin_spec.npz"))
    yade = dict(np.load(HERE / "ringing_twin_yade.npz"))
    for k in ("load_centre", "upper_vertices", "spring_centres"):  # the Yade records must be of this spec
        if not np.array_equal(np.asarray(yade[k]), np.asarray(spec[k])):
            raise SystemExit(f"ringing_twin_yade.npz was made from another spec ({k} differs): re-run Yade")
    warp, walls = {}, {}
    for reading in a.readings.split(","):
        t0 = time.perf_counter()
        warp[reading] = rt.run_twin(spec, reading, device=a.device)
        walls[reading] = time.perf_counter() - t0
    rows = rt.compare(yade, warp)
    lines = ["# Ringing twin: warpdem against Yade 2023.02a", "",
             f"Both engines from `ringing_twin_spec.npz` (scenes/ringing_twin.py); dt {float(spec['dt']):.4g} s, "
             f"settling {float(spec['settle_time'])} s, ringing {float(spec['ring_time'])} s; f and zeta by "
             f"`scenes.analysis.ringdown` after a {rt.LOWPASS_HZ:g} Hz low-pass, the same for both records. "
             f"warpdem on `{a.device}`: " + ", ".join(f"{r} {w:.0f} s" for r, w in walls.items()) + ".", "",
             "| reading | springs | Yade f [Hz] | warpdem f [Hz] | diff f | Yade zeta | warpdem zeta | diff zeta | "
             "Table 2 f [Hz] | Table 2 zeta |", "|---" * 10 + "|"]
    for r in rows:
        lines.append(f"| {r['reading']} | {r['springs']} | {_fmt(r['yade_f'], '.3f')} | {_fmt(r['warp_f'], '.3f')} | "
                     f"{_fmt(100 * r['df'], '+.1f')} % | {_fmt(r['yade_zeta'], '.4f')} | "
                     f"{_fmt(r['warp_zeta'], '.4f')} | {_fmt(100 * r['dzeta'], '+.1f')} % | {r['table2_f']:.3f} | "
                     f"{r['table2_zeta']:.4f} |")
    (HERE / "ringing_twin_compare.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(spec["springs"])
    fig, axes = plt.subplots(len(warp), n, figsize=(3 * n, 2.4 * len(warp)), squeeze=False)
    for i, (reading, w) in enumerate(warp.items()):
        for k, s in enumerate(np.asarray(w["springs"]).tolist()):
            ax = axes[i, k]
            p = f"{reading}/{s}/"
            ax.plot(yade[p + "time"], 1e3 * (yade[p + "sensor_y"] - yade[p + "sensor_y"][0]), lw=0.7, label="Yade")
            ax.plot(w["time"], 1e3 * (w["sensor_y"][:, k] - w["sensor_y"][0, k]), lw=0.7, ls="--", label="warpdem")
            ax.set_title(f"{reading}, {s} springs", fontsize=8)
            ax.tick_params(labelsize=7)
    axes[0, 0].legend(fontsize=7)
    axes[-1, 0].set_xlabel("time after the hit [s]")
    axes[0, 0].set_ylabel("sensor y [mm]")
    fig.tight_layout()
    fig.savefig(HERE / "ringing_twin_compare.png", dpi=80)


if __name__ == "__main__":
    main()
