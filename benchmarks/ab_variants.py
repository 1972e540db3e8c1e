"""Upper bounds of what the pieces of a body's step cost on the GPU: copies of this tree's engine with one piece cut
out, for ``gpu_ab.sh ringing`` to time beside the tree itself.

    python benchmarks/ab_variants.py            # makes _ab_norot, _ab_diaginv, _ab_nocheck in the project root

- ``_ab_norot``: ``quat_integrate`` returns q unchanged (no square root, division, sine or cosine of the rotation
  step): bounds any cheaper rotation step.
- ``_ab_diaginv``: ``masked_inverse`` inverts only the diagonal (no determinant or adjugate): bounds a cheaper
  solve of the hinged and constrained bodies' rotation.
- ``_ab_nocheck``: no fault check of the bodies (``check_body``): bounds a cheaper check.

Each changes the physics (the rigs still run: the rotations are small, the tool's inertia nearly diagonal), so the
copies are for timing only; delete them afterwards. A branch can be added beside them with
``mkdir _ab_BRANCH && git archive BRANCH warpdem scenes calibration benchmarks | tar x -C _ab_BRANCH``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VARIANTS = {
    "_ab_norot": ("        dq = wp.quat_from_axis_angle(wp.normalize(omega), angle)\n"
                  "        return wp.normalize(dq * q)\n",
                  "        return q\n"),
    "_ab_diaginv": ("    return wp.inverse(m)\n",
                    "    return wp.diag(wp.vec3d(wp.float64(1.0) / m[0, 0], wp.float64(1.0) / m[1, 1],"
                    " wp.float64(1.0) / m[2, 2]))\n"),
    "_ab_nocheck": ("    check_body(b, x, v, omega, max_speed, lower, upper, step, fault_base, fault)\n",
                    "    if step < 0:\n"
                    "        check_body(b, x, v, omega, max_speed, lower, upper, step, fault_base, fault)\n"),
}


SKIP = shutil.ignore_patterns("__pycache__", ".beds", "yade", "*.jsonl", "*.npz")
"""left out of the copies: caches, Yade's reference data and result files (the device's upload is limited)."""


def main() -> None:
    src = (ROOT / "warpdem" / "integrator.py").read_text()
    for name, (old, new) in VARIANTS.items():
        if src.count(old) != 1:
            raise SystemExit(f"{name}: the piece to cut is not found once in warpdem/integrator.py")
        dest = ROOT / name
        shutil.rmtree(dest, ignore_errors=True)
        for part in ("warpdem", "scenes", "calibration", "benchmarks"):
            shutil.copytree(ROOT / part, dest / part, ignore=SKIP)
        (dest / "warpdem" / "integrator.py").write_text(src.replace(old, new))
        print(f"{name}: made")


if __name__ == "__main__":
    main()
