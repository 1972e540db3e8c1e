"""The `warpdem` command as a user meets it: --version, defaults in --help, Warp's banner off (one process each)."""

from __future__ import annotations

import json
import subprocess
import sys

import warpdem


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "calibration.cli", *args], capture_output=True, text=True, timeout=300)


def test_version_and_defaults_in_help() -> None:
    r = _run("--version")
    assert r.returncode == 0 and r.stdout.strip() == f"warpdem {warpdem.__version__}"
    h = _run("soil-bin", "--help")
    assert h.returncode == 0
    text = " ".join(h.stdout.split())
    for shown in ("(default: cpu)", "(default: C)", "(default: results/soil_bin)", "214,000 spheres"):
        assert shown in text, shown


def test_warp_banner_off_unless_verbose_and_bad_input_is_one_line() -> None:
    """The command initialises Warp (it picks the default device) and then refuses --springs 0 for the full
    workflow: stdout holds no banner, stderr one line; --verbose brings the banner back (and, on a machine without
    an NVIDIA driver like CI's, Warp's own "CUDA driver" line)."""
    args = ("reproduce", "--workflow", "full", "--springs", "0", "--out", "unused")
    r = _run(*args)
    assert r.returncode == 2
    assert "initialized" not in r.stdout
    lines = [x for x in r.stderr.splitlines() if x.strip()]  # without a GPU, Warp's native driver line is off too
    assert lines == ["warpdem reproduce: error: --springs of the full workflow lists passive configurations (the "
                     "rigid runs are always made), got 0"]
    v = _run("--verbose", *args)
    assert v.returncode == 2 and "initialized" in v.stdout


def test_bed_files_are_written_atomically_and_a_damaged_one_is_named(tmp_path) -> None:
    """Bed.save leaves only the bed (no temporary file); a truncated or foreign file raises InputError naming it,
    not a raw zipfile/numpy error."""
    import numpy as np
    import pytest

    from scenes.assemblies import AssemblySpec, Bed
    from warpdem.errors import InputError

    bed = Bed(AssemblySpec(kind="A", radius=0.01), (0.2, 0.2, 0.2), 0.1, np.random.default_rng(0).random((5, 3)),
              np.full(5, 0.01), np.arange(5))
    path = tmp_path / "bed.npz"
    bed.save(path)
    assert [p.name for p in tmp_path.iterdir()] == ["bed.npz"]
    back = Bed.load(path)
    assert np.array_equal(back.centres, bed.centres) and np.array_equal(back.particle, bed.particle)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match="bed.npz.*not a readable bed"):
        Bed.load(path)
    np.savez(path, centres=np.zeros((3, 3)))
    with pytest.raises(InputError, match="not a readable bed"):
        Bed.load(path)


def test_two_runs_into_one_folder_lose_nothing(tmp_path) -> None:
    """`warpdem ringing` for 16 springs, then for 32 springs into the same --out: the second is refused (exit 2, one
    line) and the first run's summary is untouched; the same command again continues in its folder; --overwrite
    replaces it. A non-empty folder that is no warpdem run is refused."""
    import json

    out = tmp_path / "ring"
    base = ("ringing", "--spring-model", "linear", "--device", "cpu", "--out", str(out))
    assert _run(*base, "--springs", "16").returncode == 0
    first = (out / "summary.json").read_text()
    assert [r["springs"] for r in json.loads(first)["linear"]] == [16]
    r = _run(*base, "--springs", "32")
    assert r.returncode == 2 and "holds another run" in r.stderr and "--overwrite" in r.stderr
    assert (out / "summary.json").read_text() == first
    assert _run(*base, "--springs", "16").returncode == 0
    assert _run(*base, "--springs", "32", "--overwrite").returncode == 0
    assert [r["springs"] for r in json.loads((out / "summary.json").read_text())["linear"]] == [32]
    other = tmp_path / "mine"
    other.mkdir()
    (other / "notes.txt").write_text("keep")
    r = _run(*base[:-1], str(other), "--springs", "16")
    assert r.returncode == 2 and "holds no warpdem run" in r.stderr
    assert (other / "notes.txt").read_text() == "keep"


def test_a_run_continued_elsewhere_keeps_where_each_call_ran(tmp_path) -> None:
    """A calibration stopped by its budget on two GPUs may continue on one or on the CPU: the Ray workers are not
    part of the folder's claim (as the device is not), and config.json keeps the earlier calls' device and
    versions, oldest first, once a call ran elsewhere."""
    import argparse

    from calibration import cli

    def claim(workers: int | None) -> object:
        return cli._claim(argparse.Namespace(command="calibrate", kind="soil", seed=0, ray_workers=workers,
                                             ray_address=None, device="cpu"), tmp_path / "ga")

    out = claim(2)
    assert claim(None) == out and claim(4) == out
    cli._write_config(out, "calibrate soil", "cuda", problem={"seed": 0})
    first = json.loads((out / "config.json").read_text())
    cli._write_config(out, "calibrate soil", "cuda", problem={"seed": 0})
    assert "earlier_calls" not in json.loads((out / "config.json").read_text())
    cli._write_config(out, "calibrate soil", "cpu", problem={"seed": 0})
    cli._write_config(out, "calibrate soil", "cpu", problem={"seed": 0})
    cfg = json.loads((out / "config.json").read_text())
    assert cfg["device"] == "cpu" and cfg["problem"] == {"seed": 0}
    assert cfg["earlier_calls"] == [{"device": "cuda", "versions": first["versions"]}]
    cli._write_config(out, "calibrate soil", "cuda", problem={"seed": 0})
    assert [c["device"] for c in json.loads((out / "config.json").read_text())["earlier_calls"]] == ["cuda", "cpu"]


