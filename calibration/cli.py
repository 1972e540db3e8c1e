"""The ``warpdem`` command (application code: it lives in the top layer, so the engine package imports neither
``scenes`` nor ``calibration``).

    warpdem reproduce [--scale ci|cpu|paper] [--device cpu|cuda] [--out DIR] [--assembly A|B|C] [--springs 0,16,32]
    warpdem reproduce --workflow full [--scale] [--assembly] [--budget S] [--replicas-min 3] [--replicas-max 8]
                      [--target-sem 1] [--worlds-per-job 4] [--replica-worlds] [--generations 5] [--population 20]
                      [--parents 7]
    warpdem ringing   [--spring-model paper|linear] [--springs 4,8,...] [--device] [--out DIR]
    warpdem soil-bin  [--scale] [--assembly] [--springs] [--spring-model] [--replicas N] [--viewer]
                      [--viewer-save FILE.rrd]
    warpdem speed-sweep [--scale] [--assembly] [--speeds 0.45,0.5,...] [--soil-from DIR] [--device] [--out DIR]
    warpdem shear-box [--scale] [--assembly] [--device] [--out DIR]
    warpdem demo      [--device] [--particles N] [--out DIR]
    warpdem calibrate ringing --springs 16 [--spring-model paper|linear] [--fitness paper|max] [--refine N]
    warpdem calibrate draught|soil --assembly C [--scale ci|cpu|paper|paper_1m] [--speed 0.62]
                      [--screen-scale ci|cpu|paper] [--no-screen] [--beds DIR]
                      (all: [--generations 5] [--population 20] [--parents 7] [--seed 0] [--device] [--out DIR]
                       [--gene NAME=LOW:HIGH] [--archive FILE] [--no-resume] [--ray-workers N] [--ray-address A]
                       [--budget S])
    warpdem diagnose MEASURED --rig ringing|soil-bin [--rig-file rig.toml] [--params FILE] [--mechanisms a,b]
                     [--uncertainty k=v,...]
                      [--rounds N] [--batch-worlds N] [--no-resume] [--device] [--out DIR]
                      (MEASURED: a summary CSV, a folder with summary.csv/series, paper:ringing or paper:soil-bin)

``reproduce`` runs the paper's study at a reduced (``cpu``, default) or full (``paper``) scale: the ringing test
for all eight spring configurations with the three spring models (paper, linear, twin), the soil bin with the rigid
tool at every configuration's speed and 16 and 32 springs (each reduction against the rigid run at its own speed),
and writes a results folder with config.json (parameters, versions, device, seed), the time series, summary.json,
PNG plots and report.md beside the paper's Tables 2, 3 and 7. Each rig also has its own command. The soil-bin runs
of ``reproduce`` and ``soil-bin`` checkpoint into OUT/checkpoints; the same command run again after a kill resumes.
``reproduce --workflow full`` runs the paper's whole workflow (:mod:`calibration.paper_workflow`): ringing and draught
calibrations, shear-box screening, Table 3 with and without support offsets on several beds; with ``--budget`` it
stops (exit code 3) where the next piece would not fit, and the same command continues.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from calibration.archive import same_or_extended
from scenes import rigs
from scenes.paper import SPRING_COUNTS
from warpdem.errors import InputError, SimulationError
from warpdem.files import write_text_atomic


def _progress(label: str) -> object:
    """A progress callback ``show(done, total)`` drawing a bar labelled ``label``."""
    return lambda done, total: _bar(label, done, total)


def _default_device() -> str:
    import warp as wp

    return "cuda" if wp.is_cuda_available() else "cpu"


def run_demo(args: argparse.Namespace) -> int:
    import warp as wp

    import warpdem as wd
    from scenes import analysis, demo

    device = _setup(args)
    out = _claim(args, args.out)
    box = (0.24, 0.10, 0.12)
    config = {
        "command": "demo", "device": device, "particles": args.particles, "seed": args.seed, "box_m": box,
        "soil": demo.SOIL.__dict__, "tool": demo.STEEL.__dict__, "deposit_s": args.deposit_time,
        "blade_speed_m_s": args.speed, "blade_depth_m": args.depth, "cut_length_m": args.cut,
        "versions": {"warpdem": wd.__version__, "warp": wp.config.version, "numpy": np.__version__,
                     "python": platform.python_version()},
    }
    t0 = time.time()
    # 1. deposition with local damping, cohesion on every new contact
    b = demo.build(args.particles, args.seed, box=box)
    b.set_local_damping("soil", 0.3)
    model, state = b.finalize(device)
    dt = 0.3 * wd.pwave_timestep(model)
    sim = wd.Simulation(model, state, dt=dt, cohesion_on_new_contacts=True)
    steps = int(args.deposit_time / dt)
    dep = sim.run(steps, record_every=max(steps // 50, 1), observers={"kinetic_energy": wd.observers.kinetic_energy},
                  progress=_progress("deposition"))
    z = sim.data.sphere_pos.numpy()[:, 2]
    r = model.host["sphere_radius"]
    top = float(np.percentile(z + r, 95))
    solid = float(np.sum(4 / 3 * np.pi * r**3))
    porosity = 1 - solid / (box[0] * box[1] * top)
    coord = float(wd.observers.coordination_number("soil")(sim)[0])
    # 2. cut: the settled bodies continue in a scene with the blade added (contacts re-form, with cohesion)
    b2 = demo.build(args.particles, args.seed, box=box)
    demo.add_blade(b2, (box[0], box[1], top), args.depth, args.speed)
    model2, state2 = b2.finalize(device)
    for k in ("body_pos", "body_vel", "body_angvel", "body_quat", "body_angmom"):
        arr = getattr(state2, k).numpy()
        arr[: model.n_bodies] = getattr(state, k).numpy()
        getattr(state2, k).assign(arr)
    sim2 = wd.Simulation(model2, state2, dt=dt, cohesion_on_new_contacts=True)
    steps = int(args.cut / args.speed / dt)
    draught = wd.observers.mesh_wrench("blade", world=0)
    observers = {"draught_n": lambda s: -draught(s)[0, 0], "kinetic_energy_j": wd.observers.kinetic_energy,
                 "coordination": wd.observers.coordination_number("soil")}
    if args.vtk:
        from warpdem.vtk import VtkWriter

        observers["vtk"] = VtkWriter(out / "vtk").as_observer(args.vtk)
    ts = sim2.run(steps, record_every=max(steps // 200, 1), observers=observers, progress=_progress("cutting"))
    ts.pop("vtk", None)
    wall = time.time() - t0
    half = len(ts["time"]) // 2
    summary = {
        "particles": int(model.n_spheres), "dt_s": dt, "bed_height_m": top, "porosity": porosity,
        "coordination_after_deposition": coord, "draught_mean_n": float(np.mean(ts["draught_n"][half:])),
        "draught_std_n": float(np.std(ts["draught_n"][half:])), "wall_time_s": wall, "device": device,
        "draught_n_eff": analysis.effective_samples(np.asarray(ts["draught_n"][half:]).reshape(-1)),
        "particle_steps_per_s": model.n_spheres * (sim.state.step + sim2.state.step) / wall,
    }
    np.savez_compressed(out / "timeseries.npz", deposition_time=dep["time"],
                        deposition_kinetic_energy=dep["kinetic_energy"], **{k: v for k, v in ts.items()})
    cols = ["time", "draught_n", "kinetic_energy_j", "coordination"]
    np.savetxt(out / "timeseries.csv", np.column_stack([np.asarray(ts[c]).reshape(len(ts["time"]), -1)[:, 0]
                                                         for c in cols]), delimiter=",", header=",".join(cols))
    summary["draught_sem_n"] = summary["draught_std_n"] / math.sqrt(summary["draught_n_eff"])
    write_text_atomic(out / "config.json", json.dumps(config, indent=2, default=str))
    write_text_atomic(out / "summary.json", json.dumps(summary, indent=2))
    demo.write_report(out, summary, ts, dep, args.speed, args.depth)
    print(f"{summary['particles']} particles, porosity {summary['porosity']:.3f}; draught "
          f"{summary['draught_mean_n']:.2f} ± {summary['draught_sem_n']:.2f} N (standard error; std "
          f"{summary['draught_std_n']:.2f} N); {summary['wall_time_s']:.0f} s on {device}")
    print(f"results in {out} (report.md, summary.json)")
    return 0


_BAR: dict[str, object] = {"quiet": False}  # the bar being drawn: label, start time, last percentage


def _end_bar() -> None:
    """End a bar's line left open (a command that stops mid-stage), so that the next line starts on its own."""
    if _BAR.get("label") is not None:
        sys.stderr.write("\n")
        sys.stderr.flush()
        _BAR["label"] = None


def _bar(label: str, done: float, total: float) -> None:
    """Progress on stderr for a labelled stage: a bar, the percentage, the elapsed time and an estimate of the time
    left; the line ends when the stage is done or the next one starts. Silent with ``--quiet``."""
    state = _BAR
    if state["quiet"]:
        return
    if state.get("label") != label:
        if state.get("label") is not None:
            sys.stderr.write("\n")
        state.update(label=label, start=time.time(), last=-1)
    frac = min(max(done / total, 0.0), 1.0) if total > 0 else 1.0
    pct = int(100 * frac)
    if pct == state["last"] and done < total:
        return
    state["last"] = pct
    elapsed = time.time() - state["start"]
    left = f"{elapsed * (1 - frac) / frac:6.0f} s left" if 0 < frac < 1 else " " * 13
    sys.stderr.write(f"\r{label:<30} [{'#' * int(30 * frac):<30}] {pct:3d} %  {elapsed:6.0f} s  {left}")
    if done >= total:
        sys.stderr.write("\n")
        state["label"] = None
    sys.stderr.flush()


