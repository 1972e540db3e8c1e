"""Time `warpdem diagnose` on eight ringing records from a rig that is not warpdem's.

The records come from the independent hinged-beam model of ``tests/test_diagnosis_foreign.py`` (other inertia,
levers, springs; a cable load with no mass; 1 % rate scatter, 0.5 % noise), all eight spring configurations, with
one hidden effect; they are written in the MEASURED format with the user's ``rig.toml`` beside them (inertia stated
40 % high, rates 10 % low, both marked uncertain) and diagnosed through the command line, as a user would:

    python benchmarks/diagnose_foreign.py --effect pivot_friction=0.012 --out results/diagnose_foreign

Prints the verdict and the wall time; the report is in ``--out``/diagnosis (refuses an existing folder).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the independent model lives in a test

from test_diagnosis_foreign import description, hinged_beam_records  # noqa: E402

from calibration.cli import main as cli  # noqa: E402
from calibration.synthetic import _write  # noqa: E402

SPRINGS = (4, 8, 12, 16, 20, 24, 28, 32)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--effect", default="", help="hidden effect NAME=VALUE (pivot_friction, progressive, "
                                                 "series_stiffness, drag); empty: none")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--out", required=True)
    ap.add_argument("--device", default="cpu")
    a = ap.parse_args()
    out = Path(a.out)
    if out.exists():
        raise SystemExit(f"diagnose_foreign: error: --out {out} exists; choose another")
    effect = {k: float(v) for k, v in (p.split("=") for p in a.effect.split(",") if p)}
    data = hinged_beam_records(effect, a.seed, springs=SPRINGS)
    _write(out / "measured", data)
    d = description(SPRINGS)
    rates = "\n".join(f"{n} = {k!r}" for n, k in d.spring_rates.items())
    (out / "measured" / "rig.toml").write_text(
        f"tool_inertia = {d.tool_inertia!r}\ntool_mass = {d.tool_mass!r}\ntool_com = {list(d.tool_com)!r}\n"
        f"spring_lever = {d.spring_lever!r}\nsensor_lever = {d.sensor_lever!r}\nload_force = {d.load_force!r}\n"
        f"load_arm = {d.load_arm!r}\nload_depth = {d.load_depth!r}\nload_mass_rides = false\n"
        f"uncertain = {list(d.uncertain)!r}\n[spring_rates]\n{rates}\n".replace("'", '"'))
    t0 = time.perf_counter()
    rc = cli(["diagnose", str(out / "measured"), "--rig", "ringing", "--device", a.device, "--out",
              str(out / "diagnosis"), "--uncertainty", "frequency=0.015,damping=0.05"])
    print(f"hidden: {effect or 'none'}; exit {rc}; {time.perf_counter() - t0:.0f} s on {a.device}")


if __name__ == "__main__":
    main()
