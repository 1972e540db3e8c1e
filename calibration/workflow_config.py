"""The configuration of the paper's workflow (calibration/paper_workflow.py): what a run does, and the scales and
Table 3 variants it knows."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field

from scenes import paper
from scenes import soil_bin as sb
from scenes.rigs import SOIL_BIN
from warpdem.errors import InputError, check_int

from . import mechanisms
from .genes import GASettings

CALIBRATION_SCALE = {"ci": "ci", "cpu": "cpu", "paper": "paper_1m", "strip": "strip"}
"""soil-bin scale of the draught calibration for each workflow scale: the paper calibrated in its first, 1 m long
bin (section 2.1.2); ``paper_1m`` is that bin at the paper scale's particle size."""
SCREEN_SCALE = {"ci": "ci", "cpu": "cpu", "paper": "paper", "paper_1m": "paper", "strip": "paper"}
"""shear-box scale (:func:`scenes.shear_box.preset`) of the screening for each workflow scale."""
VARIANTS = ("offset", "no_offset")
"""Table 3 variants: the passive tool with Table 2's support offsets (the paper's final model) and without."""


REFIT_FIELDS = ("diagnosis_rounds",)
"""fields a run folder may change: the diagnosis keeps every simulated point (``diagnosis/checkpoint.json`` and
``checkpoints/diagnosis_runs/``), and another number of rounds fits again from them (fewer rounds simulate nothing;
more continue from the last round simulated). A finished diagnosis of the old value is set aside."""


SOIL_PROTOCOLS = ("paper", "bonded")
"""the soil protocols of the workflow (``WorkflowConfig.soil_protocol``)."""
BONDED_SETTLE = 1.0
"""[s] the least settling of a "bonded" bed before its bonds are set (0.5 s left the ci bed moving, 0.39 J;
docs/fidelity.md, section 3)."""