def _deposit_bar(label: str, max_time: float = 3.0) -> Callable[[str, float, float], None]:
    """A deposition's progress (phase, simulated time [s], kinetic energy per particle [J]) as a bar over its
    longest simulated time; it usually ends earlier, when the bed is at rest."""
    return lambda phase, t, _ke: _bar(f"{label} ({phase})", t, max_time)


def _write_config(out: Path, command: str, device: str, **fields: object) -> None:
    """config.json of a run: command, device, versions and the given parameters. A run continued on another
    device or with other versions keeps the earlier calls' device and versions (``earlier_calls``, oldest first),
    so that its folder says where each part ran."""
    from scenes.reproduce import versions

    path = out / "config.json"
    now = {"device": device, "versions": versions()}
    earlier: list[dict[str, object]] = []
    try:
        old = json.loads(path.read_text())
    except (OSError, ValueError):
        old = None
    if isinstance(old, dict):
        earlier = list(old.get("earlier_calls", []))
        last = json.loads(json.dumps({"device": old.get("device"), "versions": old.get("versions")}, default=str))
        if last != json.loads(json.dumps(now, default=str)) and (not earlier or earlier[-1] != last):
            earlier.append(last)
    write_text_atomic(path, json.dumps({"command": command, **now, **({"earlier_calls": earlier} if earlier else {}),
                                        **fields}, indent=2, default=str))


CLAIM = ".warpdem-run.json"
"""The file that marks a results folder as one run's: the command and every parameter that makes the run (not the
device nor the Ray workers that evaluate a calibration: a run may continue on another machine, and output options
such as --quiet do not count)."""
_NOT_IDENTITY = {"argv", "out", "verbose", "quiet", "debug", "overwrite", "budget", "no_resume", "device", "vtk",
                 "beds", "defaults", "given", "diagnosis_rounds", "ray_workers", "ray_address"}


def _claim(args: argparse.Namespace, out: str | Path, adopt: str | None = None) -> Path:
    """Make ``out`` this run's folder, or refuse: a folder holding another run (another command or other
    parameters) needs ``--overwrite`` (which removes it first); a non-empty folder that is no warpdem run is
    refused always (``adopt``: a file whose presence marks a folder of this command made before claims existed).
    The same command with the same parameters continues in its own folder."""
    import shutil

    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {str(out)!r} is a file, not a folder; choose a new or empty folder")
    mine = json.loads(json.dumps({"command": args.command, **{k: v for k, v in sorted(vars(args).items())
                                                                if k not in _NOT_IDENTITY | {"command"}}},
                                 default=str))
    claim = out / CLAIM
    if claim.exists():
        try:
            held = {k: v for k, v in json.loads(claim.read_text()).items() if k not in _NOT_IDENTITY}
        except (OSError, ValueError, AttributeError):
            held = {}
        if held == mine:
            return out
        defaults = json.loads(json.dumps(getattr(args, "defaults", {}), default=str))
        if same_or_extended(held, mine, defaults):
            # a run made before these options existed, continued with them at their defaults
            _write_claim(claim, mine)
            return out
        if not getattr(args, "overwrite", False):
            diff = [k for k in sorted(set(held) | set(mine)) if held.get(k) != mine.get(k)]
            what = ", ".join(f"{k} {held.get(k)!r} (now {mine.get(k)!r})" for k in diff[:4])
            raise InputError(f"--out {str(out)!r} holds another run ({what}); choose another --out, or pass "
                             "--overwrite to replace it")
        shutil.rmtree(out)
    elif out.exists() and any(out.iterdir()) and not (adopt and (out / adopt).exists()) and \
            _command_of(out) != args.command:
        raise InputError(f"--out {str(out)!r} is not empty and holds no warpdem run; choose a new or empty folder")
    _write_claim(claim, mine)
    return out


def _write_claim(claim: Path, mine: dict[str, object]) -> None:
    """Write the claim, the run's first file: a folder that cannot be made or written (read-only, under a file) is
    refused here, naming --out, before anything runs."""
    try:
        write_text_atomic(claim, json.dumps(mine, indent=1))
    except OSError as e:
        raise InputError(f"--out {str(claim.parent)!r} cannot be written ({e.strerror or e}); choose a folder you "
                         "can write to") from None


def _command_of(out: Path) -> str | None:
    """The command that wrote ``out/config.json`` (a folder of a warpdem from before claims), else None."""
    try:
        return str(json.loads((out / "config.json").read_text()).get("command", "")).split(" ")[0] or None
    except (OSError, ValueError, AttributeError):
        return None


