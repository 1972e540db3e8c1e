"""The foreign rig's diagnosis table of docs/case-studies.md ("A rig that is not warpdem's"), re-run as it stands:
each set of tests/test_diagnosis_foreign.py (its hinged beam, an RK4 model in numpy, one hidden effect per set)
through ``diagnose`` at the default settings, on the CPU.

    python docs/runs/foreign_rig_table/run.py --out docs/runs/foreign_rig_table/results.json

Writes one JSON record per set (verdict, cause, held-out losses of the baseline and of the named model, the named
gene's size and the inertia factor, wall seconds) and prints the markdown rows.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

SETS = [  # (label, effect, seed, rig-file keywords, the named gene)
    ("per-configuration damping ratios 0.04/0.12/0.07/0.15 (5), `damping = \"per_configuration\"`", "zeta", 5,
     {"damping": "per_configuration"}, "damping_scale"),
    ("the same data, one dashpot", "zeta", 5, {}, None),
    ("pivot friction 0.012 N m (1), `static_deflection` on 4 springs", {"pivot_friction": 0.012}, 1, "datum",
     "pivot_friction"),
    ("progressive k3 = 1e5 N/m^3 (1), `static_deflection` on 4 springs", {"progressive": 1e5}, 1, "datum",
     "progressive"),
    ("pivot friction 0.012 N m (1), no datum", {"pivot_friction": 0.012}, 1, {}, "pivot_friction"),
    ("progressive k3 = 1e5 N/m^3 (1), no datum", {"progressive": 1e5}, 1, {}, "progressive"),
    ("clean, one dashpot (3), no datum", {}, 3, {}, None),
    ("series stiffness 2e4 N/m (1), no datum", {"series_stiffness": 2e4}, 1, {}, "series_stiffness"),
]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    out = Path(args.out)
    if out.exists():
        raise SystemExit(f"--out: {out} exists; choose a new file")
    import warp as wp

    wp.config.quiet = True
    import test_diagnosis_foreign as f

    rows = []
    for label, effect, seed, kw, gene in SETS:
        if effect == "zeta":
            effect = {"zeta": f.ZETA}
        if kw == "datum":
            kw = {"static_deflection": (4, f.static_reading(seed=1))}
        t0 = time.perf_counter()
        d = f.run(effect, seed=seed, **kw)
        wall = time.perf_counter() - t0
        named = d.named if d.named is not None else None
        row = {"set": label, "verdict": d.verdict, "cause": list(d.cause or ()),
               "baseline_heldout": float(d.baseline.heldout_loss.sum()),
               "named_heldout": float(named.heldout_loss.sum()) if named is not None else None,
               "wall_s": round(wall, 1)}
        params = (named or d.baseline).params_all()
        if gene and gene in params:
            row[gene] = float(params[gene])
        if "inertia_factor" in params:
            row["inertia_factor"] = float(params["inertia_factor"])
        rows.append(row)
        print(json.dumps(row), flush=True)
    out.write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
