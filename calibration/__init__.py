"""GA calibration of the paper's rigs with whole populations evaluated as batched simulations (issue: section 2.2).

- :mod:`calibration.genes`: genes (ranges, log scaling) and GA settings (the paper's defaults).
- :mod:`calibration.problems`: the ringing and draught problems (targets, relative errors, fitness eqs. 7 and 10).
- :mod:`calibration.ga`: the PyGAD driver (batch fitness, checkpoint/resume after every generation, refinement).
- :mod:`calibration.archive`: every evaluated individual, reusable by later calibrations.
- :mod:`calibration.evaluators`: in-process or Ray workers (one batched simulation each).
- :mod:`calibration.screening`: shear-box screening of the accepted draught sets.
- :mod:`calibration.report`, :mod:`calibration.workflow`: tables, convergence plot, the ``warpdem calibrate`` run.
"""

from .archive import Archive, Record
from .ga import CalibrationResult, calibrate
from .genes import GASettings, Gene
from .problems import DraughtProblem, RingingProblem

__all__ = ["Archive", "CalibrationResult", "DraughtProblem", "GASettings", "Gene", "Record", "RingingProblem",
           "calibrate"]