def _springs(text: str) -> tuple[int, ...]:
    allowed = (0, *SPRING_COUNTS)  # rigid and the paper's eight configurations
    try:
        v = tuple(int(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be comma-separated spring counts, got {text!r}") from None
    if not v or any(n not in allowed for n in v):
        raise argparse.ArgumentTypeError(f"must list one or more of {','.join(map(str, allowed))} (0 = rigid), got "
                                         f"{text!r}")
    twice = sorted({n for n in v if v.count(n) > 1})
    if twice:
        raise argparse.ArgumentTypeError(f"lists {','.join(map(str, twice))} more than once (each configuration runs "
                                         f"once), got {text!r}")
    return v


MAX_REPLICAS = 32
"""the most replica beds of ``soil-bin --replicas``: each replica deposits a bed of its own and adds a world per
configuration to every simulation (time and memory grow with N), while the standard error falls only as 1/sqrt(N):
32 beds take it to 18 % of one bed's scatter."""


def _replicas(text: str) -> int:
    n = int(_number(int, ge=1)(text))
    if n > MAX_REPLICAS:
        raise argparse.ArgumentTypeError(
            f"must be at most {MAX_REPLICAS}, got {text!r}: each replica deposits a bed of its own and adds a world "
            f"per configuration to every simulation, while the standard error falls only as 1/sqrt(N) "
            f"({MAX_REPLICAS} beds: {100 / math.sqrt(MAX_REPLICAS):.0f} % of one bed's scatter)")
    return n


def _setup(args: argparse.Namespace) -> str:
    """The device to run on: --device, else CUDA if available; a CUDA device on a machine without one is refused
    here, before Warp's own driver messages."""
    import warp as wp

    if args.device and args.device.startswith("cuda") and not wp.is_cuda_available():
        raise InputError(f"--device {args.device}: CUDA is not available on this machine (no NVIDIA GPU or driver); "
                         "use --device cpu")
    return args.device or _default_device()


FULL_ONLY = ("budget", "replicas_min", "replicas_max", "target_sem", "worlds_per_job", "replica_worlds", "settle_time",
             "soil_protocol", "box_stresses", "box_samples", "deposit_friction", "no_diagnosis", "diagnosis_rounds",
             "diagnosis_grid", "generations", "population", "parents")
"""options of ``reproduce`` that only the full workflow reads (the quick one refuses them)."""


def _given(parser: argparse.ArgumentParser, argv: list[str]) -> set[str]:
    """The destinations of the options typed in ``argv`` (whole, abbreviated as argparse allows, or --NAME=VALUE),
    to tell an option given at its default from one left out."""
    given = set()
    for token in argv:
        if token == "--":
            break
        flag = token.split("=", 1)[0]
        if not flag.startswith("--"):
            continue
        exact = [a for a in parser._actions if flag in a.option_strings]
        prefix = [a for a in parser._actions if any(o.startswith(flag) for o in a.option_strings)]
        given |= {a.dest for a in exact or (prefix if len(prefix) == 1 else [])}
    return given


def _as_given(value: object) -> str:
    """An option's value as its command line wrote it (a flag: nothing; normal stresses in kPa)."""
    if isinstance(value, bool):
        return ""
    if isinstance(value, tuple):
        return " " + ",".join(f"{x / 1e3:g}" for x in value)
    return f" {value:g}" if isinstance(value, int | float) else f" {value}"


def run_reproduce(args: argparse.Namespace) -> int:
    if args.workflow == "quick":
        full = [f"--{d.replace('_', '-')}{_as_given(getattr(args, d))}" for d in FULL_ONLY
                if d in getattr(args, "given", ())]
        if full:
            raise InputError(f"{', '.join(full)}: only --workflow full reads {'them' if len(full) > 1 else 'it'}, "
                             "the quick workflow (the default) does not; add --workflow full or leave "
                             f"{'them' if len(full) > 1 else 'it'} out")
    if args.workflow == "full":
        if args.vtk:
            raise InputError(f"--vtk {args.vtk}: ParaView frames are written by the quick workflow (and by "
                             "soil-bin, speed-sweep, shear-box, demo), not by --workflow full")
        return run_workflow(args)
    if args.tool is not None:
        raise InputError(f"--tool {args.tool}: the described tool is used by --workflow full (and by soil-bin), not "
                         "by the quick workflow")
    from scenes.reproduce import reproduce

    device = _setup(args)
    _claim(args, args.out)
    summary = reproduce(args.out, scale=args.scale, device=device, assembly=args.assembly,
                        springs=args.springs or (0, 16, 32), seed=args.seed, progress=_bar, vtk_every=args.vtk,
                        deposit_progress=_deposit_bar("soil bin: deposition"))
    print(f"results in {args.out} (report.md), wall time {summary['wall_s']:.0f} s on {device}")
    return 0


def _folder_config(out: str | Path) -> dict | None:
    """The configuration of the full workflow in ``out`` (its workflow.json), or None where there is none."""
    try:
        config = json.loads((Path(out) / "workflow.json").read_text()).get("config")
    except (OSError, ValueError, AttributeError):
        return None
    return config if isinstance(config, dict) else None


def _folder_rounds(args: argparse.Namespace) -> int:
    """--diagnosis-rounds, else the folder's (workflow.json), else 3."""
    if args.diagnosis_rounds is not None:
        return args.diagnosis_rounds
    try:
        return int(_folder_config(args.out)["diagnosis_rounds"])
    except (KeyError, TypeError, ValueError):
        return 3


def _ringing_workflow(out: str | Path) -> bool:
    """Whether ``out`` holds a full workflow whose Table 3 takes the ringing calibration's springs (every folder
    made before the described tool became the default): without ``--tool`` it goes on with them."""
    config = _folder_config(out)
    return config is not None and config.get("passive_tool") is None


SOIL_BOX_SAMPLES = 3
"""shear-box samples per individual of ``calibrate soil`` and of a new full workflow's soil calibration, unless told:
one sample's c and phi scatter by about 1 kPa and 0.9 deg (15 samples of the ``cpu`` box,
docs/runs/soil_ga_loose_box_h100x2), and a GA that sees one sample per individual accepts the individuals that met a
favourable one. Three samples bring the scatter of the means to about 0.6 kPa and 0.5 deg."""
WORKFLOW_BOX_STRESSES = (20e3, 40e3, 80e3)
"""[Pa] the shear box's normal stresses of the full workflow's soil calibration ("bonded" protocol) unless told
``--box-stresses``: the paper gives neither the laboratory's nor its DEM box's; at these a frictional soil's
envelope has the laboratory's intercept (docs/fidelity.md, section 3b)."""


def _workflow_soil(args: argparse.Namespace) -> None:
    """--soil-protocol, --box-stresses and --box-samples of the full workflow, where not given: a folder's own (one
    made before these defaults goes on as it was), else the "bonded" protocol (the draught and the shear box
    calibrated together) with the box at WORKFLOW_BOX_STRESSES on SOIL_BOX_SAMPLES samples."""
    folder = _folder_config(args.out)
    if args.soil_protocol is None:
        args.soil_protocol = str(folder.get("soil_protocol", "paper")) if folder is not None else "bonded"
    if args.box_stresses is None:
        if folder is not None:
            stresses = (folder.get("screen_changes") or {}).get("normal_stresses")
            args.box_stresses = tuple(float(x) for x in stresses) if stresses else None
        elif args.soil_protocol == "bonded":
            args.box_stresses = WORKFLOW_BOX_STRESSES
    if args.box_samples is None:
        args.box_samples = (int(folder.get("box_samples", 1)) if folder is not None
                            else SOIL_BOX_SAMPLES if args.soil_protocol == "bonded" else 1)
    elif args.box_samples != 1 and args.soil_protocol != "bonded":
        raise InputError(f"--box-samples {args.box_samples}: only the bonded soil protocol's calibration reads it, "
                         f"got --soil-protocol {args.soil_protocol}")


def run_workflow(args: argparse.Namespace) -> int:
    """``reproduce --workflow full``: calibration.paper_workflow in OUT, continued when OUT holds one already."""
    from calibration.genes import GASettings
    from calibration.paper_workflow import Budget, Workflow, WorkflowConfig
    from scenes import paper
    from warpdem.errors import BudgetExhausted

    device = _setup(args)
    if args.springs is not None and 0 in args.springs:
        raise InputError(f"--springs of the full workflow lists passive configurations (the rigid runs are always "
                         f"made), got {','.join(map(str, args.springs))}")
    if args.population < args.parents:
        raise InputError(f"--population ({args.population}) must be at least --parents ({args.parents})")
    ga = GASettings(generations=args.generations, population=args.population, parents=args.parents, seed=args.seed)
    _workflow_soil(args)
    config = WorkflowConfig(scale=args.scale, assembly=args.assembly,
                            springs=args.springs or paper.SPRING_COUNTS, ringing_ga=ga, draught_ga=ga,
                            replicas_min=args.replicas_min, replicas_max=args.replicas_max,
                            target_sem=args.target_sem, worlds_per_job=args.worlds_per_job,
                            replica_worlds=args.replica_worlds,
                            settle_time=args.settle_time, soil_protocol=args.soil_protocol, seed=args.seed,
                            deposit_friction=args.deposit_friction,
                            diagnose=not args.no_diagnosis,
                            diagnosis_rounds=_folder_rounds(args), diagnosis_grid=args.diagnosis_grid,
                            screen_changes={"normal_stresses": args.box_stresses} if args.box_stresses else {},
                            box_samples=args.box_samples)
    if args.tool != "ringing" and not (args.tool is None and _ringing_workflow(args.out)):
        from dataclasses import replace

        from scenes.passive_tool import joint_tool, load_toml

        tool = joint_tool() if args.tool is None else load_toml(args.tool)
        config = replace(config, passive_tool=tool.to_dict())
    budget = Budget(args.budget)
    _claim(args, args.out, adopt="workflow.json")
    wf = Workflow(args.out, config, device=device, log=lambda m: print(m, flush=True), progress=_bar)
    t0 = time.perf_counter()
    try:
        summary = wf.run(budget)
    except BudgetExhausted as e:
        _end_bar()
        report = wf.write_interim_report()
        print(f"warpdem reproduce: stopped: {e}; the report so far is {report}", file=sys.stderr)
        return 3
    cmp = summary["table3"]["comparison"]
    for variant, c in cmp.items():
        print(f"Table 3, {variant}: MAE {c['mae_pp']:.2f} +- {c['mae_sem_pp']:.2f} pp, signs {c['signs_right']}/"
              f"{c['n']}, largest reduction SE {c['max_sem_pp']:.2f} pp (paper's DEM: MAE "
              f"{c['paper_dem_mae_pp']:.2f} pp, signs {c['paper_dem_signs_right']}/{c['n']})")
    print(f"results in {args.out} (report.md), this call {time.perf_counter() - t0:.0f} s on {device}")
    return 0


def run_ringing_cmd(args: argparse.Namespace) -> int:
    from scenes import ringing
    from scenes.reproduce import write_ringing_report

    if "seed" in getattr(args, "given", ()):
        raise InputError(f"--seed {args.seed}: the ringing rig has no bed and no other random input; leave it out")
    device = _setup(args)
    out = _claim(args, args.out)
    springs = args.springs or ringing.RingingConfig().springs
    res = {}
    for m in ([args.spring_model] if args.spring_model else list(ringing.SPRING_MODELS)):
        cfg = ringing.RingingConfig(springs=springs, spring_model=m)
        res[m] = ringing.run_ringing(cfg, device=device, progress=lambda d, n, ph, m=m: _bar(f"ringing {m} {ph}", d, n))
    table = {m: r.table() for m, r in res.items()}
    _write_config(out, rigs.RINGING.name, device, config={m: r.config for m, r in res.items()})
    write_text_atomic(out / "summary.json", json.dumps(table, indent=2))
    report = write_ringing_report(out, res, device)
    for m, rows in table.items():
        for r in rows:
            print(f"{m:7s} {r['springs']:2d} springs: {r['freq_hz']:.3f} Hz (lab {r['measured_freq_hz']:.3f}), "
                  f"zeta {r['damping']:.4f} (lab {r['measured_damping']:.4f})")
    print(f"report: {report}")
    return 0


def run_soil_bin_cmd(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from scenes import soil_bin as sb

    device = _setup(args)
    tool = None
    if args.tool is not None:  # read before the folder is claimed: a bad file leaves nothing behind
        from scenes.passive_tool import load_toml

        if (args.spring_model or "linear") != "linear":
            raise InputError(f"--tool describes linear spring stacks; --spring-model must be linear, got "
                             f"{args.spring_model!r}")
        tool = load_toml(args.tool)
    out = _claim(args, args.out)
    cfg = sb.SoilBinConfig(scale=args.scale, assembly=args.assembly, springs=args.springs or (0, 16, 32),
                           spring_model=args.spring_model or "linear", seed=args.seed)
    viewer = None
    if args.viewer or args.viewer_save:
        from warpdem.viewer import RerunViewer

        lo, hi = args.speed_range

        def viewer(sim: object) -> RerunViewer:
            return RerunViewer(sim, spawn=args.viewer, save_path=args.viewer_save, speed_range=(lo, hi),
                               hide_outside_range=args.hide_outside_range)

    _write_config(out, rigs.SOIL_BIN.name, device, config=asdict(cfg), preset=sb.SCALES[args.scale],
                  replicas=args.replicas, tool=None if tool is None else tool.to_dict())
    study = sb.run_study(cfg, device=device, cache_dir=out / "beds",
                         progress=lambda run, d, n: _bar(f"soil bin: {run} tool", d, n), viewer=viewer,
                         checkpoint_dir=out / "checkpoints",
                         deposit_progress=_deposit_bar("deposition"), vtk_every=args.vtk, vtk_dir=out / "vtk",
                         replicas=args.replicas, passive_tool=tool)
    (out / "summary.json").write_text(json.dumps(sb.json_safe(study["table"]), indent=2))
    from scenes.reproduce import write_soil_bin_report

    report = write_soil_bin_report(out, {"scale": args.scale, "assembly": args.assembly}, study, device)
    for r in study["table"]:
        name = "rigid" if r["springs"] == 0 else f"{r['springs']} springs"
        over = f", {r['replicas']} replicas" if args.replicas > 1 else ""
        line = (f"{name:>10} at {r['speed']:.2f} m/s: draught {r['draught_mean']:.1f} N (SE {r['draught_sem']:.1f}, "
                f"std {r['draught_std']:.1f}{over})")
        if r["springs"]:
            line += f", displacement {1e3 * r['displacement_mean']:.2f} mm"
            if r["reduction_pct"] is not None:
                line += (f", reduction {r['reduction_pct']:+.1f} % (SE {r['reduction_sem']:.1f}) against the rigid "
                         f"run at {r['rigid_reference_speed']:.2f} m/s")
        print(line)
    print(f"report: {report}")
    return 0


def _soil_from(args: argparse.Namespace) -> tuple[dict | None, dict[str, float] | None]:
    """--soil-from: the calibration's record (``calibration.problems.calibrated_soil``), or a study soil's by name
    (``calibration.passive_study.SOILS``: assembly C, the box's own normal stresses), and its soil material's fields,
    or (None, None); a bad folder or another assembly than the soil's is refused before --out is claimed."""
    if not args.soil_from:
        return None, None
    from calibration.genes import soil_fields
    from calibration.passive_study import SOILS
    from calibration.problems import DEPOSIT_FRICTION, calibrated_soil

    if args.soil_from in SOILS:
        cal = {"assembly": "C", "deposit_friction": DEPOSIT_FRICTION, "box_changes": {}, **SOILS[args.soil_from]}
        where = f"the study soil {args.soil_from}"
    else:
        cal = calibrated_soil(args.soil_from)
        where = f"calibrated in {args.soil_from}"
    if args.assembly != cal["assembly"]:
        raise InputError(f"--assembly {args.assembly} differs from the soil's ({cal['assembly']}, {where}); give "
                         f"--assembly {cal['assembly']}")
    return cal, {k: float(v) for k, v in soil_fields(cal).items()}


def run_speed_sweep_cmd(args: argparse.Namespace) -> int:
    from scenes import soil_bin as sb
    from scenes import speed_sweep

    cal, soil = _soil_from(args)
    protocol = {k: cal[k] for k in ("settle_time", "fragile", "deposit_friction")} if cal else {}
    device = _setup(args)
    out = _claim(args, args.out)
    cfg = sb.SoilBinConfig(scale=args.scale, assembly=args.assembly, springs=(0,), seed=args.seed, **protocol)
    _write_config(out, "speed-sweep", device, speeds=args.speeds, scale=args.scale, assembly=args.assembly,
                  seed=args.seed, preset=sb.SCALES[args.scale], soil_from=args.soil_from, soil=soil, **protocol)
    res = speed_sweep.main(out, cfg, args.speeds, device=device, progress=lambda d, n: _bar("rigid sweep", d, n),
                           vtk_every=args.vtk, soil=soil)
    for r in res["rows"]:
        print(f"rigid at {r['speed']:.2f} m/s: draught {r['draught_mean']:.1f} N (SE {r['draught_sem']:.1f})")
    line = res["line"]
    print(f"line: {line.intercept:.1f} + {line.slope:.1f} v N; report in {out / 'report.md'}")
    return 0


def run_passive_tool_cmd(args: argparse.Namespace) -> int:
    """``warpdem passive-tool``: Table 2 fitted within bounds, the rigid pitch sweep and Table 3 with the tool."""
    from calibration.passive_study import (
        DEFAULT_VARIANTS,
        PITCHES,
        SOILS,
        PassiveStudy,
        calibrated_soil_of,
        write_report,
    )
    from warpdem.errors import BudgetExhausted

    if args.joint_from and args.beds_from:
        raise InputError("--joint-from and --beds-from are two jobs; give one")
    if args.joint_from:
        return _passive_joint(args)
    if args.beds_from:
        return _passive_beds(args)
    device = _setup(args)
    variants = args.variants or (DEFAULT_VARIANTS + (("described",) if args.tool else ()))
    for v in ("described", "described_offsets"):
        if v in variants and not args.tool:
            raise InputError(f"--variants {v} needs --tool TOML (the tool to run)")
    if args.tool:
        from scenes.passive_tool import load_toml

        load_toml(args.tool)  # a bad file is refused before the folder is claimed
    if args.soil not in SOILS:
        calibrated_soil_of(args.soil)  # refused before the folder is claimed too
    out = _claim(args, args.out)
    study = PassiveStudy(out, scale=args.scale, device=device, seed=args.seed, travel=args.travel,
                         steady_travel=args.steady_travel, shank_length=args.shank_length, soil=args.soil,
                         pitches=PITCHES if args.pitches is None else args.pitches,
                         log=lambda m: print(m, flush=True), tool_file=args.tool)
    t0 = time.perf_counter()
    try:
        study.run(args.budget, variants)
    except BudgetExhausted as e:
        _end_bar()
        print(f"warpdem passive-tool: stopped: {e}; the report so far is {write_report(out)}", file=sys.stderr)
        return 3
    print(f"results in {out} (report.md), this call {time.perf_counter() - t0:.0f} s on {device}")
    return 0


def _passive_joint(args: argparse.Namespace) -> int:
    """``warpdem passive-tool --joint-from``: Table 2 and Table 3 fitted with one tool, the soil's levers from the
    named passive runs; writes joint.json, joint.md and tool_joint.toml into --out."""
    from calibration.passive_study import passive_runs, write_joint

    try:
        passive_runs(args.joint_from)  # refused before the folder is claimed
    except InputError as e:
        raise InputError(f"--joint-from: {e}") from None
    out = _claim(args, args.out)
    t0 = time.perf_counter()
    write_joint(out, args.joint_from)
    print(f"results in {out} (joint.md), {time.perf_counter() - t0:.0f} s")
    return 0


def _passive_beds(args: argparse.Namespace) -> int:
    """``warpdem passive-tool --beds-from``: Table 3 over several beds, from finished passive-tool folders (the
    variant ``--variants`` names first, default "described"; a second: the first's runs against its on the beds
    holding both); writes beds.json, beds.md and fig_table3_beds.png."""
    from calibration.passive_study import beds_table, paired_changes, write_beds

    variants = args.variants or ("described",)
    if len(variants) > 2:
        raise InputError(f"--beds-from combines one tool variant, or one against another; --variants names "
                         f"{len(variants)}: {list(variants)}")
    against = variants[1] if len(variants) == 2 else None
    try:  # refused before the folder is claimed
        beds_table(args.beds_from, variants[0])
        if against is not None:
            paired_changes(args.beds_from, variants[0], against)
    except InputError as e:
        raise InputError(f"--beds-from: {e}") from None
    out = _claim(args, args.out)
    rows = write_beds(out, args.beds_from, variants[0], against)
    print(f"results in {out} (beds.md): {len(args.beds_from)} bed(s), {len(rows)} configurations")
    return 0


def _folders(text: str) -> tuple[str, ...]:
    v = tuple(x.strip() for x in text.split(",") if x.strip())
    if not v:
        raise argparse.ArgumentTypeError(f"must name one or more folders, comma-separated, got {text!r}")
    return v


def _pitches(text: str) -> tuple[float, ...]:
    if text.strip() == "none":
        return ()
    try:
        v = tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be comma-separated angles [deg] or 'none', got {text!r}") from None
    if not v or not all(math.isfinite(x) and abs(x) <= 30 for x in v):
        raise argparse.ArgumentTypeError(f"must be angles within +-30 deg, got {text!r}")
    return v


def _variants(text: str) -> tuple[str, ...]:
    from calibration.passive_study import VARIANTS

    v = tuple(x.strip() for x in text.split(",") if x.strip())
    if not v or any(x not in VARIANTS for x in v):
        raise argparse.ArgumentTypeError(f"must name tool variants among {list(VARIANTS)}, got {text!r}")
    return v


def _speeds(text: str) -> tuple[float, ...]:
    try:
        v = tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be comma-separated speeds [m/s], got {text!r}") from None
    if not v or not all(math.isfinite(x) and x > 0 for x in v):
        raise argparse.ArgumentTypeError(f"must be one or more speeds > 0 [m/s], got {text!r}")
    twice = sorted({x for x in v if v.count(x) > 1})
    if twice:
        raise argparse.ArgumentTypeError(f"lists {','.join(f'{x:g}' for x in twice)} more than once (each speed runs "
                                         f"once), got {text!r}")
    return v


def _speed_range(text: str) -> tuple[float, float]:
    try:
        lo, hi = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be LO,HI in m/s, got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 <= lo < hi):
        raise argparse.ArgumentTypeError(f"must be LO,HI with 0 <= LO < HI m/s, got {text!r}")
    return lo, hi


def _stresses(text: str) -> tuple[float, ...]:
    """An argparse type: normal stresses given in kPa as 'A,B,C' (at least three distinct, each > 0) -> Pa."""
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be comma-separated normal stresses in kPa, e.g. 20,40,80, got "
                                         f"{text!r}") from None
    if not all(math.isfinite(x) and x > 0 for x in v) or len(set(v)) < 3:
        raise argparse.ArgumentTypeError(f"must be at least three distinct normal stresses > 0 kPa (a Mohr-Coulomb "
                                         f"line through the peaks), got {text!r}")
    return tuple(1e3 * x for x in sorted(v))


def _add_budget(parser: argparse.ArgumentParser, help_text: str) -> None:
    """A command's --budget: the wall time [s] of one call, > 0."""
    parser.add_argument("--budget", type=_number(float, gt=0, unit="s"), default=None, help=help_text)


def _number(cast: type, *, gt: float | None = None, ge: float | None = None, lt: float | None = None,
            unit: str = "") -> Callable[[str], float]:
    """An argparse type: a finite ``cast`` (int or float) within the given bounds, else a message saying so."""
    bounds = " and ".join(f"{op} {b:g}" for op, b in ((">", gt), (">=", ge), ("<", lt)) if b is not None)
    unit = f" {unit}" if unit else ""

    def parse(text: str) -> float:
        try:
            v = cast(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {'an integer' if cast is int else 'a number'}{unit}, got "
                                             f"{text!r}") from None
        if not math.isfinite(v) or (gt is not None and v <= gt) or (ge is not None and v < ge) or \
                (lt is not None and v >= lt):
            raise argparse.ArgumentTypeError(f"must be {bounds}{unit}, got {text!r}")
        return v
    parse.__name__ = cast.__name__
    return parse


def run_shear_box_cmd(args: argparse.Namespace) -> int:
    from calibration.problems import calibrated_box
    from scenes import shear_box

    cal, _ = _soil_from(args)
    changes = calibrated_box(cal) if cal else {}
    if args.normal_stresses:
        changes["normal_stresses"] = args.normal_stresses
    device = _setup(args)
    out = _claim(args, args.out)
    cfg = shear_box.preset(args.scale, args.assembly, seed=args.seed, **changes)
    _write_config(out, "shear-box", device, config=str(cfg), soil_from=args.soil_from)
    vtk = None
    if args.vtk:
        from warpdem.vtk import VtkWriter

        vtk = (VtkWriter(out / "vtk"), args.vtk)
    res = shear_box.run_shear_box(cfg, device, progress=lambda ph, d, n: _bar(f"shear box: {ph}", d, n), vtk=vtk)
    (out / "summary.json").write_text(json.dumps(res.to_dict(), indent=2, default=float))
    report = shear_box.write_report(res, out)
    print(res.table())
    print(f"report: {report}")
    return 0


def _gene_range(text: str) -> tuple[str, tuple[float, float]]:
    try:
        name, rng = text.split("=")
        lo, hi = (float(x) for x in rng.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--gene must be NAME=LOW:HIGH, got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise argparse.ArgumentTypeError(f"--gene must be NAME=LOW:HIGH with finite LOW < HIGH, got {text!r}")
    return name.strip(), (lo, hi)


def _genes(args: argparse.Namespace) -> dict[str, tuple[float, float]] | None:
    """--gene ranges checked against the calibration's genes (names, once each, a log gene's LOW > 0) before
    anything runs."""
    from calibration.genes import with_ranges
    from calibration.problems import DRAUGHT_GENES, RINGING_GENES, SOIL_GENES

    if not args.gene:
        return None
    names = [n for n, _ in args.gene]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise InputError(f"--gene {twice[0]} given more than once; give each gene's range once")
    defaults = {"ringing": RINGING_GENES[args.spring_model], "draught": DRAUGHT_GENES, "soil": SOIL_GENES}[args.kind]
    for name, (lo, hi) in args.gene:
        try:
            with_ranges(defaults, {name: (lo, hi)})
        except ValueError as e:
            raise InputError(f"--gene {name}={lo:g}:{hi:g}: {e}") from None
    return dict(args.gene)


def run_calibrate_cmd(args: argparse.Namespace) -> int:
    from calibration.genes import GASettings
    from calibration.workflow import run_calibration
    from calibration.workflow_config import SCREEN_SCALE
    from warpdem.errors import BudgetExhausted

    device = _setup(args)
    settings = GASettings(generations=args.generations, population=args.population, parents=args.parents,
                          seed=args.seed, refine_iterations=args.refine)
    genes = _genes(args)
    for flag, given in (("--box-stresses", args.box_stresses), ("--box-samples", args.box_samples)):
        if given is not None and args.kind != "soil":
            raise InputError(f"{flag}: only 'calibrate soil' reads it (its shear box), got 'calibrate {args.kind}'")
    if args.kind == "ringing":
        kw: dict[str, object] = {"springs": args.springs, "spring_model": args.spring_model, "fitness": args.fitness}
    else:
        kw = {"assembly": args.assembly, "scale": args.scale, "speed": args.speed, "seed": args.seed,
              "deposit_friction": args.deposit_friction}
        if args.kind == "soil":
            kw["box_scale"] = args.screen_scale or SCREEN_SCALE.get(args.scale, args.scale)
            if args.box_stresses:
                kw["box_changes"] = {"normal_stresses": args.box_stresses}
            kw["box_samples"] = args.box_samples or SOIL_BOX_SAMPLES
        if args.beds:
            kw["cache_dir"] = str(args.beds)
    out = _claim(args, args.out or f"results/calibrate/{args.kind}_" + (str(args.springs) if args.kind == "ringing"
                                                                        else args.assembly))
    _write_config(out, f"calibrate {args.kind}", device, settings=settings.to_dict(), problem=kw, genes=genes)

    def show(h: dict[str, object]) -> None:
        errs = ", ".join(f"{k} {abs(v):.2f} deg" if k.startswith("d_") else f"{k} {100 * abs(v):.2f} %"
                         for k, v in h["best_errors"].items())
        total = args.generations if h["stage"] == "ga" else args.generations + 1 + args.refine
        print(f"{h['stage']:6s} {h['generation']:3d}/{total}: best fitness {h['best_fitness']:.4g} ({errs}); "
              f"{h['simulated']} simulated in {h['simulation_s']:.1f} s, {h['wall_s']:.0f} s so far", flush=True)

    try:
        result, summary = run_calibration(
            args.kind, out, settings=settings, device=device, ray_workers=args.ray_workers,
            ray_address=args.ray_address,
            gpus_per_worker=1.0 if (device.startswith("cuda") and (args.ray_workers or args.ray_address)) else 0.0,
            screen_scale=(args.screen_scale or SCREEN_SCALE.get(args.scale, args.scale))
            if args.kind == "draught" and not args.no_screen else None,
            archive=args.archive, resume=not args.no_resume, progress=show, genes=genes, budget=args.budget,
            **({"stage_progress": _bar} if args.kind != "ringing" else {}),
            screen_progress=lambda ph, d, n: _bar(f"screening: shear box {ph}", int(1e6 * d), int(1e6 * n)), **kw)
    except BudgetExhausted as e:
        _end_bar()
        print(f"warpdem calibrate: {e}; the generations so far are in {out}", file=sys.stderr)
        return 3
    best = result.best
    print(f"best: {best.genes} -> {best.observables}, errors {best.errors}, fitness {best.fitness:.4g}")
    if (held := summary.get("held_out_box")) is not None:
        o = held["observables"]
        print(f"best set's shear box on samples the calibration never saw (seeds "
              f"{','.join(map(str, held['seeds']))}): c {o['cohesion_kpa']:.2f} kPa, phi {o['friction_angle_deg']:.2f} "
              f"deg: {'within' if held['box_accepted'] else 'NOT within'} the tolerances")
    if summary.get("screening"):
        for r in summary["screening"]:
            print(f"screening rank {r['rank']}: set {r['set']} c {r['cohesion_kpa']:.2f} kPa, "
                  f"phi {r['friction_angle_deg']:.1f} deg (distance {r['distance']:.3f})")
    print(f"{result.n_simulated} simulated individuals, {result.wall_s:.0f} s; report in {out / 'report.md'}")
    return 0


def _keyvals(text: str) -> dict[str, float]:
    """'a=1,b=2' -> {'a': 1.0, 'b': 2.0}."""
    out = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        try:
            k, v = part.split("=")
            out[k.strip()] = float(v)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected NAME=VALUE[,NAME=VALUE...], got {text!r}") from None
        if not (math.isfinite(out[k.strip()]) and out[k.strip()] > 0):
            raise argparse.ArgumentTypeError(f"{k.strip()} must be a finite number > 0, got {v.strip()!r}")
    return out


_NOT_PARAMS = {"self", "measured", "device", "fixed", "uncertainty", "description", "bed", "runs_from", "simulator"}
"""arguments of a rig model that --params does not set (the command's own options, Python objects)."""


def _diagnose_params(args: argparse.Namespace) -> dict[str, object]:
    """--params read and checked (a JSON object of the rig model's settings and 'fixed'), and --uncertainty's names
    checked against the rig's observables, before anything is read or simulated."""
    import inspect

    from calibration.rig_models import rig_model_class

    model = rig_model_class(args.rig)
    known = model.uncertainty_defaults
    for k in args.uncertainty or {}:
        if k not in known:
            raise InputError(f"--uncertainty {k}={args.uncertainty[k]:g}: {k!r} is no observable of the {args.rig} "
                             f"rig; known: {', '.join(sorted(known))}")
    if not args.params:
        return {}
    where = f"--params {args.params!r}"
    try:
        text = Path(args.params).read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError(f"{where}: no such file (--params names a JSON file holding an object of rig settings, "
                         'e.g. {"ring_time": 1.5, "fixed": {"dashpot": 300}})') from None
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{where} cannot be read: {e}") from None
    try:
        params = json.loads(text)
    except ValueError as e:
        raise InputError(f"{where} is not valid JSON: {e}") from None
    if not isinstance(params, dict):
        raise InputError(f"{where} must hold a JSON object of rig settings (NAME: VALUE), got "
                         f"{type(params).__name__} {text.strip()[:40]}")
    allowed = sorted(set(inspect.signature(model.__init__).parameters) - _NOT_PARAMS) + ["fixed"]
    unknown = sorted(set(params) - set(allowed))
    if unknown:
        raise InputError(f"{where}: unknown key {unknown[0]!r}; the {args.rig} rig takes {', '.join(allowed)}")
    if not isinstance(params.get("fixed", {}), dict):
        raise InputError(f"{where}: 'fixed' must be an object of baseline parameters (NAME: VALUE), got "
                         f"{params['fixed']!r}")
    annotations = {k: str(p.annotation) for k, p in inspect.signature(model.__init__).parameters.items()}
    for key, value in params.items():
        _check_param(where, key, value, annotations[key])
    return params


def _check_param(where: str, key: str, value: object, annotation: str) -> None:
    """One --params setting against its type in the rig model's signature (``annotation``, e.g. "float | None",
    "dict[str, float] | None", "tuple[str, ...] | None"): an InputError naming the setting and its value if it is
    not of that type (a number must be finite; an object's entries are numbers, named ``key.entry``)."""

    def number(v: object) -> bool:
        return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)

    def refuse(name: str, what: str, v: object) -> InputError:
        return InputError(f"{where}: {name!r} must be {what}, got {json.dumps(v)}")

    if value is None and "None" in annotation:
        return
    kind = annotation.split(" | ")[0]
    if kind.startswith("dict["):
        if not isinstance(value, dict):
            raise refuse(key, "an object of numbers (NAME: VALUE)", value)
        for name, v in value.items():
            if not number(v):
                raise refuse(f"{key}.{name}", "a finite number", v)
    elif kind.startswith("tuple[str"):
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise refuse(key, "a list of names", value)
    elif kind == "bool":
        if not isinstance(value, bool):
            raise refuse(key, "true or false", value)
    elif kind == "int":
        if not isinstance(value, int) or isinstance(value, bool):
            raise refuse(key, "a whole number", value)
    elif kind == "float":
        if not number(value):
            raise refuse(key, "a finite number", value)
    elif kind == "str" and not isinstance(value, str):
        raise refuse(key, "a string", value)


def run_diagnose_cmd(args: argparse.Namespace) -> int:
    from calibration import diagnosis, diagnosis_report, measured
    from calibration.rig_models import make_rig_model

    device = _setup(args)
    params = _diagnose_params(args)
    data = measured.from_paper(args.measured.split(":", 1)[1]) if args.measured.startswith("paper:") \
        else measured.load(args.measured)
    fixed = params.pop("fixed", {})
    from calibration import rig_description

    desc = rig_description.load(args.rig_file) if args.rig_file else \
        rig_description.find_description(args.measured) if Path(args.measured).is_dir() else None
    if desc is not None:
        if args.rig != rigs.RINGING.name:
            raise InputError(f"a rig description ({desc.source}) is for --rig ringing, got --rig {args.rig}")
        print(f"rig description: {desc.source}")
    rig = make_rig_model(args.rig, data, device=device, fixed=fixed, uncertainty=args.uncertainty, **params,
                         **({"description": desc} if desc is not None else {}))
    if desc is not None:
        params["description"] = desc.to_dict()
    settings = diagnosis.DiagnosisSettings(rounds=args.rounds, alpha=args.alpha, min_gain=args.min_gain,
                                           mechanisms=tuple(args.mechanisms.split(",")) if args.mechanisms else None,
                                           batch_worlds=args.batch_worlds)
    if rig.n_configs < 2:  # checked again by diagnose(); here before the results folder is made
        raise InputError(f"the diagnosis holds each configuration out in turn and fits the rest: it needs at least "
                         f"2 configurations, the data have {rig.n_configs}")
    out = _claim(args, args.out)
    checkpoint = out / "checkpoint.json"
    if args.no_resume and checkpoint.exists():
        checkpoint.unlink()
    _write_config(out, "diagnose", device, measured=args.measured, rig=args.rig, params=params, fixed=fixed,
                  settings={"rounds": args.rounds, "alpha": args.alpha, "min_gain": args.min_gain,
                            "mechanisms": args.mechanisms, "uncertainty": args.uncertainty})
    d = diagnosis.diagnose(rig, settings, log=lambda m: print(m, flush=True), checkpoint=checkpoint)
    report = diagnosis_report.write(d, out, command="warpdem " + " ".join(args.argv))
    print(f"verdict: {d.verdict}{': ' + ' + '.join(d.cause) if d.cause else ''}; report in {report}")
    return 0


class _DefaultsFormatter(argparse.HelpFormatter):
    """--help with each option's default where its text does not already say it."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        d = action.default
        shown = d is not None and d is not False and d is not argparse.SUPPRESS  # 0 is a default to show
        if action.option_strings and shown and "default" not in text:
            text += f" (default: {','.join(map(str, d)) if isinstance(d, tuple | list) else d})"
        return text


class _DefaultsParser(argparse.ArgumentParser):
    """Subcommand parsers whose --help shows every option's default and whose errors are one line."""

    def __init__(self, **kw: object) -> None:
        super().__init__(formatter_class=_DefaultsFormatter, **kw)

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message}\n")


