"""warpdem's diagnosis of the Yade twin's Table-3-format data sets (``passive_twin_table_<effect>/``): does it name the
hidden effect that Yade simulated, and nothing where there is none?

    python benchmarks/yade/passive_twin_diagnose.py pitch --device cuda --out /tmp/ptd     # one data set (or more)
    python benchmarks/yade/passive_twin_diagnose.py all --device cuda --out /tmp/ptd       # all six
    python benchmarks/yade/passive_twin_diagnose.py all --device cuda --out /tmp/ptd --resume  # after a stop

Each data set's simulated points are checkpointed in ``OUT/<effect>.ckpt.json`` after every batch: a stopped run
resumes there (and tests/test_twin_diagnosis.py, given WARPDEM_TWIN_DIAGNOSIS_DIR=OUT, reuses them).

The rig model is ``calibration.rig_models.SoilBinRigModel`` on the data set's summary (reduction and displacement,
weighted by the data's own conservative standard errors, its ``*_se`` columns), simulating the scene the Yade twin
ran: assembly A at ci scale, GA set 11, no support offsets, the rigid twin's exported bed (681 spheres) and tool pose
(``soil_bin_twin_spec_A.npz``), 0.30 m of travel, steady after 0.15 m, linear springs at the DIN 2093 rates with Table
2's dashpot. Every point is the mean of ``--realizations`` runs (default 9, as the Yade data, passive_twin_table.py;
the committed reports and tests/test_twin_diagnosis.py: 4): the main bed and copies perturbed by 1e-9 m
(``scenes.replica_beds.perturbed``) as worlds of one simulation, its standard error the larger of their scatter's and
the runs' own. Every registered soil-bin mechanism is a candidate (``--mechanisms`` narrows them).

Expected names (the hidden effects, passive_twin_table_notes.md): clean and mass (a null case: 3 kg do not move the
steady means beyond their SE) -> no cause; pitch -> mount_pitch; preload -> stack_preload; friction20 (20 N m)
-> pivot_friction; friction (10 N m, below 3 SE at every spring count) -> no cause or pivot_friction.

Writes ``OUT/<effect>/`` (the diagnosis's report.md, diagnosis.json and plots) and prints one line per data set:
verdict, cause, the named gene's value, wall time.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent))
sys.path.insert(0, str(HERE))

EFFECTS = ("clean", "pitch", "preload", "friction", "friction20", "mass")
EXPECTED: dict[str, tuple[str, ...]] = {"clean": (), "mass": (), "pitch": ("mount_pitch",),
                                        "preload": ("stack_preload",), "friction20": ("pivot_friction",)}
"""the cause each data set should get (() : none); 'friction' (10 N m) is below the data's noise: either."""


def rig_model(effect: str, device: str | None, realizations: int = 9, runs_from: object | None = None) -> object:
    """The soil-bin rig model of data set ``effect`` on the Yade twin's scene (bed and tool from its spec), every
    case run on ``realizations`` copies of the bed (the main bed and the Yade twin's perturbations, seeds 1, 2, ...)."""
    import numpy as np
    import soil_bin_twin_compare as twin

    from calibration import measured
    from calibration.rig_models import SoilBinRigModel
    from scenes.replica_beds import perturbed

    spec = dict(np.load(HERE / "soil_bin_twin_spec_A.npz"))
    bed, tool = twin.spec_bed_and_tool("A", spec)
    data = measured.load(HERE / f"passive_twin_table_{effect}")
    max_worlds = 256 * realizations  # up to 256 cases per simulation
    beds = perturbed(bed, list(range(realizations)), twin.EPS) if realizations > 1 else bed
    return SoilBinRigModel(data, device=device, scale="ci", assembly="A", parameter_set=11, bed=beds, tool=tool,
                           runs_from=runs_from, max_worlds=max_worlds)


def diagnose(effect: str, device: str | None, out: Path, rounds: int = 3, realizations: int = 9,
             runs_from: object | None = None, mechanisms: tuple[str, ...] | None = None) -> tuple[object, object]:
    """Diagnose one data set; returns (the Diagnosis, the rig model, whose runs the next data set can share)."""
    from calibration import diagnosis, diagnosis_report

    rig = rig_model(effect, device, realizations, runs_from)
    t0 = time.perf_counter()
    d = diagnosis.diagnose(rig, diagnosis.DiagnosisSettings(rounds=rounds, mechanisms=mechanisms),
                           checkpoint=out / f"{effect}.ckpt.json")
    d.wall_s = time.perf_counter() - t0
    diagnosis_report.write(d, out / effect, command=f"passive_twin_diagnose.py {effect} --rounds {rounds} "
                                                      f"--realizations {realizations}")
    return d, rig


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("effect", nargs="+", choices=(*EFFECTS, "all"), help="data sets in this order (all: every one)")
    ap.add_argument("--device", default=None, help="Warp device (default: Warp's)")
    ap.add_argument("--out", required=True, help="folder for the reports and checkpoints (must not hold reports "
                    "already, unless --resume)")
    ap.add_argument("--resume", action="store_true", help="go on from the checkpoints in --out (a stopped run)")
    ap.add_argument("--rounds", type=int, default=3, help="diagnosis rounds (one grid, then Levenberg-Marquardt)")
    ap.add_argument("--realizations", type=int, default=9, help="runs per case: the main bed and perturbed copies")
    ap.add_argument("--mechanisms", nargs="+", default=None, help="the candidates (default: every soil-bin one)")
    a = ap.parse_args()
    out = Path(a.out)
    effects = EFFECTS if "all" in a.effect else tuple(dict.fromkeys(a.effect))
    for e in effects:
        if (out / e).exists() and not a.resume:
            raise SystemExit(f"--out: {out / e} exists; name another folder (or --resume a stopped run)")
    out.mkdir(parents=True, exist_ok=True)
    rig = None
    for e in effects:
        d, rig = diagnose(e, a.device, out, a.rounds, a.realizations, runs_from=rig,
                          mechanisms=tuple(a.mechanisms) if a.mechanisms else None)
        named = d.named.params_all() if d.cause else {}
        line = {"effect": e, "verdict": d.verdict, "cause": list(d.cause), "expected": list(EXPECTED.get(e, ("?",))),
                "named": named, "ranking": d.ranking[:4], "wall_s": round(d.wall_s, 1)}
        print(json.dumps(line, default=float), flush=True)


if __name__ == "__main__":
    main()