@dataclass
class WorkflowConfig:
    """What a workflow run does. Every field is recorded in ``workflow.json``; a folder holding another
    configuration is refused, except for a change of :data:`REFIT_FIELDS`."""

    scale: str = "paper"
    """soil-bin scale of the Table 3 runs (:data:`scenes.soil_bin.SCALES`)."""
    assembly: str = "C"
    springs: tuple[int, ...] = paper.SPRING_COUNTS
    """passive configurations of the ringing calibration and of Table 3."""
    ringing_models: tuple[str, ...] = ("linear", "paper")
    ringing_ga: GASettings = field(default_factory=GASettings)
    ringing_fitness: dict[str, str] = field(default_factory=lambda: {"linear": "max", "paper": "paper"})
    """fitness of each model's ringing GA: "paper" (eq. 7, 1/(REf REd)) or "max" (1/max(REf, REd)). Eq. 7 rewards
    one tiny error as much as two balanced ones (the paper's GA took 0.37 % / 99 % for the linear 4-spring stack),
    and the linear springs' stiffness and dashpot are what the Table 3 runs use: their GA ranks by the larger error."""
    ringing_refine: dict[str, int] = field(default_factory=lambda: {"linear": 20, "paper": 0})
    """batched pattern-search iterations after each model's ringing GA (:class:`GASettings.refine_iterations`)."""
    ringing_time: float = 2.0
    """[s] of free ringing per simulation."""
    draught_ga: GASettings = field(default_factory=GASettings)
    screen_top: int = 6
    """shear-box screening of at most this many sets (the accepted ones, fittest first)."""
    screen_changes: dict[str, object] = field(default_factory=dict)
    """further :class:`scenes.shear_box.ShearBoxConfig` fields of the screening (e.g. ``shear_displacement``)."""
    replicas_min: int = 3
    replicas_max: int = 8
    target_sem: float = 1.0
    """[percentage points]: replicas are added until every reduction's standard error is below this."""
    settle_time: float = 0.5
    """[s] each soil-bin bed settles under the run's soil set before the tool moves (``SoilBinConfig``)."""
    soil_protocol: str = "paper"
    """how the soil is calibrated and its bonds made. "paper": the paper's way, the draught GA over the paper's gene
    ranges, then its fittest accepted sets screened in the shear box; bonds that break (Yade's default), set on the
    bed after ``settle_time``. "bonded": the draught and the shear box calibrated together
    (:class:`calibration.problems.SoilProblem`), bonds that yield instead of breaking, set on a bed settled for
    ``max(settle_time, BONDED_SETTLE)``, the normal cohesion's range up to 500 kPa (10x the paper's top); the
    screening runs the fittest sets in the shear box with the same bonds. docs/runs/bond_protocols_h100 says why:
    with GA set 11 only the second reaches the laboratory's draught and shear box together. ``reproduce --workflow
    full`` takes "bonded" with the box at 20-80 kPa (``screen_changes``) in a new folder: on the default bed that
    calibration accepted a set (docs/runs/soil_ga_loose_box_h100x2)."""
    box_samples: int = 1
    """the "bonded" soil calibration's shear-box samples per individual (``SoilProblem.box_samples``: the box's c and
    phi are their means). ``reproduce --workflow full`` takes 3 in a new folder
    (``calibration.cli.SOIL_BOX_SAMPLES``). The screening then runs the fittest sets on sample seed ``box_samples``,
    one the calibration never saw."""
    deposit_friction: float = 30.0
    """[deg] contact friction of the soil-bin beds' deposition (``SoilBinConfig.deposit_friction``; 0: a dense bed,
    coordination 8.7 at paper scale against 6.95, the paper's 9.55) in the draught calibration, Table 3 and the
    diagnosis stage's rig model."""
    worlds_per_job: int = 4
    """soil-bin worlds per simulation (at most): smaller jobs fit a shorter budget."""
    travel: float | None = None
    """[m] of the Table 3 runs (default: the scale's)."""
    steady_travel: float | None = None
    calibration_travel: float | None = None
    """[m] of the draught calibration's runs (default: its scale's)."""
    seed: int = 0
    """first bed's deposition seed; replica r uses seed + r (with ``replica_worlds``: the replicas' population
    seed, replica r set down from the seed r)."""
    replica_worlds: bool = False
    """Table 3's replicas as worlds of one simulation: replica beds of one population (``scenes.replica_beds``),
    each job's worlds spread over a group of replicas (the first ``replicas_min`` together, then each group that the
    standard errors ask for), at most ``worlds_per_job`` worlds, the tool at the group's mean bed surface in every
    job of the group. The replicas share one draw of particle shapes and sizes. Off: a bed per replica, each
    replica's jobs on its bed alone, the tool on that bed's surface."""
    diagnose: bool = True
    """stage 5: ``warpdem diagnose`` of Table 3 (the configurations of ``springs``) with the soil of the Table 3
    runs, in the draught calibration's bin (:data:`CALIBRATION_SCALE`): every fitted point is a soil-bin run of
    every configuration."""
    diagnosis_rounds: int = 3
    """fit rounds of the diagnosis (one grid, then Levenberg-Marquardt; ``warpdem diagnose --rounds``)."""
    diagnosis_grid: int = 5
    """grid points of a one-gene mechanism in the diagnosis's first round (``warpdem diagnose``: 9)."""
    diagnosis_mechanisms: tuple[str, ...] | None = None
    """the candidate mechanisms of the diagnosis (None: every one that applies to the soil bin)."""

    passive_tool: dict[str, object] | None = None
    """the passive tool described once (``scenes.passive_tool.PassiveTool.to_dict``; ``--tool`` reads a TOML):
    Table 3's passive jobs use it instead of the ringing calibration's linear springs, with Table 2's support
    offsets in the "offset" jobs and none in the "no_offset" ones, and read the displacement zeroed at rest; rigid
    and passive jobs take its geometry (pivot height). None: the ringing GA's stiffness and dashpot (the paper's
    way). The diagnosis stage keeps its own rig model either way. ``reproduce --workflow full`` gives the joint
    fit's tool (``scenes.passive_tool.joint_tool``) unless told ``--tool ringing``."""

    @property
    def fragile(self) -> bool:
        """the soil's bonds break at their strength (the "paper" protocol) or yield ("bonded")."""
        return self.soil_protocol != "bonded"

    @property
    def soil_settle_time(self) -> float:
        """[s] the soil-bin beds settle before their bonds are set (``settle_time``; "bonded": at least
        BONDED_SETTLE)."""
        return max(self.settle_time, BONDED_SETTLE) if self.soil_protocol == "bonded" else self.settle_time

    def __post_init__(self) -> None:
        if self.soil_protocol not in SOIL_PROTOCOLS:
            raise InputError(f"soil_protocol must be one of {SOIL_PROTOCOLS}, got {self.soil_protocol!r}")
        self.box_samples = check_int("box_samples", self.box_samples, 1)
        if not (math.isfinite(self.deposit_friction) and 0.0 <= self.deposit_friction < 90.0):
            raise InputError(f"deposit_friction must be in [0, 90) deg, got {self.deposit_friction!r}")
        if self.passive_tool is not None:
            from scenes.passive_tool import from_dict

            from_dict(self.passive_tool)  # a bad description is refused here, by name
        if self.scale not in CALIBRATION_SCALE:
            raise InputError(f"scale must be one of {sorted(CALIBRATION_SCALE)}, got {self.scale!r}")
        for n in self.springs:
            if n not in paper.SPRING_COUNTS:
                raise InputError(f"springs must be among {paper.SPRING_COUNTS}, got {n!r}")
        if not self.springs:
            raise InputError("springs must name at least one passive configuration, got ()")
        for m in self.ringing_models:
            if m not in ("linear", "paper"):
                raise InputError(f"ringing_models must be among ('linear', 'paper'), got {m!r}")
            fit, ref = self.ringing_fitness.get(m), self.ringing_refine.get(m, 0)
            if fit not in ("paper", "max"):
                raise InputError(f"ringing_fitness[{m!r}] must be 'paper' or 'max', got {fit!r}")
            if not isinstance(ref, int) or ref < 0:
                raise InputError(f"ringing_refine[{m!r}] must be an integer >= 0, got {ref!r}")
        if not 1 <= self.replicas_min <= self.replicas_max:
            raise InputError(f"replicas must satisfy 1 <= replicas_min <= replicas_max, got {self.replicas_min}, "
                             f"{self.replicas_max}")
        if not (math.isfinite(self.target_sem) and self.target_sem > 0):
            raise InputError(f"target_sem must be a positive number of percentage points, got {self.target_sem!r}")
        if not (math.isfinite(self.settle_time) and self.settle_time >= 0):
            raise InputError(f"settle_time must be a finite number of seconds >= 0, got {self.settle_time!r}")
        if self.worlds_per_job < 1:
            raise InputError(f"worlds_per_job must be >= 1, got {self.worlds_per_job!r}")
        if self.diagnosis_rounds < 1:
            raise InputError(f"diagnosis_rounds must be >= 1, got {self.diagnosis_rounds!r}")
        if self.diagnosis_grid < 2:
            raise InputError(f"diagnosis_grid must be >= 2, got {self.diagnosis_grid!r}")
        if self.diagnosis_mechanisms is not None:
            for m in self.diagnosis_mechanisms:
                if m not in mechanisms.REGISTRY or SOIL_BIN.name not in mechanisms.REGISTRY[m].rigs:
                    raise InputError(f"diagnosis_mechanisms: {m!r} is not a soil-bin mechanism")

    def to_dict(self) -> dict[str, object]:
        return json.loads(json.dumps(asdict(self), default=str))

    def speeds(self) -> dict[int, float]:
        """Table 3's mean carriage speed [m/s] of each passive configuration."""
        t3 = paper.table("soil_bin_measured")
        return {n: float(t3["speed_mean_m_s"][t3["springs"] == n][0]) for n in self.springs}

    def rigid_speeds(self) -> list[float]:
        """The distinct speeds [m/s] of the configurations, ascending: the rigid runs of a replica."""
        return sorted({sb.speed_key(v) for v in self.speeds().values()})