SCALE_HELP = ("soil-bin size: ci = 0.5 x 0.65 m bin, 20 mm members (tests, seconds); cpu = 0.7 x 1.1 m, 15 mm "
              "(minutes on a CPU); paper = the paper's 1.0 x 2.0 m bin, 7 mm members, about 214,000 spheres (a GPU)")
SWITCHES = {"--verbose": "keep Warp's banner and kernel-load lines", "--quiet": "no progress bars (results and "
            "errors still print)", "--debug": "show the traceback of an internal error"}
"""switches of every command, accepted before or after the command's name."""
SHEAR_SCALE_HELP = ("particle size in the 100 mm box: ci = 10 particles across (assembly A: about half a minute on 2 "
                    "CPU cores; C has about 7x the spheres); cpu = 14 across (minutes to an hour on a CPU); paper = "
                    "20 across (a GPU)")
ASSEMBLY_HELP = "A = single spheres, B = two-sphere clumps, C = the paper's mix with elongated three-sphere clumps"


RESUMABLE = ("reproduce", "soil-bin", "diagnose", "calibrate", "passive-tool")
"""Commands that save checkpoints into their results folder and resume from them when run again (unless given
--no-resume)."""


def main(argv: list[str] | None = None) -> int:
    from warpdem import __version__

    parser = argparse.ArgumentParser(prog="warpdem", description="DEM of soil-tool interaction on NVIDIA Warp")
    parser.add_argument("--version", action="version", version=f"warpdem {__version__}")
    for flag, text in SWITCHES.items():
        parser.add_argument(flag, action="store_true", help=text)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_DefaultsParser)

    def common(p: argparse.ArgumentParser, out: str, scale: bool = True,
               seed: str = "the bed's deposition seed") -> None:
        p.add_argument("--device", default=None, help="Warp device (default: cuda if available, else cpu)")
        p.add_argument("--out", default=out, help="results folder")
        p.add_argument("--seed", type=_number(int, ge=0), default=0, help=seed)
        if scale:
            p.add_argument("--scale", default="cpu", choices=("ci", "cpu", "paper"), help=SCALE_HELP)
            p.add_argument("--assembly", default="C", choices=("A", "B", "C"), help=ASSEMBLY_HELP)

    r = sub.add_parser("reproduce", help="the paper's study (ringing + soil bin) with a report; after a kill, "
                       "the same command resumes the soil-bin runs from OUT/checkpoints")
    common(r, "results/reproduce")
    r.add_argument("--springs", type=_springs, default=None,
                   help="soil-bin configurations, 0 = rigid (quick: default 0,16,32; full: the passive ones, "
                        "default all eight)")
    r.add_argument("--vtk", type=_number(int, ge=1), default=None, metavar="EVERY",
                   help="quick: write ParaView (VTK) frames of the soil-bin runs into OUT/vtk/<run>/ at every "
                        "EVERY-th record")
    r.add_argument("--workflow", choices=("quick", "full"), default="quick",
                   help="quick: ringing with the paper's parameters + soil bin with the paper's GA set 11; full: "
                        "ringing and draught calibrations, shear-box screening, Table 3 with replicas (resumable: "
                        "run the same command again after a stop)")
    _add_budget(r, "full: wall time [s] of this call; the workflow stops (exit code 3) where the next piece "
                   "would not fit, saving its state; the same command continues")
    r.add_argument("--replicas-min", type=_number(int, ge=1), default=3,
                   help="full: independent beds at least (default 3)")
    r.add_argument("--replicas-max", type=_replicas, default=8,
                   help=f"full: independent beds at most (default 8; at most {MAX_REPLICAS}, as soil-bin --replicas)")
    r.add_argument("--target-sem", type=_number(float, gt=0), default=1.0,
                   help="full: replicas are added until every reduction's standard error is below this "
                        "[percentage points] (default 1)")
    r.add_argument("--worlds-per-job", type=_number(int, ge=1), default=4,
                   help="full: soil-bin worlds per simulation (default 4)")
    r.add_argument("--replica-worlds", action="store_true",
                   help="full: Table 3's replicas as worlds of one simulation (replica beds of one population; "
                        "each simulation's worlds spread over a group of replicas)")
    r.add_argument("--settle-time", type=_number(float, ge=0, unit="s"), default=0.5,
                   help="full: [s] a bed settles under the soil set before the tool moves (default 0.5)")
    r.add_argument("--soil-protocol", choices=("paper", "bonded"), default=None,
                   help="full: bonded (default for a new folder): the draught and the shear box calibrated together, "
                        "yielding bonds on a bed settled >= 1 s; paper: the draught GA, then shear-box screening, "
                        "bonds that break (the paper's way; a folder made with it goes on with it)")
    r.add_argument("--box-stresses", type=_stresses, default=None, metavar="KPA,KPA,KPA",
                   help="full: the shear box's normal stresses [kPa] of the soil calibration and the screening "
                        "(default 20,40,80 with --soil-protocol bonded, the box's 5,10,20 with paper; the paper does "
                        "not give the laboratory's)")
    r.add_argument("--box-samples", type=_number(int, ge=1), default=None, metavar="N",
                   help=f"full, bonded: shear-box samples per individual of the soil calibration (default "
                        f"{SOIL_BOX_SAMPLES} in a new folder; a folder goes on with its own)")
    r.add_argument("--deposit-friction", type=_number(float, ge=0, lt=90, unit="deg"), default=30.0,
                   help="full: contact friction of the soil-bin beds' deposition [deg] (0: a dense bed, near the "
                        "paper's coordination)")
    r.add_argument("--tool", default=None, metavar="TOML",
                   help="full: the passive tool of Table 3's passive jobs, described once (scenes/passive_tool.py; "
                        "e.g. a passive-tool run's tool_fitted.toml); 'ringing': the ringing calibration's springs "
                        "(the paper's way; a folder made before this default goes on with it); default: "
                        "the tool fitted to Table 2 and Table 3 together (scenes/data/passive_tool_joint.toml)")
    r.add_argument("--no-diagnosis", action="store_true",
                   help="full: leave out the last stage, the diagnosis of Table 3")
    r.add_argument("--diagnosis-rounds", type=_number(int, ge=1), default=None,
                   help="full: the diagnosis's fit rounds (one grid, then Levenberg-Marquardt; default: the "
                        "folder's, else 3); a folder may change it: its simulated points are kept and refitted")
    r.add_argument("--diagnosis-grid", type=_number(int, ge=2), default=5,
                   help="full: the diagnosis's grid points per gene of a one-gene mechanism")
    r.add_argument("--generations", type=_number(int, ge=1), default=5,
                   help="full: GA generations (default: the paper's 5)")
    r.add_argument("--population", type=_number(int, ge=2), default=20,
                   help="full: GA population (default: the paper's 20)")
    r.add_argument("--parents", type=_number(int, ge=1), default=7,
                   help="full: GA parents mating (default: the paper's 7)")
    g = sub.add_parser("ringing", help="ringing test of the eight spring configurations")
    common(g, "results/ringing", scale=False, seed="not read: the ringing rig has no random input (refused if given)")
    g.add_argument("--springs", type=_springs, default=None,
                   help="spring configurations, e.g. 4,16,32 (default: all eight)")
    g.add_argument("--spring-model", choices=("paper", "linear", "twin"), default=None,
                   help="paper: spring spheres on warpdem's hinged rig; linear: DIN 2093 springs; twin: the paper's "
                   "rig as its text builds it (a ball pivot, the load sphere; equals Yade's); default: all three")
    s = sub.add_parser("soil-bin", help="soil bin: rigid and passive tool; after a kill, the same command resumes "
                       "from OUT/checkpoints")
    common(s, "results/soil_bin")
    s.add_argument("--springs", type=_springs, default=None, help="configurations, 0 = rigid (default 0,16,32)")
    s.add_argument("--spring-model", choices=("paper", "linear"), default=None,
                   help="passive tool's springs: linear spring-dashpot (default) or the paper's spring spheres")
    s.add_argument("--replicas", type=_replicas, default=1, metavar="N",
                   help="run every configuration on N replica beds (worlds of the same simulations) and report the "
                   "mean over them with standard errors from their scatter (default 1: one bed; at most "
                   f"{MAX_REPLICAS}: each bed is deposited on its own and adds a world per configuration, while the "
                   "standard error falls only as 1/sqrt(N))")
    s.add_argument("--tool", default=None, metavar="TOML",
                   help="the passive tool described once (scenes/passive_tool.py: rates, inertia, series compliance, "
                        "preload, pivot height, offsets), e.g. a passive-tool run's tool_fitted.toml; the displacement "
                        "is then zeroed on the tool at rest, as the laboratory reads it")
    s.add_argument("--viewer", action="store_true", help="stream to the Rerun viewer")
    s.add_argument("--viewer-save", default=None, help="write a Rerun recording (.rrd) instead of / as well")
    s.add_argument("--speed-range", type=_speed_range, default=(0.2, 0.7),
                   help="particle speed colour range LO,HI [m/s] (Fig. 15: 0.2,0.7)")
    s.add_argument("--hide-outside-range", action="store_true", help="show only particles inside the speed range")
    s.add_argument("--vtk", type=_number(int, ge=1), default=None, metavar="EVERY",
                   help="write ParaView (VTK) frames of every run into OUT/vtk/<run>/ at every EVERY-th record")
    t = sub.add_parser("passive-tool", help="the passive tool described once: Table 2 fitted within physical "
                       "bounds, the rigid tool's pitch sweep and Table 3 with the fitted tool (resumable)")
    common(t, "results/passive_tool")
    t.add_argument("--travel", type=_number(float, gt=0, unit="m"), default=None,
                   help="travel of every soil-bin run [m] (default: the scale's)")
    t.add_argument("--steady-travel", type=_number(float, gt=0, unit="m"), default=None,
                   help="travel after which the steady state is averaged [m] (default: the scale's)")
    t.add_argument("--shank-length", type=_number(float, gt=0, unit="m"), default=0.6,
                   help="the pivot's height above the blade tip [m] (default 0.6, an assumption: the paper gives none)")
    t.add_argument("--pitches", type=_pitches, default=None,
                   help="the rigid tool's backward pitches [deg] besides 0, comma-separated, or 'none' (default "
                        "-4,-2,2,4,6,8,9)")
    t.add_argument("--variants", type=_variants, default=None,
                   help="tool variants of the passive runs, comma-separated (default fitted,din_preload, and "
                        "described with --tool; described_offsets: that tool with Table 2's support offsets, on "
                        "the same bed)")
    t.add_argument("--tool", default=None, metavar="TOML",
                   help="a described tool (variant 'described'), e.g. the tool_joint.toml that --joint-from writes; "
                        "its shank_length must be --shank-length")
    t.add_argument("--joint-from", type=_folders, default=None, metavar="DIR,...",
                   help="instead of running stages: fit Table 2's frequencies and Table 3's displacements with one "
                        "tool, the soil's levers read from these finished passive-tool folders (their 'din_preload' "
                        "runs, one shank length); writes joint.json, joint.md and tool_joint.toml (the per-rig fit "
                        "at the runs' shank length) into --out")
    t.add_argument("--beds-from", type=_folders, default=None, metavar="DIR,...",
                   help="instead of running stages: Table 3 over several beds, from these finished passive-tool "
                        "folders (the variant --variants names, default described; each reduction against its own "
                        "bed's rigid run; a second variant: the first's runs against its, paired on the beds that "
                        "hold both); writes beds.json, beds.md and fig_table3_beds.png into --out")
    t.add_argument("--soil", default="workflow", metavar="NAME|DIR",
                   help="workflow: the paper-scale workflow's calibrated soil (default); bonded: GA set 11 with 4x its "
                        "cohesions, yielding bonds on a settled bed (its draught and shear box match the lab's); "
                        "dense: GA set 11, yielding bonds on a bed deposited without friction; or the folder of a "
                        "`warpdem calibrate draught` or `calibrate soil` run: its best soil and bed protocol")
    _add_budget(t, "wall time [s] of this call; a soil-bin stage stops into its checkpoint (exit code 3) and "
                   "the same command continues")
    v = sub.add_parser("speed-sweep", help="rigid draught against speed (one world per speed) and the paper's "
                       "Table 7 reductions re-paired with a rigid run at each configuration's speed")
    common(v, "results/speed_sweep")
    v.add_argument("--speeds", type=_speeds, default=(0.45, 0.50, 0.55, 0.60, 0.65, 0.70, 0.75),
                   help="carriage speeds [m/s] (default 0.45,0.50,...,0.75)")
    v.add_argument("--vtk", type=_number(int, ge=1), default=None, metavar="EVERY",
                   help="write ParaView (VTK) frames of every speed's world into OUT/vtk/ at every EVERY-th record")
    v.add_argument("--soil-from", default=None, metavar="DIR|NAME",
                   help="the soil of a `warpdem calibrate draught` or `calibrate soil` folder: its best individual "
                        "and the bed protocol it was calibrated with; or a study soil by name (workflow, bonded, "
                        "dense: `passive-tool --soil`) (default: the assembly's GA set)")
    x = sub.add_parser("shear-box", help="direct shear box: Mohr-Coulomb cohesion and friction angle")
    common(x, "results/shear_box", scale=False, seed="the sample's deposition seed")
    x.add_argument("--scale", default="cpu", choices=("ci", "cpu", "paper"), help=SHEAR_SCALE_HELP)
    x.add_argument("--assembly", default="C", choices=("A", "B", "C"), help=ASSEMBLY_HELP)
    x.add_argument("--normal-stresses", type=_stresses, default=None, metavar="KPA,KPA,KPA",
                   help="the plate's normal stresses [kPa] (default 5,10,20, or --soil-from's calibration's; the "
                        "paper does not give the laboratory's)")
    x.add_argument("--soil-from", default=None, metavar="DIR|NAME",
                   help="the soil of a `warpdem calibrate draught` or `calibrate soil` folder: its best individual, "
                        "its bonds' rule and, from `calibrate soil`, the box's normal stresses; or a study soil by "
                        "name (workflow, bonded, dense: `passive-tool --soil`) (default: the assembly's GA set)")
    x.add_argument("--vtk", type=_number(int, ge=1), default=None, metavar="EVERY",
                   help="write ParaView (VTK) frames of every normal stress's sample into OUT/vtk/ while it is "
                        "sheared, at its start and at every EVERY-th record")
    d = sub.add_parser("demo", help="deposit a small cohesive bed and cut it with a blade")
    d.add_argument("--device", default=None, help="Warp device (default: cuda if available, else cpu)")
    d.add_argument("--particles", type=_number(int, ge=1), default=1500, help="particles in the bed")
    d.add_argument("--seed", type=_number(int, ge=0), default=0, help="deposition seed")
    d.add_argument("--deposit-time", type=_number(float, gt=0, unit="s"), default=0.5,
                   help="simulated deposition time [s]")
    d.add_argument("--speed", type=_number(float, gt=0, unit="m/s"), default=0.5, help="blade speed [m/s]")
    d.add_argument("--depth", type=_number(float, gt=0, unit="m"), default=0.03, help="cutting depth [m]")
    d.add_argument("--cut", type=_number(float, gt=0, unit="m"), default=0.06, help="cut length [m]")
    d.add_argument("--out", default="results/demo", help="results folder")
    d.add_argument("--vtk", type=_number(int, ge=1), default=None, metavar="EVERY",
                   help="write ParaView (VTK) frames of the cut into OUT/vtk/ at every EVERY-th record (200 in all)")
    c = sub.add_parser("calibrate", help="GA calibration (ringing rig, draught, or soil: draught and shear box "
                       "together), populations as batched worlds")
    c.add_argument("kind", choices=("ringing", "draught", "soil"))
    c.add_argument("--device", default=None, help="Warp device (default: cuda if available, else cpu)")
    c.add_argument("--out", default=None, help="results folder (default results/calibrate/<kind>_<springs|assembly>)")
    c.add_argument("--seed", type=_number(int, ge=0), default=0, help="GA seed (and the bed's deposition seed)")
    c.add_argument("--generations", type=_number(int, ge=1), default=5, help="GA generations (the paper's 5)")
    c.add_argument("--population", type=_number(int, ge=2), default=20, help="GA population (the paper's 20)")
    c.add_argument("--parents", type=_number(int, ge=1), default=7, help="GA parents mating (the paper's 7)")
    c.add_argument("--refine", type=_number(int, ge=0), default=0,
                   help="batched pattern-search iterations after the GA")
    c.add_argument("--gene", type=_gene_range, action="append", help="replace a gene range: NAME=LOW:HIGH (SI)")
    c.add_argument("--springs", type=int, default=16, choices=SPRING_COUNTS,
                   help="ringing: spring configuration")
    c.add_argument("--spring-model", choices=("paper", "linear", "twin"), default="paper",
                   help="ringing: spring model")
    c.add_argument("--fitness", choices=("paper", "max"), default="paper",
                   help="ringing: eq. (7) 1/(REf REd), or 1/max(REf, REd)")
    c.add_argument("--scale", default="ci", choices=("ci", "cpu", "paper", "paper_1m"),
                   help="draught, soil: soil-bin scale (paper_1m: the paper's 1 m calibration bin at its particle "
                        "size)")
    c.add_argument("--assembly", default="C", choices=("A", "B", "C"), help="draught: assembly")
    c.add_argument("--speed", type=_number(float, gt=0, unit="m/s"), default=0.62, help="draught: carriage speed [m/s]")
    c.add_argument("--screen-scale", default=None, choices=("ci", "cpu", "paper"),
                   help="draught: shear-box scale of the screening; soil: of the shear box (default: --scale)")
    c.add_argument("--no-screen", action="store_true", help="draught: calibrate only, no shear-box screening")
    c.add_argument("--deposit-friction", type=_number(float, ge=0, lt=90, unit="deg"), default=30.0,
                   help="draught, soil: contact friction of the bed's deposition [deg] (0: a dense bed)")
    c.add_argument("--box-stresses", type=_stresses, default=None, metavar="KPA,KPA,KPA",
                   help="soil: the shear box's normal stresses [kPa] (default 5,10,20; the paper does not give the "
                        "laboratory's)")
    c.add_argument("--box-samples", type=_number(int, ge=1), default=None, metavar="N",
                   help="soil: shear-box samples per individual, each deposited with its own seed; the box's c and "
                        f"phi are their means (default {SOIL_BOX_SAMPLES}: one sample's c and phi scatter by about 1 "
                        "kPa and 0.9 deg)")
    c.add_argument("--beds", default=None,
                   help="draught: folder of deposited beds to read and add to (default OUT/beds)")
    c.add_argument("--archive", default=None, help="archive.json of an earlier calibration to reuse")
    c.add_argument("--no-resume", action="store_true", help="start afresh even if --out holds a saved state")
    c.add_argument("--ray-workers", type=_number(int, ge=1), default=None,
                   help="evaluate on N Ray workers (optional extra)")
    c.add_argument("--ray-address", default=None, help="address of an existing Ray cluster")
    _add_budget(c, "wall time [s] for this call: stop before a GA batch that would not fit (exit 3); the same "
                   "command continues")
    q = sub.add_parser("diagnose", help="model criticism: residuals, candidate mechanisms, the named cause, its gain")
    q.add_argument("measured", help="MEASURED data (a summary CSV or a folder; calibration.measured), or "
                                    "paper:ringing (Table 2) or paper:soil-bin (Table 3)")
    q.add_argument("--rig", choices=(rigs.RINGING.name, rigs.SOIL_BIN.name), required=True,
                   help="the rig the data come from")
    q.add_argument("--params", default=None, metavar="FILE",
                   help="a JSON file: rig settings (ringing: load_force, ring_time, ...; soil-bin: scale, assembly, "
                        "travel, cache_dir, ...) and 'fixed': baseline parameters not to fit (e.g. dashpot)")
    q.add_argument("--rig-file", default=None,
                   help="ringing: the rig's description (TOML/JSON: inertia, lever arms, load, spring rates, what "
                        "is uncertain; calibration.rig_description); default rig.toml or rig.json in MEASURED")
    q.add_argument("--device", default=None, help="Warp device (default: cuda if available, else cpu)")
    q.add_argument("--out", default="results/diagnose", help="results folder")
    q.add_argument("--mechanisms", default=None, help="comma-separated candidates (default: all that apply)")
    q.add_argument("--uncertainty", type=_keyvals, default=None,
                   help="1-sigma uncertainties, e.g. frequency=0.01,damping=0.05 (relative) or "
                        "reduction=2,displacement_mean=2e-4 (absolute: %% points, m)")
    q.add_argument("--rounds", type=_number(int, ge=1), default=6,
                   help="fit rounds (one grid, then Levenberg-Marquardt)")
    q.add_argument("--alpha", type=_number(float, gt=0, lt=1), default=0.05, help="family-wise significance level")
    q.add_argument("--min-gain", type=_number(float, ge=0, lt=1), default=0.3,
                   help="least relative fall of the held-out loss")
    q.add_argument("--batch-worlds", type=_number(int, ge=0), default=0,
                   help="at most N worlds per batched simulation, the checkpoint saved after each (0: one per round)")
    q.add_argument("--no-resume", action="store_true", help="start afresh even if --out holds a checkpoint")
    for p in sub.choices.values():
        # the global switches are accepted after the command too (default SUPPRESS: absent, they keep the value
        # given before the command)
        for flag, text in SWITCHES.items():
            p.add_argument(flag, action="store_true", default=argparse.SUPPRESS, help=text)
        p.add_argument("--overwrite", action="store_true",
                       help="replace a results folder (--out) that holds another run; without it such a folder is "
                            "refused")
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    args.defaults = {a.dest: a.default for a in sub.choices[args.command]._actions if a.dest != "help"}
    args.given = _given(sub.choices[args.command], args.argv)
    if not args.verbose:
        from warpdem import init_quietly

        init_quietly()
    _BAR["quiet"] = args.quiet
    commands = {"diagnose": run_diagnose_cmd, "demo": run_demo, "reproduce": run_reproduce, "ringing": run_ringing_cmd,
                "soil-bin": run_soil_bin_cmd, "passive-tool": run_passive_tool_cmd,
                "speed-sweep": run_speed_sweep_cmd, "shear-box": run_shear_box_cmd, "calibrate": run_calibrate_cmd}
    try:
        return commands[args.command](args)
    except InputError as e:  # a user's bad input: one line naming it, no traceback
        _end_bar()
        print(f"warpdem {args.command}: error: {e}", file=sys.stderr)
        return 2
    except SimulationError as e:  # a run that went unstable: where and why, in one line
        _end_bar()
        print(f"warpdem {args.command}: simulation stopped: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # Ctrl-C or SIGINT (a time limit): one line, no traceback
        _end_bar()
        if args.debug:
            raise
        again = args.command in RESUMABLE and not getattr(args, "no_resume", False)
        print(f"warpdem {args.command}: interrupted" + ("; the same command run again resumes from its last "
                                                        "checkpoint" if again else ""), file=sys.stderr)
        return 130
    except Exception as e:  # noqa: BLE001 - an internal error: one line, the traceback with --debug
        _end_bar()
        if args.debug:
            raise
        print(f"warpdem {args.command}: internal error: {type(e).__name__}: {e} (run with --debug for the "
              "traceback)", file=sys.stderr)
        return 1


if __name__ == "__main__":
    raise SystemExit(main())