BAD = [
    ("demo --speed -0.5", "argument --speed: must be > 0 m/s, got '-0.5'"),
    ("demo --depth -0.05", "argument --depth: must be > 0 m"),
    ("demo --cut 0", "argument --cut: must be > 0 m"),
    ("demo --deposit-time -1", "argument --deposit-time: must be > 0 s"),
    ("demo --particles 0", "argument --particles: must be >= 1"),
    ("demo --speed inf", "argument --speed: must be > 0 m/s, got 'inf'"),
    ("demo --vtk -2", "argument --vtk: must be >= 1"),
    ("ringing --springs ,", "argument --springs: must list one or more of"),
    ("ringing --springs 16,x", "argument --springs: must be comma-separated spring counts"),
    ("soil-bin --springs 0,17", "argument --springs: must list one or more of"),
    ("passive-tool --variants fitted,stiff", "argument --variants: must name tool variants among"),
    ("passive-tool --travel -1", "argument --travel: must be > 0 m"),
    ("passive-tool --joint-from nowhere", "error: --joint-from: 'nowhere' holds no finished 'din_preload' passive run"),
    ("passive-tool --variants described", "error: --variants described needs --tool TOML"),
    ("passive-tool --variants din_preload,described_offsets", "error: --variants described_offsets needs --tool TOML"),
    ("passive-tool --beds-from nowhere", "error: --beds-from: 'nowhere' holds no finished 'described' passive run"),
    ("passive-tool --beds-from a --joint-from b", "error: --joint-from and --beds-from are two jobs; give one"),
    ("passive-tool --beds-from a --variants fitted,described,din_preload",
     "error: --beds-from combines one tool variant, or one against another"),
    ("soil-bin --seed -3", "argument --seed: must be >= 0"),
    ("soil-bin --scale huge", "argument --scale: invalid choice: 'huge'"),
    ("soil-bin --vtk 0", "argument --vtk: must be >= 1"),
    ("soil-bin --replicas 0", "argument --replicas: must be >= 1"),
    ("soil-bin --replicas 2.5", "argument --replicas: must be an integer"),
    ("soil-bin --speed-range 0.5", "argument --speed-range: must be LO,HI in m/s, got '0.5'"),
    ("soil-bin --speed-range 0.7,0.2", "argument --speed-range: must be LO,HI with 0 <= LO < HI"),
    ("speed-sweep --speeds 0.5,-1", "argument --speeds: must be one or more speeds > 0"),
    ("reproduce --budget nan", "argument --budget: must be > 0 s, got 'nan'"),
    ("reproduce --workflow full --replicas-min 0", "argument --replicas-min: must be >= 1"),
    ("reproduce --workflow full --target-sem -1", "argument --target-sem: must be > 0"),
    ("reproduce --workflow full --settle-time -0.1", "argument --settle-time: must be >= 0 s"),
    ("speed-sweep --vtk 0", "argument --vtk: must be >= 1"),
    ("calibrate draught --population 1", "argument --population: must be >= 2"),
    ("calibrate draught --speed 0", "argument --speed: must be > 0 m/s"),
    ("calibrate ringing --springs 17", "argument --springs: invalid choice: 17"),
    ("calibrate ringing --refine -1", "argument --refine: must be >= 0"),
    ("diagnose x --rig ringing --alpha 1", "argument --alpha: must be > 0 and < 1, got '1'"),
    ("diagnose x --rig ringing --min-gain 1.5", "argument --min-gain: must be >= 0 and < 1"),
    ("diagnose x --rig ringing --rounds 0", "argument --rounds: must be >= 1"),
    ("diagnose x --rig ringing --uncertainty frequency=inf", "argument --uncertainty: frequency must be a finite"),
    ("diagnose x --rig ringing --uncertainty damping=0", "argument --uncertainty: damping must be a finite"),
    ("soil-bin --replicas 100000", "argument --replicas: must be at most 32, got '100000': each replica deposits"),
    ("soil-bin --springs 16,16", "argument --springs: lists 16 more than once (each configuration runs once)"),
    ("speed-sweep --speeds 0.5,0.6,0.5", "argument --speeds: lists 0.5 more than once (each speed runs once)"),
    ("reproduce --workflow full --replicas-max 100", "argument --replicas-max: must be at most 32, got '100'"),
    ("reproduce --budget 10 --replicas-max 2 --target-sem 0.1",
     "error: --budget 10, --replicas-max 2, --target-sem 0.1: only --workflow full reads them"),
    ("reproduce --replica-worlds", "error: --replica-worlds: only --workflow full reads it"),
    ("reproduce --deposit-friction 0", "error: --deposit-friction 0: only --workflow full reads it"),
    ("reproduce --soil-protocol bonded --box-stresses 20,40,80",
     "error: --soil-protocol bonded, --box-stresses 20,40,80: only --workflow full reads them"),
    ("reproduce --workflow full --deposit-friction 90", "argument --deposit-friction: must be >= 0 and < 90 deg"),
    ("calibrate soil --deposit-friction -5", "argument --deposit-friction: must be >= 0 and < 90 deg"),
    ("calibrate soil --box-stresses 20,40", "argument --box-stresses: must be at least three distinct normal stresses"),
    ("calibrate soil --box-stresses 20,x,80", "argument --box-stresses: must be comma-separated normal stresses"),
    ("calibrate draught --box-stresses 20,40,80", "--box-stresses: only 'calibrate soil' reads it (its shear box), "
                                                  "got 'calibrate draught'"),
    ("calibrate soil --box-samples 0", "argument --box-samples: must be >= 1"),
    ("calibrate draught --box-samples 3", "--box-samples: only 'calibrate soil' reads it (its shear box), got "
                                          "'calibrate draught'"),
    ("reproduce --box-samples 3", "error: --box-samples 3: only --workflow full reads it"),
    ("reproduce --workflow full --soil-protocol paper --box-samples 3 --out {tmp}/w",
     "error: --box-samples 3: only the bonded soil protocol's calibration reads it, got --soil-protocol paper"),
    ("shear-box --normal-stresses 10,10,-3", "argument --normal-stresses: must be at least three distinct normal"),
    ("speed-sweep --soil-from {tmp}/none --out {tmp}/s", "error: soil folder '{tmp}/none' holds no archive.json of a "
                                                         "warpdem calibration"),
    ("shear-box --soil-from {tmp}/ring --out {tmp}/s", "error: soil folder '{tmp}/ring' holds no draught or soil "
                                                       "calibration (rig 'ringing', 0 individuals)"),
    ("passive-tool --soil clay --out {tmp}/s", "error: soil must be one of ['bonded', 'dense', 'workflow'] or a "
                                               "calibration's folder, got 'clay'"),
    ("speed-sweep --soil-from {tmp}/soil --assembly A --out {tmp}/s", "error: --assembly A differs from the soil's (C, "
                                                                      "calibrated in {tmp}/soil); give --assembly C"),
    ("shear-box --soil-from bonded --assembly A --out {tmp}/s", "error: --assembly A differs from the soil's (C, the "
                                                                "study soil bonded); give --assembly C"),
    ("calibrate soil --budget 0", "argument --budget: must be > 0 s"),
    ("calibrate draught --scale paper_2m", "argument --scale: invalid choice: 'paper_2m'"),
    ("calibrate ringing --gene young=1e8:1e6", "argument --gene: --gene must be NAME=LOW:HIGH with finite LOW < HIGH, "
                                               "got 'young=1e8:1e6'"),
    ("calibrate ringing --gene dashpot=1:10 --out {tmp}/c", "error: --gene dashpot=1:10: unknown gene name 'dashpot'"),
    ("calibrate ringing --gene young=-1:1 --out {tmp}/c", "error: --gene young=-1:1: gene 'young': a log-scaled gene "
                                                          "needs low > 0"),
    ("diagnose x --rig ringing --uncertainty frequncy=0.01",
     "error: --uncertainty frequncy=0.01: 'frequncy' is no observable of the ringing rig; known: damping,"),
    ("diagnose x --rig ringing --params [0.6]", "error: --params '[0.6]': no such file (--params names a JSON file"),
    ("diagnose x --rig ringing --params {tmp}/list.json", "error: --params '{tmp}/list.json' must hold a JSON object "
                                                         "of rig settings (NAME: VALUE), got list [0.6]"),
    ("diagnose x --rig ringing --params {tmp}/typo.json", "error: --params '{tmp}/typo.json': unknown key 'ring_tme'; "
                                                         "the ringing rig takes"),
    ("diagnose x --rig ringing --params {tmp}/word.json", "error: --params '{tmp}/word.json': 'ring_time' must be a "
                                                         'finite number, got "abc"'),
    ("diagnose x --rig ringing --params {tmp}/in_list.json", "error: --params '{tmp}/in_list.json': 'ring_time' must "
                                                            "be a finite number, got [1.5]"),
    ("diagnose x --rig soil-bin --params {tmp}/soil.json", "error: --params '{tmp}/soil.json': 'soil.friction_angle' "
                                                          'must be a finite number, got "abc"'),
    ("demo --out {tmp}/file", "error: --out '{tmp}/file' is a file, not a folder"),
    ("demo --out {tmp}/read-only/demo", "error: --out '{tmp}/read-only/demo' cannot be written (Permission denied)"),
    ("diagnose {tmp}/binary.csv --rig ringing --out {tmp}/d", "error: {tmp}/binary.csv: not a text CSV file (byte 4 "
                                                              "is not UTF-8)"),
    ("diagnose {tmp}/m.csv --rig ringing --rig-file {tmp}/rig.toml --out {tmp}/d",
     "error: rig description: spring_rates key -4 is not a spring count of the rig; allowed 4, 8,"),
    ("ringing --seed 3", "error: --seed 3: the ringing rig has no bed and no other random input; leave it out"),
    ("diagnose {tmp}/temperature.csv --rig ringing --out {tmp}/d",
     "error: {tmp}/temperature.csv: column 'temperature [C]' is not one warpdem reads; accepted: springs, stiffness,"),
    ("diagnose {tmp}/twice.csv --rig ringing --out {tmp}/d",
     "error: {tmp}/twice.csv: rows 1 and 3 are one configuration (springs 16) with different values (frequency [Hz]: "
     "6.09 and 7.5); give one row per configuration"),
    ("diagnose {tmp}/header.csv --rig ringing --out {tmp}/d",
     "error: {tmp}/header.csv: a header (springs, frequency [Hz], damping [-]) and no rows; give one row per "
     "configuration"),
    ("diagnose {tmp}/semicolon.csv --rig ringing --out {tmp}/d",
     "error: {tmp}/semicolon.csv: the header 'springs;frequency [Hz];damping [-]' is separated by ';'; the separator "
     "must be a comma"),
]


