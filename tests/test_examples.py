"""The examples run as written (examples/engine_quickstart.py, the engine API of README's "Using the engine")."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from conftest import DEVICE

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_engine_quickstart_runs_and_its_checkpoint_continues_the_run(tmp_path) -> None:
    """Reference: the uninterrupted run. The example saves a checkpoint half way and continues a second, freshly
    built simulation from it: on the CPU both second halves agree to the bit (every force, contact history and
    counter is in the file, the last step's forces too, which the first record reads). Compared exactly on the CPU
    only until the CUDA repeat test (tests/test_determinism.py) has run on a GPU."""
    spec = importlib.util.spec_from_file_location("engine_quickstart", EXAMPLES / "engine_quickstart.py")
    ex = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ex)
    r = ex.main(DEVICE, tmp_path)
    assert (tmp_path / "quickstart_checkpoint.npz").exists()
    plate = r["rest"]["plate"]
    assert plate.shape[1:] == (2, 2, 3) and np.all(np.isfinite(plate))
    assert np.max(np.abs(plate[:, :, 0, 0])) > 0  # the plate meets the soil in both worlds
    if DEVICE == "cpu":
        for k in ("time", "plate", "pull"):
            np.testing.assert_array_equal(r["rest"][k], r["rest_again"][k])


def test_engine_quickstart_as_a_script_prints_its_results_only_and_leaves_no_file(tmp_path) -> None:
    """Run as a newcomer runs it (from their own folder): stdout holds the two result lines, stderr nothing (no Warp
    banner, module loads or CUDA-driver warning), and the folder stays empty (the checkpoint went to a temporary
    folder). The repository is on PYTHONPATH, so that the test does not depend on where `pip install -e .` last
    pointed."""
    path = os.pathsep.join(x for x in (str(EXAMPLES.parent), os.environ.get("PYTHONPATH")) if x)
    r = subprocess.run([sys.executable, str(EXAMPLES / "engine_quickstart.py"), "--device", DEVICE], cwd=tmp_path,
                       capture_output=True, text=True, timeout=600, env={**os.environ, "PYTHONPATH": path})
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 2 and all(x.startswith("friction ") for x in lines), r.stdout
    assert r.stderr.strip() == ""
    assert list(tmp_path.iterdir()) == []