def test_bad_command_lines_get_one_line_naming_the_value(capsys, tmp_path, monkeypatch) -> None:
    """Each bad value ends the command with exit code 2 and exactly one line `warpdem <cmd>: error: <what>`
    naming the option and the value (no usage block, no traceback), before anything runs: no results folder is
    made. {tmp}: a folder with the files the lines name."""
    import os
    from pathlib import Path

    from calibration import cli

    (tmp_path / "list.json").write_text("[0.6]\n")
    (tmp_path / "typo.json").write_text('{"ring_tme": 1.5}\n')
    (tmp_path / "word.json").write_text('{"ring_time": "abc"}\n')
    (tmp_path / "in_list.json").write_text('{"ring_time": [1.5]}\n')
    (tmp_path / "soil.json").write_text('{"soil": {"friction_angle": "abc"}}\n')
    (tmp_path / "file").write_text("not a folder\n")
    soil_key = {"rig": "soil_bin_rigid", "assembly": "C", "scale": "ci", "speed": 0.62}
    for name, key in (("ring", {"rig": "ringing"}), ("soil", soil_key)):
        (tmp_path / name).mkdir()
        records = [] if name == "ring" else [{"index": 0, "generation": 0, "stage": "ga", "observables": {},
                                              "genes": {"friction_angle": 30.0, "normal_cohesion": 1e3,
                                                        "eta_roll": 0.01}}]
        (tmp_path / name / "archive.json").write_text(json.dumps({"gene_names": ["friction_angle", "normal_cohesion",
                                                                                 "eta_roll"],
                                                                  "simulation_key": key, "records": records}))
    (tmp_path / "binary.csv").write_bytes(b"\x7fELF\xd0\x01\x02\x00")
    (tmp_path / "m.csv").write_text("springs,frequency [Hz],damping [-]\n16,6.09,0.2027\n32,7.5,0.2\n")
    (tmp_path / "rig.toml").write_text("[spring_rates]\n-4 = 2.1e5\n")
    (tmp_path / "temperature.csv").write_text("springs,frequency [Hz],damping [-],temperature [C]\n16,6.09,0.2027,21\n"
                                              "32,7.5,0.2,22\n")
    (tmp_path / "twice.csv").write_text("springs,frequency [Hz],damping [-]\n16,6.09,0.2027\n32,7.5,0.2\n16,7.5,0.2\n")
    (tmp_path / "header.csv").write_text("springs,frequency [Hz],damping [-]\n")
    (tmp_path / "semicolon.csv").write_text("springs;frequency [Hz];damping [-]\n16;6,09;0,2027\n32;7,5;0,2\n")
    read_only = tmp_path / "read-only"
    read_only.mkdir(mode=0o555)
    if os.geteuid() == 0:  # root writes anywhere: the folder refuses its writes as it would a user's
        write = cli.write_text_atomic

        def refused(path: Path, text: str) -> None:
            if read_only in Path(path).parents:
                raise PermissionError(13, "Permission denied", str(path))
            write(path, text)
        monkeypatch.setattr(cli, "write_text_atomic", refused)
    for line, words in BAD:
        line, words = line.replace("{tmp}", str(tmp_path)), words.replace("{tmp}", str(tmp_path))
        capsys.readouterr()
        try:  # argparse's refusals exit, the commands' return 2
            code = cli.main(line.split())
        except SystemExit as e:
            code = e.code
        err = capsys.readouterr().err.strip().splitlines()
        cmd = line.split()[0]
        assert code == 2, line
        assert len(err) == 1 and err[0].startswith(f"warpdem {cmd}: error: ") and words in err[0], (line, err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["binary.csv", "file", "header.csv", "in_list.json",
                                                         "list.json", "m.csv", "read-only", "rig.toml", "ring",
                                                         "semicolon.csv", "soil", "soil.json", "temperature.csv",
                                                         "twice.csv", "typo.json", "word.json"]
    assert not any(read_only.iterdir())


def test_a_diagnosis_of_one_configuration_is_refused_before_its_folder_is_made(tmp_path, capsys) -> None:
    """Leave-one-configuration-out needs at least two configurations: one row is a one-line error (exit 2) and no
    results folder is written."""
    from calibration.cli import main

    m = tmp_path / "one.csv"
    m.write_text("springs,frequency [Hz],damping [-]\n16,6.09,0.2027\n")
    out = tmp_path / "diag"
    capsys.readouterr()
    assert main(["diagnose", str(m), "--rig", "ringing", "--device", "cpu", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["warpdem diagnose: error: the diagnosis holds each configuration out in turn and fits the rest: "
                   "it needs at least 2 configurations, the data have 1"]
    assert not out.exists()


def test_an_excel_csv_with_a_byte_order_mark_is_read_by_the_command(tmp_path, capsys) -> None:
    """Excel's "CSV UTF-8" export starts with a byte-order mark (EF BB BF): `warpdem diagnose` reads it as the plain
    table. Here one configuration, which the diagnosis refuses after reading it (exit 2, before any simulation and
    before its folder is made): the refusal counts the file's one row, so the header with the mark was read."""
    from calibration.cli import main

    m = tmp_path / "excel.csv"
    m.write_bytes(b"\xef\xbb\xbfsprings,frequency [Hz],damping [-]\r\n16,6.09,0.2027\r\n")
    out = tmp_path / "diag"
    capsys.readouterr()
    assert main(["diagnose", str(m), "--rig", "ringing", "--device", "cpu", "--out", str(out)]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "warpdem diagnose: error: the diagnosis holds each configuration out in turn and fits the rest: it needs at "
        "least 2 configurations, the data have 1"]
    assert not out.exists()


def test_progress_shows_elapsed_and_time_left_and_quiet_silences_it(capsys) -> None:
    """A stage's line carries its percentage, elapsed time and an estimate of the time left (elapsed x left/done);
    a new stage ends the previous line; --quiet writes nothing."""
    import time

    from calibration import cli

    cli._BAR.update(quiet=False, label=None)
    cli._bar("stage one", 0.0, 4.0)
    time.sleep(0.2)
    cli._bar("stage one", 1.0, 4.0)
    cli._bar("stage two", 1.0, 2.0)
    cli._bar("stage two", 2.0, 2.0)
    err = capsys.readouterr().err
    lines = err.split("\n")
    assert "stage one" in lines[0] and " 25 %" in lines[0] and "s left" in lines[0]
    assert "stage two" in lines[1] and "100 %" in lines[1] and err.endswith("\n")
    cli._BAR.update(quiet=True, label=None)
    cli._bar("stage three", 1.0, 2.0)
    assert capsys.readouterr().err == ""
    cli._BAR.update(quiet=False, label=None)


def test_a_command_stopped_mid_bar_says_so_on_a_line_of_its_own(monkeypatch, capsys) -> None:
    """A progress bar's line stays open while its stage runs (it is redrawn with a carriage return); a command that
    stops there (bad input found late, an interrupt, an internal error) ends that line first, so its one line starts
    a line of its own."""
    from calibration import cli
    from warpdem.errors import InputError

    def late(exc: BaseException):  # noqa: ANN202
        def command(args):  # noqa: ANN001
            cli._bar("screening: shear box", 1.0, 4.0)
            raise exc
        return command

    for exc, code, line in ((InputError("what was wrong"), 2, "warpdem shear-box: error: what was wrong"),
                            (KeyboardInterrupt(), 130, "warpdem shear-box: interrupted"),
                            (ValueError("x"), 1, "warpdem shear-box: internal error: ValueError: x (run with --debug "
                                                 "for the traceback)")):
        monkeypatch.setattr(cli, "run_shear_box_cmd", late(exc))
        capsys.readouterr()
        assert cli.main(["shear-box", "--out", "unused"]) == code
        lines = capsys.readouterr().err.split("\n")
        assert lines[0].startswith("\rscreening: shear box") and " 25 %" in lines[0]
        assert lines[1:] == [line, ""]


def test_internal_errors_are_one_line_unless_debug(monkeypatch, capsys) -> None:
    """An error that is not the user's (here a command that raises ZeroDivisionError) ends with one line and exit 1;
    --debug lets the traceback through."""
    import pytest

    from calibration import cli

    def broken(args):  # noqa: ANN001
        return 1 / 0

    monkeypatch.setattr(cli, "run_shear_box_cmd", broken)
    capsys.readouterr()
    assert cli.main(["shear-box", "--out", "unused"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["warpdem shear-box: internal error: ZeroDivisionError: division by zero (run with --debug for the "
                   "traceback)"]
    with pytest.raises(ZeroDivisionError):
        cli.main(["--debug", "shear-box", "--out", "unused"])


def test_ringing_writes_a_report_whose_numbers_are_the_runs(tmp_path) -> None:
    """`warpdem ringing` writes report.md, series.npz, summary.json and the figure. Reference for the report's
    numbers: the run's own summary.json and Table 2 (scenes/data); the stiffness factor it states follows from the
    linear oscillator's f ~ sqrt(k) with the same mass, (f_lab / f)^2."""
    import json

    import numpy as np

    r = _run("--quiet", "ringing", "--spring-model", "linear", "--springs", "4,32", "--device", "cpu",
             "--out", str(tmp_path / "r"))
    assert r.returncode == 0, r.stderr
    out = tmp_path / "r"
    rows = json.loads((out / "summary.json").read_text())["linear"]
    text = (out / "report.md").read_text()
    for row in rows:
        assert f"| {row['springs']} | {row['measured_freq_hz']:.4g} |" in text
        assert f"| {row['freq_hz']:.4g} | {row['damping']:.3g} |" in text
    factor = np.median([(x["measured_freq_hz"] / x["freq_hz"]) ** 2 for x in rows])
    assert f"about {factor:.2g} x the DIN 2093 stiffness" in text
    series = np.load(out / "series.npz")
    assert series["linear_displacement"].shape == (len(series["linear_time"]), 2)
    assert list(series["linear_springs"]) == [4, 32]
    assert (out / "fig06_ringing.png").stat().st_size > 0


def test_demo_writes_a_report_with_the_draughts_standard_error(tmp_path) -> None:
    """`warpdem demo` writes report.md and demo_cut.png beside its series. Reference for the numbers: the series
    itself (mean and standard deviation of the second half recomputed with numpy; the standard error as the
    standard deviation over the square root of the effective sample count the summary states)."""
    import json
    import math

    import numpy as np
    import pytest

    out = tmp_path / "d"
    r = _run("--quiet", "demo", "--particles", "300", "--deposit-time", "0.2", "--cut", "0.02", "--device", "cpu",
             "--vtk", "50", "--out", str(out))
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "summary.json").read_text())
    assert r.stdout.splitlines() == [  # two lines for a person, not the summary's JSON
        f"{s['particles']} particles, porosity {s['porosity']:.3f}; draught {s['draught_mean_n']:.2f} ± "
        f"{s['draught_sem_n']:.2f} N (standard error; std {s['draught_std_n']:.2f} N); {s['wall_time_s']:.0f} s on cpu",
        f"results in {out} (report.md, summary.json)"]
    d = np.load(out / "timeseries.npz")["draught_n"].reshape(-1)
    half = d[len(d) // 2:]
    assert s["draught_mean_n"] == pytest.approx(half.mean(), rel=1e-12)
    assert s["draught_std_n"] == pytest.approx(half.std(), rel=1e-12)
    assert 1 <= s["draught_n_eff"] <= len(half)
    assert s["draught_sem_n"] == pytest.approx(half.std() / math.sqrt(s["draught_n_eff"]), rel=1e-12)
    text = (out / "report.md").read_text()
    assert f"draught {s['draught_mean_n']:.2f} ± {s['draught_sem_n']:.2f} N (standard error" in text
    assert "![cut](demo_cut.png)" in text and (out / "demo_cut.png").stat().st_size > 0
    # ParaView frames of the cut at every 50th record: the spheres of the bed, the blade's triangles
    import meshio

    frames = sorted((out / "vtk").glob("spheres_*.vtu"))
    assert len(frames) == (len(d) - 1) // 50 + 1
    assert len(meshio.read(frames[-1]).points) == s["particles"]
    assert len(meshio.read(str(frames[-1]).replace("spheres_", "meshes_")).cells_dict["triangle"]) > 0


def test_the_soil_bin_reports_what_this_means_from_its_numbers() -> None:
    """Reference: Table 3 (the laboratory's; scenes/data) and hand arithmetic on two rigid and two passive rows:
    201.1 / 337.0 N and 195.9 / 335.8 N are 60 % and 58 % of the laboratory's rigid draughts at 0.68 and 0.52 m/s;
    both reductions lie within two SEs of zero; -0.55 % (16 springs) has not the laboratory's sign (+7.0 %), -2.0 %
    (32 springs) has (-5.5 %); 2.9 mm is more than half the laboratory's smallest 4.75 mm, so no "much less"."""
    from scenes import paper
    from scenes.reproduce import soil_bin_meaning

    rows = [{"springs": 0, "speed": 0.68, "draught_mean": 201.1}, {"springs": 0, "speed": 0.52, "draught_mean": 195.9},
            {"springs": 16, "speed": 0.68, "draught_mean": 202.2, "reduction_pct": -0.55, "reduction_sem": 9.6,
             "displacement_mean": 2.86e-3},
            {"springs": 32, "speed": 0.52, "draught_mean": 199.8, "reduction_pct": -2.0, "reduction_sem": 16.0,
             "displacement_mean": -0.718e-3}]
    text = "\n".join(soil_bin_meaning(rows, paper.table("soil_bin_measured")))
    assert "The rigid draught is 58-60 % of the laboratory's" in text
    assert "2 of 2 reductions are within two standard errors of zero" in text
    assert "1 of 2 have the laboratory's sign" in text
    assert "against the laboratory's 4.8 to 12 mm" in text and "moves much less" not in text


def test_an_interrupted_command_says_so_in_one_line(tmp_path, monkeypatch, capsys) -> None:
    """Ctrl-C (or SIGINT from a time limit) during the deposition of `warpdem soil-bin`: Python raises
    KeyboardInterrupt where the signal lands, here in a progress callback. The command prints one line that says
    the same command resumes, no traceback, and exits 130 (128 + SIGINT), as shells report an interrupted
    program; the deposition's bed is not saved half-made."""
    from calibration import cli

    def bar(label: str, done: float, total: float) -> None:
        if done / total > 0.2:
            raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_bar", bar)
    out = tmp_path / "run"
    rc = cli.main(["--quiet", "soil-bin", "--scale", "ci", "--device", "cpu", "--out", str(out)])
    err = [x for x in capsys.readouterr().err.splitlines() if x.strip()]
    assert rc == 130
    assert err == ["warpdem soil-bin: interrupted; the same command run again resumes from its last checkpoint"]
    assert not list((out / "beds").glob("*.npz"))


class _Killed(BaseException):
    """A kill: not an Exception, so the command's error handling does not catch it (as with SIGKILL)."""


def test_a_killed_soil_bin_command_resumes_to_the_same_result(tmp_path, monkeypatch) -> None:
    """Reference: the same command run uninterrupted into another folder. `warpdem soil-bin` is killed in each of
    its stages in turn (the deposition, the rigid run, the passive run) and then run again to the end; CPU runs are
    deterministic, so the table must be equal to the bit. The runs checkpoint at every chance (0.05 s simulated)
    instead of every 60 s of wall time, so that each kill finds a checkpoint; nothing else differs from the
    command. A run that had finished before a kill is read back from its checkpoint, not simulated again."""
    import functools
    import json

    import pytest

    from calibration import cli
    from scenes import soil_bin as sb

    monkeypatch.setattr(sb, "run_soil_bin", functools.partial(sb.run_soil_bin, checkpoint_every=0.0))
    args = ["--quiet", "soil-bin", "--scale", "ci", "--assembly", "A", "--springs", "0,16", "--device", "cpu"]
    whole, out = tmp_path / "whole", tmp_path / "killed"
    assert cli.main([*args, "--out", str(whole)]) == 0
    seen: list[tuple[str, float]] = []

    def bar(stage: str | None, run: str | None) -> object:
        """A progress bar that records (label, fraction) and kills past half of a stage (of the passive run: once
        its checkpoint exists)."""
        def progress(label: str, done: float, total: float) -> None:
            seen.append((label, done / total))
            passive_begun = (out / "checkpoints" / "passive" / "latest.json").exists()
            if label.startswith(str(stage)) and done / total > 0.5 and passive_begun == (run == "passive"):
                raise _Killed
        return progress

    def runs() -> list[float]:
        """The fraction at which each soil-bin run of the last call started (a run starts where the fraction drops)."""
        f = [frac for label, frac in seen if label.startswith("soil bin: ")]
        return [x for k, x in enumerate(f) if k == 0 or x < f[k - 1]]

    for stage, run in (("deposition", None), ("soil bin", "rigid"), ("soil bin", "passive")):
        seen.clear()
        monkeypatch.setattr(cli, "_bar", bar(stage, run))
        with pytest.raises(_Killed):
            cli.main([*args, "--out", str(out)])
        if stage == "deposition":
            assert not list((out / "beds").glob("*.npz"))  # killed before the bed was saved
        if run == "rigid":
            assert (out / "checkpoints" / "rigid" / "latest.json").exists()
        if run == "passive":  # the rigid run went on from its last checkpoint (0.05 s of a 0.12 s run before the
            starts = runs()   # kill at half), the passive one from its start
            assert len(starts) == 2 and starts[0] > 0.4 and starts[1] < 0.1
    seen.clear()
    monkeypatch.setattr(cli, "_bar", bar(None, None))
    assert cli.main([*args, "--out", str(out)]) == 0
    assert len(runs()) == 1 and runs()[0] > 0.4  # the passive run went on; the finished rigid run was read back
    assert json.loads((out / "summary.json").read_text()) == json.loads((whole / "summary.json").read_text())
    assert not (out / "checkpoints").exists()


def test_switches_work_after_the_command_too(tmp_path) -> None:
    """`--quiet` after the command's name silences the progress bars as it does before it (stderr empty), and
    `--debug` there keeps its meaning (a bad value still ends with one line and exit code 2)."""
    out = tmp_path / "r"
    r = _run("ringing", "--springs", "4", "--spring-model", "linear", "--device", "cpu", "--quiet", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert r.stderr.strip() == ""
    loud = _run("ringing", "--springs", "4", "--spring-model", "linear", "--device", "cpu", "--out",
                str(tmp_path / "loud"))
    assert loud.returncode == 0 and "%" in loud.stderr  # without it, a progress bar
    bad = _run("demo", "--debug", "--particles", "0")
    assert bad.returncode == 2 and bad.stderr.strip().splitlines() == [
        "warpdem demo: error: argument --particles: must be >= 1, got '0'"]


def test_vtk_with_the_full_workflow_is_refused(capsys) -> None:
    """The full workflow writes no ParaView frames: asking for them is an error (exit 2, one line), not ignored."""
    from calibration.cli import main

    assert main(["reproduce", "--workflow", "full", "--vtk", "5", "--out", "unused"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["warpdem reproduce: error: --vtk 5: ParaView frames are written by the quick workflow (and by "
                   "soil-bin, speed-sweep, shear-box, demo), not by --workflow full"]


def test_cuda_on_a_machine_without_it_is_one_line(tmp_path) -> None:
    """Without an NVIDIA driver (as on CI), --device cuda ends with one line naming the option, before Warp's own
    driver messages (a subprocess: those are written by Warp's native code on stderr)."""
    import pytest
    import warp as wp

    if wp.is_cuda_available():
        pytest.skip("this machine has CUDA")
    r = _run("demo", "--device", "cuda", "--out", str(tmp_path / "d"))
    assert r.returncode == 2
    assert [x for x in r.stderr.splitlines() if x.strip()] == [
        "warpdem demo: error: --device cuda: CUDA is not available on this machine (no NVIDIA GPU or driver); use "
        "--device cpu"]
    assert not (tmp_path / "d").exists()


def test_a_killed_reproduce_keeps_its_ringing_and_bed_and_resumes_to_the_same_result(tmp_path, monkeypatch,
                                                                                    capsys) -> None:
    """Reference: the same command run uninterrupted into another folder. `warpdem reproduce --scale ci` is
    interrupted (Ctrl-C: KeyboardInterrupt from a progress callback) past half of its soil-bin run, after the
    ringing and the bed's deposition: one line, exit code 130. The same command again must neither ring nor deposit
    (both refused here), goes on with the soil-bin run from its checkpoint, and gives the uninterrupted run's
    tables (to the bit on the CPU). Two of the three spring models (the twin rings for 12 s) and checkpoints at
    every chance (0.05 s simulated, not every 60 s of wall time); nothing else differs from the command."""
    import functools
    import json

    from calibration import cli
    from scenes import ringing
    from scenes import soil_bin as sb

    monkeypatch.setattr(ringing, "SPRING_MODELS", ("paper", "linear"))
    monkeypatch.setattr(sb, "run_soil_bin", functools.partial(sb.run_soil_bin, checkpoint_every=0.0))
    seen: list[tuple[str, float]] = []
    out = tmp_path / "killed"

    def bar(kill: bool) -> object:
        def progress(label: str, done: float, total: float) -> None:
            seen.append((label, done / total))
            if kill and label == "soil bin: rigid tool" and done / total > 0.5 and \
                    (out / "checkpoints" / "rigid" / "latest.json").exists():
                raise KeyboardInterrupt
        return progress

    args = ["--quiet", "reproduce", "--scale", "ci", "--springs", "0", "--device", "cpu"]
    monkeypatch.setattr(cli, "_bar", bar(False))
    assert cli.main([*args, "--out", str(tmp_path / "whole")]) == 0
    assert any(label.startswith("soil bin: deposition (fill)") for label, _ in seen)  # the deposition has a bar
    seen.clear()
    capsys.readouterr()
    monkeypatch.setattr(cli, "_bar", bar(True))
    assert cli.main([*args, "--out", str(out)]) == 130
    assert [x for x in capsys.readouterr().err.splitlines() if x.strip()] == [
        "warpdem reproduce: interrupted; the same command run again resumes from its last checkpoint"]
    assert sorted(p.name for p in out.glob("ringing_*.npz")) == ["ringing_linear.npz", "ringing_paper.npz"]
    assert len(list((out / "beds").glob("*.npz"))) == 1 and not (out / "summary.json").exists()

    def refuse(*_a: object, **_k: object) -> None:
        raise AssertionError("ran again")

    monkeypatch.setattr(ringing, "run_ringing", refuse)
    monkeypatch.setattr(sb, "deposit", refuse)
    seen.clear()
    monkeypatch.setattr(cli, "_bar", bar(False))
    assert cli.main([*args, "--out", str(out)]) == 0
    soil = [f for label, f in seen if label == "soil bin: rigid tool"]
    assert {label for label, _ in seen} == {"soil bin: rigid tool"} and soil[0] > 0.4  # went on from its checkpoint
    whole = json.loads((tmp_path / "whole" / "summary.json").read_text())
    resumed = json.loads((out / "summary.json").read_text())
    for key in ("ringing", "soil_bin"):
        assert resumed[key] == whole[key], key
    for key in ("particles", "spheres", "porosity", "coordination"):
        assert resumed["bed"][key] == whole["bed"][key], key
    assert not (out / "checkpoints").exists()


def test_a_killed_full_workflow_keeps_its_ringing_calibrations_and_bed(tmp_path, monkeypatch, capsys) -> None:
    """`warpdem reproduce --workflow full --scale ci` (a small GA) interrupted (Ctrl-C) in the draught calibration's
    first batch, after the ringing calibrations and the calibration bed's deposition: exit 130, one line; the same
    command again neither calibrates the ringing rig again nor deposits (both refused here; it is interrupted again
    in the draught calibration). That a resumed workflow gives the uninterrupted result is
    tests/test_workflow.py's (stopped in every kind of piece)."""
    from calibration import cli
    from calibration import paper_workflow as pw
    from scenes import soil_bin as sb

    seen: list[str] = []

    def bar(label: str, done: float, total: float) -> None:
        seen.append(label)
        if label.startswith("soil bin:"):  # a soil-bin batch: the draught calibration's
            raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_bar", bar)
    args = ["reproduce", "--workflow", "full", "--scale", "ci", "--assembly", "A", "--springs", "16",
            "--generations", "1", "--population", "2", "--parents", "1", "--device", "cpu", "--out",
            str(tmp_path / "wf")]
    capsys.readouterr()
    assert cli.main(args) == 130
    assert capsys.readouterr().err.splitlines()[-1] == ("warpdem reproduce: interrupted; the same command run again "
                                                        "resumes from its last checkpoint")
    assert any(x.startswith("ringing calibration") for x in seen) and any(x.startswith("deposition") for x in seen)
    assert sorted(p.name for p in (tmp_path / "wf").glob("ringing_*.json")) == ["ringing_linear.json",
                                                                              "ringing_paper.json"]

    def refuse(*_a: object, **_k: object) -> None:
        raise AssertionError("ran again")

    monkeypatch.setattr(pw, "run_ringing", refuse)
    monkeypatch.setattr(sb, "deposit", refuse)
    seen.clear()
    assert cli.main(args) == 130
    assert capsys.readouterr().err.splitlines()[-1].startswith("warpdem reproduce: interrupted")
    assert seen and all(x.startswith("soil bin:") for x in seen), seen
