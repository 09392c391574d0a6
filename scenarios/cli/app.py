"""The `twincell` command line. Imports are lazy so that `twincell --help` stays fast."""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING, Annotated, Any

import typer

if TYPE_CHECKING:
    from scenarios.cli.file_registration import MatchOptions

app = typer.Typer(
    name="twincell",
    help="Correlate a virtual robot cell with the real one by 3D surface matching.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _version(value: bool) -> None:
    if value:
        from importlib.metadata import version

        typer.echo(f"twincell {version('twincell')}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option("--version", callback=_version, is_eager=True, help="Print the version."),
    ] = False,
) -> None:
    """twincell: surface matching for robot cells."""


@app.command("check")
def check(
    json_file: Annotated[
        str | None, typer.Option("--json", help="Also write the figures to this JSON file.")
    ] = None,
) -> None:
    """Self-check of the cell: physics, FK/IK, tool changes, table, laser. Exit 0 if all hold."""
    from rich.console import Console

    from cell.sim.selfcheck import render, run_check, write_json

    report = run_check()
    Console().print(render(report))
    if json_file is not None:
        write_json(report, json_file)
    if not report.passed:
        raise typer.Exit(1)


def _volume_model(
    path: str, iso: float, units: str, out: str | None, voxel_mm: str | None, max_gap_mm: float
) -> None:
    """`twincell model` on a CT volume: its bone surface, checked, exported; an irregular
    series resampled (and said so)."""
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    from models.ct import bone_model, read_volume
    from models.ct.regular import voxel_size
    from models.mesh_export import write_mesh

    volume = read_volume(path, voxel_size(voxel_mm), max_gap_mm)
    if volume.resampled is not None:
        typer.echo(f"{path}: {volume.resampled}")
    if volume.skipped is not None:
        typer.echo(f"twincell: warning: {volume.skipped}", err=True)
    bone = bone_model(volume, iso_hu=iso)
    c = bone.check
    table = Table(title=f"bone model: {path}", show_header=False)
    table.add_column("item", style="bold")
    table.add_column("value")
    rows = (
        ("modality / frame", f"{volume.modality or 'not stated'} / {volume.native_frame}"),
        ("voxels (i, j, k)", " x ".join(str(n) for n in volume.data.shape)),
        ("grid", "the file's own" if volume.resampled is None else str(volume.resampled)),
        ("files skipped", "none" if volume.skipped is None else str(volume.skipped)),
        ("voxel size (i, j, k) \\[mm]", ", ".join(f"{v:.3f}" for v in c.voxel_mm)),
        ("threshold \\[HU]", f"{c.iso_hu:g}"),
        ("faces", str(c.faces)),
        ("watertight", "yes" if c.watertight else "no"),
        ("volume \\[cm^3]", "-" if c.volume_m3 is None else f"{c.volume_m3 * 1e6:.2f}"),
        ("from the isosurface, mean / max \\[mm]",
         f"{c.deviation_mean_m * 1e3:.3f} / {c.deviation_max_m * 1e3:.3f}"),
    )  # fmt: skip
    for label, value in rows:
        table.add_row(label, Text(value))  # Text: a file's name is not markup
    Console().print(table)
    if out is not None:
        written = write_mesh(bone.mesh, out, units)
        typer.echo(f"wrote {written} ({len(bone.mesh.faces)} triangles, {units})")


@app.command("model")
def model(
    name: Annotated[
        str,
        typer.Argument(
            help="A built-in model (skull, bracket, housing, lid, ellipsoid), a mesh file "
            "(.stl, .obj, .ply), or a CT volume (a DICOM series folder, .nii/.nii.gz, "
            ".nrrd/.nhdr) whose bone surface is segmented and meshed."
        ),
    ],
    real: Annotated[
        bool, typer.Option("--real", help="The real entity: the model plus its model error.")
    ] = False,
    seed: Annotated[
        int, typer.Option("--seed", min=0, help="Seed of the skull's shape and the model error.")
    ] = 0,
    units: Annotated[
        str, typer.Option("--units", help="Units of a mesh file and of --out: mm or m.")
    ] = "mm",
    out: Annotated[
        str | None, typer.Option("--out", help="Write the mesh to this .stl/.obj/.ply file.")
    ] = None,
    iso: Annotated[
        float, typer.Option("--iso", help="Bone threshold of a CT volume [HU].")
    ] = 300.0,
    voxel_mm: Annotated[
        str | None,
        typer.Option(
            "--voxel-mm",
            help="Resample a CT volume onto a regular grid of this voxel size [mm] (one size "
            "or AxBxC). Default: a series with uneven slice steps or a gantry tilt is "
            "resampled at its pixel spacing and smallest step, a regular one kept.",
        ),
    ] = None,
    max_gap_mm: Annotated[
        float,
        typer.Option(
            "--max-gap-mm",
            help="The widest step between a CT series' slices that is interpolated over "
            "[mm]; wider is refused as missing slices.",
        ),
    ] = 10.0,
) -> None:
    """Check a model (vertices, faces, watertight, size, volume, convex pieces); export it."""
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    from models.check import check_model
    from models.ct.readers import is_volume
    from models.mesh_export import write_mesh
    from models.registry import load_model

    if is_volume(name):
        _volume_model(name, iso, units, out, voxel_mm, max_gap_mm)
        return

    loaded, warnings = load_model(name, real=real, seed=seed, units=units)
    report = check_model(loaded, warnings)
    table = Table(title=f"model check: {report.name}", show_header=False)
    table.add_column("item", style="bold")
    table.add_column("value")
    for label, value in report.rows():
        table.add_row(Text(label), Text(value))  # Text: "[mm]" is not markup
    Console().print(table)
    for warning in report.warnings:
        typer.echo(f"twincell: warning: {warning}", err=True)
    if out is not None:
        written = write_mesh(loaded.mesh, out, units)
        typer.echo(f"wrote {written} ({len(loaded.mesh.faces)} triangles, {units})")


#: The register command's arguments and longer options (typer reads them from the types).
RegisterData = Annotated[
    list[str],
    typer.Argument(
        help="Data points: .xyz, .txt, .pts, .csv, .npy, .ply, .pcd, .e57, .las or .laz. "
        "Several files: each is registered to the one model, one JSON line per file."
    ),
]
RegisterModel = Annotated[
    str,
    typer.Argument(
        help="Model: a mesh (.stl, .obj, .ply, .off), a point file, or a prepared model "
        "(.twm, from `twincell prepare`)."
    ),
]
RegisterMode = Annotated[
    str,
    typer.Option(
        "--mode",
        help="auto (any coverage, the default), global (data cover the whole model), "
        "local (part of it) or refine (ICP from --init, no search).",
    ),
]
RegisterTargets = Annotated[
    str | None,
    typer.Option(
        "--targets",
        help="Targets in the model frame (JSON {name: \\[x, y, z]} or a point file, in "
        "the model's units): the verdict is then per target.",
    ),
]
RegisterInit = Annotated[
    str | None,
    typer.Option(
        "--init",
        help="A guess of T_model_data (a 4 x 4 in .txt, .csv, .npy, or .json such as "
        "this command's --json output; translation in --units): the start of refine, "
        "one more start in the other modes.",
    ),
]
RegisterJson = Annotated[
    str | None,
    typer.Option(
        "--json",
        help="Write the result to this JSON file (several data files: their JSON Lines, "
        "one per file, instead of standard output).",
    ),
]


@app.command("register")
def register(
    data: RegisterData,
    model: RegisterModel,
    mode: RegisterMode = "auto",
    units: Annotated[
        str, typer.Option("--units", help="Units of the data (and of the model): m or mm.")
    ] = "m",
    model_units: Annotated[
        str | None,
        typer.Option(
            "--model-units",
            help="Units of the model if not --units (a .twm keeps those it was prepared in).",
        ),
    ] = None,
    targets: RegisterTargets = None,
    noise: Annotated[
        float | None,
        typer.Option("--noise", min=0.0, help="The sensor's range noise (sigma), in --units."),
    ] = None,
    init: RegisterInit = None,
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of the search.")] = 0,
    json_file: RegisterJson = None,
    batch: Annotated[
        bool,
        typer.Option("--batch", help="JSON Lines output even for one data file."),
    ] = False,
) -> None:
    """Register data points to a model surface and print the transform and its quality.

    With several data files, every file is registered to the one model in this process and
    each gives one JSON line (its result's fields, or its error): on standard output, or in
    the --json file with a summary line per file on standard output. A file that fails does
    not stop the others; the exit status is then 2.
    """
    from registration.io import load_pose, unit_scale
    from scenarios.cli.file_registration import MatchOptions, load_named_targets, model_units_of

    named = None
    if targets is not None:
        named = load_named_targets(targets, model_units_of(model, units, model_units))
    noise_m = None if noise is None or noise == 0 else noise * unit_scale(units)
    T_init = None if init is None else load_pose(init, units)
    options = MatchOptions(mode, units, seed, named, noise_m, T_init)
    if len(data) == 1 and not batch:
        _register_one(data[0], model, options, model_units, json_file)
    else:
        _register_many(data, model, options, model_units, json_file)


def _register_one(
    data: str, model: str, options: MatchOptions, model_units: str | None, json_file: str | None
) -> None:
    """`twincell register DATA MODEL`: the result as a table, and as JSON with --json."""
    from scenarios.cli.file_registration import register_files, render_result, write_result_json

    result = register_files(data, model, options, model_units)
    render_result(result, options.targets)
    if json_file is not None:
        write_result_json(result, json_file, options.targets)


def _register_many(
    data: list[str],
    model: str,
    options: MatchOptions,
    model_units: str | None,
    json_file: str | None,
) -> None:
    """`twincell register DATA... MODEL`: one JSON line per data file, the model read once."""
    from scenarios.cli.file_registration import load_model_file, register_batch, write_batch

    options.check()
    shape = load_model_file(model, options.units, model_units)
    outcomes = register_batch(data, shape, model, options)
    if json_file is None:
        count = write_batch(outcomes, model, options.targets, sys.stdout)
    else:
        with open(json_file, "w") as lines:
            count = write_batch(outcomes, model, options.targets, lines, typer.echo)
    if count.failed or count.internal:
        typer.echo(
            f"twincell: error: {count.failed + count.internal} of {len(data)} data files "
            f"failed (their lines say why)",
            err=True,
        )
        raise typer.Exit(1 if count.internal else 2)


@app.command("prepare")
def prepare(
    model: Annotated[
        str,
        typer.Argument(help="Model: a mesh (.stl, .obj, .ply, .off) or a point file."),
    ],
    out: Annotated[
        str | None,
        typer.Option(
            "--out", help="The prepared model file (.twm); default: MODEL with the suffix .twm."
        ),
    ] = None,
    units: Annotated[str, typer.Option("--units", help="Units of the model: m or mm.")] = "m",
) -> None:
    """Prepare a model once for many `twincell register` calls: its surface sample, voxel
    lookup, anchors and symmetries, written to a .twm file that `register` reads back."""
    import time

    from scenarios.cli.file_registration import model_summary, prepare_file

    t0 = time.perf_counter()
    written, shape = prepare_file(model, out, units)
    typer.echo(
        f"wrote {written} ({model_summary(shape)}; from {model} in {units}; "
        f"{written.stat().st_size / 1e6:.1f} MB; {time.perf_counter() - t0:.2f} s)"
    )


# The options of `twincell run` that take a paragraph to explain.
_FaultOption = Annotated[
    list[str] | None,
    typer.Option(
        "--fault",
        help="NAME[=AMOUNT[:OPTION]]: inject a fault into the real cell (see --list-faults), "
        "the amount in SI units; repeatable.",
    ),
]
_ModelOption = Annotated[
    str | None,
    typer.Option(
        "--model",
        help="Replace the job's object by this mesh (.stl, .obj, .ply) or CT volume (a "
        "DICOM series folder, .nii/.nii.gz, .nrrd/.nhdr: its bone).",
    ),
]
_TargetsOption = Annotated[
    str | None,
    typer.Option(
        "--targets",
        help="The object's targets: a targets YAML, or for a CT volume the plan made on "
        "it (plan.json: entry and target points in the volume's frame, mm).",
    ),
]
_ProgramOption = Annotated[
    str | None,
    typer.Option(
        "--program",
        help="Your RAPID module (.mod) written for the virtual cell, or a folder of the "
        "task's modules: its work object's robtargets become the operations, and the run "
        "writes it back corrected.",
    ),
]
_CellOption = Annotated[
    str | None,
    typer.Option(
        "--cell",
        help="The cell to run the job in: a shipped cell (ur5: the UR5 of "
        "example-robot-data, the rack placed for its reach) or a cell YAML (robot file, "
        "flange, mount, rack).",
    ),
]
_SetOption = Annotated[
    list[str] | None,
    typer.Option(
        "--set",
        help="KEY=VALUE: set any configuration value by its dotted key (e.g. "
        "cell.noise.laser_sigma_m=2e-4, calibration.enabled=false); repeatable.",
    ),
]


@app.command("run")
def run(
    name: Annotated[
        str | None,
        typer.Argument(help="A shipped job (paper, skull, assembly) or a CONFIG.yaml file."),
    ] = None,
    seed: Annotated[
        int | None, typer.Option("--seed", min=0, help="Seed of all random draws.")
    ] = None,
    out: Annotated[str, typer.Option("--out", help="Folder that holds the run folders.")] = "runs",
    fault: _FaultOption = None,
    list_faults: Annotated[
        bool, typer.Option("--list-faults", help="List the faults and exit.")
    ] = False,
    model: _ModelOption = None,
    units: Annotated[str, typer.Option("--units", help="Units of --model: mm or m.")] = "mm",
    targets: _TargetsOption = None,
    program: _ProgramOption = None,
    cell: _CellOption = None,
    assign: _SetOption = None,
    spawn: Annotated[bool, typer.Option("--spawn", help="Show the run in a rerun viewer.")] = False,
    no_rrd: Annotated[bool, typer.Option("--no-rrd", help="Do not write run.rrd.")] = False,
    no_cache: Annotated[
        bool,
        typer.Option(
            "--no-cache",
            help="Build the skull phantom and plan the scan anew instead of reading them from "
            "the user's cache folder (TWINCELL_NO_CACHE=1 does the same).",
        ),
    ] = False,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress lines.")] = False,
) -> None:
    """Run a job headless and write a run folder (results, table, figures, recording)."""
    from rich.console import Console

    from scenarios.jobs.runner import RunOptions, run_job

    if list_faults:
        _print_faults()
        return
    if name is None:
        raise typer.BadParameter("give a job (skull, assembly, paper) or a CONFIG.yaml")
    if no_cache:
        os.environ["TWINCELL_NO_CACHE"] = "1"  # models.cache; campaign workers inherit it

    def progress(message: str) -> None:
        if not quiet:
            typer.echo(f"  {message}", err=True)

    overrides = run_overrides(
        model=model, units=units, targets=targets, program=program, assign=assign, fault=fault
    )
    folder, result = run_job(
        name,
        seed=seed,
        out=out,
        progress=progress,
        overrides=overrides,
        options=RunOptions(rrd=not no_rrd, spawn=spawn),
        cell=cell,
    )
    from scenarios.results.run import RunResult

    if not isinstance(result, RunResult):  # the paper's experiments
        typer.echo(result.table)
        typer.echo(f"run folder: {folder}")
        return
    from scenarios.results.result_table import results_table

    Console().print(results_table(result))
    typer.echo(f"run folder: {folder}")
    if result.status == "at_risk":
        typer.echo(f"twincell: the program ran, but {result.reason}", err=True)
        raise typer.Exit(6)
    if result.status in ("refused", "aborted"):
        typer.echo(f"twincell: {result.status} in {result.stage}: {result.reason}", err=True)
        raise typer.Exit(3 if result.status == "refused" else 4)


def run_overrides(
    *,
    model: str | None,
    units: str,
    targets: str | None,
    program: str | None,
    assign: list[str] | None,
    fault: list[str] | None,
) -> dict[str, object]:
    """The dotted configuration keys `twincell run`'s options set: the object's model and
    units, its targets file, the program, each `--set KEY=VALUE` and each `--fault`."""
    from scenarios.configuration.config_files import fault_assignment, parse_assignment

    overrides: dict[str, object] = {}
    if model is not None:
        overrides |= {"cell.object.model": model, "cell.object.units": units}
    if targets is not None:
        overrides["cell.object.targets_file"] = targets
    if program is not None:
        overrides["operations.program"] = program
    overrides |= dict(parse_assignment(text) for text in assign or [])
    overrides |= dict(fault_assignment(text) for text in fault or [])
    return overrides


def _print_faults() -> None:
    """The fault kinds of the real cell, as a table."""
    from rich.console import Console
    from rich.table import Table

    from cell.sim.faults import FAULT_KINDS

    table = Table(title="faults of the real cell (--fault NAME[=AMOUNT[:OPTION]])")
    for column in ("fault", "what happens", "amount", "default", "stage", "option"):
        table.add_column(column)
    for k in FAULT_KINDS.values():
        table.add_row(
            k.name,
            k.what,
            f"{k.amount} \\[{k.unit}]",
            f"{k.default:g}",
            k.stage or "start",
            " | ".join(k.options) or "-",
        )
    Console(width=160).print(table)


@app.command("execute")
def execute(
    run_folder: Annotated[
        str, typer.Argument(help="A run folder written by `twincell run` (config.yaml inside).")
    ],
    program: Annotated[
        str | None,
        typer.Option(
            "--program",
            help="The RAPID module (.mod), or a folder of a task's modules, to run instead "
            "of the folder's program.",
        ),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress lines.")] = False,
) -> None:
    """Run a run's RAPID program on its real cell as an IRC5 without absolute accuracy (the
    arm's nominal kinematics) and measure the touched targets against the truth; writes
    execution.json into the run folder."""
    from pathlib import Path

    from rich.console import Console

    from scenarios.jobs.execute_run_folder import EXECUTION_FILE, execute_run, execution_table

    def progress(message: str) -> None:
        if not quiet:
            typer.echo(f"  {message}", err=True)

    result = execute_run(run_folder, program, progress)
    Console().print(execution_table(result))
    typer.echo(f"wrote {Path(run_folder) / EXECUTION_FILE}")


@app.command("serve")
def serve(
    name: Annotated[
        str,
        typer.Argument(help="A shipped job (skull, assembly), a CONFIG.yaml, or a run folder."),
    ],
    rws: Annotated[
        str, typer.Option("--rws", help="HOST:PORT the Robot Web Services answer on.")
    ] = "127.0.0.1:8080",
    host: Annotated[
        str | None,
        typer.Option("--host", help="Bind to this host instead of --rws's (e.g. 0.0.0.0)."),
    ] = None,
    egm_port: Annotated[
        int | None,
        typer.Option("--egm-port", min=1, max=65535, help="The EGM client's UDP port."),
    ] = None,
    egm_host: Annotated[
        str, typer.Option("--egm-host", help="The EGM client's host.")
    ] = "127.0.0.1",
    seed: Annotated[
        int | None, typer.Option("--seed", min=0, help="The real cell's seed (default: the job's).")
    ] = None,
    speed: Annotated[
        float,
        typer.Option("--speed", min=0.01, help="The cell's time runs N times the wall clock's."),
    ] = 1.0,
    opmode: Annotated[
        str,
        typer.Option(
            "--opmode",
            help="The operation mode: AUTO, or MANR (manual: clients read, but neither start "
            "programs nor write).",
        ),
    ] = "AUTO",
    user: Annotated[
        list[str] | None,
        typer.Option(
            "--user",
            help="NAME:PASSWORD of a user (repeatable; default the "
            "controller's Default User:robotics).",
        ),
    ] = None,
    out: Annotated[
        str, typer.Option("--out", help="Folder that holds the serve folders.")
    ] = "runs",
    spawn: Annotated[
        bool, typer.Option("--spawn", help="Show the cell live in a rerun viewer.")
    ] = False,
    rrd: Annotated[
        bool, typer.Option("--rrd", help="Write serve.rrd into the serve folder.")
    ] = False,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress lines.")] = False,
) -> None:
    """Serve a job's real cell as an ABB IRC5 controller: Robot Web Services (HTTP, digest
    authentication) and EGM (UDP), until Ctrl-C. Programs a client loads and starts run as
    `twincell execute` runs them; each one run to its end is measured against the truth in
    the serve folder (executions/)."""
    from scenarios.jobs.serve import serve_job
    from scenarios.twin.server import ServeOptions, parse_address, parse_users

    def progress(message: str) -> None:
        if not quiet:
            typer.echo(f"  {message}", err=True)

    rws_host, rws_port = parse_address(rws)
    options = ServeOptions(host or rws_host, rws_port, egm_port, egm_host, parse_users(user or []))
    serving = serve_job(name, options, seed=seed, speed=speed, out=out, spawn=spawn, rrd=rrd,
                        progress=progress, opmode=opmode.upper())  # fmt: skip
    typer.echo(f"serving {serving.url} (Ctrl-C to stop); serve folder: {serving.folder}")
    _serve_until_stopped(serving)


def _serve_until_stopped(serving: Any) -> None:
    """Serve until SIGINT (Ctrl-C) or SIGTERM, then close the servers and say what ran."""
    import contextlib
    import signal
    import threading

    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda _s, _f: done.set())
    try:
        with contextlib.suppress(KeyboardInterrupt):
            while not done.wait(0.5):
                continue
    finally:
        serving.close()
    n = len(serving.executions)
    typer.echo(f"stopped; {n} program{'' if n == 1 else 's'} measured in {serving.folder}")


@app.command("rapid")
def rapid(
    paths: Annotated[
        list[str],
        typer.Argument(
            help="A RAPID module file, several files of one task, or a folder (a backup's "
            "RAPID/TASKn with PROGMOD and SYSMOD, or any folder of .mod/.modx/.sys/.prg)."
        ),
    ],
) -> None:
    """Read a RAPID task as a controller would and print what was read: modules, routines,
    tools, work objects, robtargets, moves per routine, the motion instructions the executor
    refuses, and warnings (procedures called but defined nowhere). Exit 2 with one line
    naming the file and the line when the task cannot be read."""
    from scenarios.rapid.summary import task_lines
    from scenarios.rapid.task import read_task

    for line in task_lines(read_task(paths)):
        typer.echo(line)


@app.command("campaign")
def campaign(
    name: Annotated[
        str,
        typer.Argument(
            help="register stage: a model (skull, ellipsoid, ...) or a job CONFIG.yaml "
            "(with its register_trial section); full stage: a shipped job (skull, assembly) "
            "or a CONFIG.yaml."
        ),
    ],
    trials: Annotated[int, typer.Option("--trials", min=1, help="Seeded trials per point.")] = 10,
    vary: Annotated[
        list[str] | None,
        typer.Option("--vary", help="KEY=V1,V2,... (dotted config key); repeat to cross."),
    ] = None,
    workers: Annotated[int, typer.Option("--workers", min=1, help="Worker processes.")] = 1,
    backend: Annotated[
        str, typer.Option("--backend", help="local (processes here) or dask (a cluster).")
    ] = "local",
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler",
            help="Dask scheduler address (tcp://HOST:8786); none: "
            "a local Dask cluster of --workers processes.",
        ),
    ] = None,
    stage: Annotated[
        str, typer.Option("--stage", help="register (matching alone) or full (the scenario).")
    ] = "register",
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of the first trial.")] = 0,
    cell: Annotated[
        str | None,
        typer.Option(
            "--cell",
            help="full stage: the cell to run each trial in, as `twincell run --cell` "
            "takes it (ur5, or a cell YAML).",
        ),
    ] = None,
    out: Annotated[
        str | None,
        typer.Option(
            "--out",
            help="Campaign folder (default runs/campaigns/NAME-STAGE-KEYS); "
            "rerunning into it resumes.",
        ),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", help="No progress bar.")] = False,
) -> None:
    """Run many seeded trials (a sweep), store one row per trial, report reliability.

    A trial stopped by a user error (a configuration it cannot use) is a failed row; one
    stopped by a program error (a bug) is a crashed row, its traceback in the campaign
    folder's trials/ID/traceback.txt, and the command exits 5 once the table and the report
    are written.
    """
    from scenarios.campaign import default_out, plan_campaign, run_campaign

    spec = plan_campaign(name, stage=stage, trials=trials, vary=vary or [], seed=seed, cell=cell)
    folder = out if out is not None else default_out(spec)
    outcome = run_campaign(
        spec, folder, backend=backend, workers=workers, scheduler=scheduler, progress=not quiet
    )
    typer.echo((outcome.folder / "report.md").read_text())
    typer.echo(
        f"campaign folder: {outcome.folder} ({outcome.ran} trials run now, "
        f"{outcome.skipped} finished before)"
    )
    if outcome.crashed:
        typer.echo(
            f"twincell: internal error: {len(outcome.crashed)} of {len(outcome.rows)} trials "
            f"crashed (a program error, not a refusal); tracebacks in "
            f"{outcome.folder / 'trials'}/<trial_id>/traceback.txt",
            err=True,
        )
        raise typer.Exit(5)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script: user errors become one line and exit status 2.

    A numerical warning (numpy's RuntimeWarning) or one of the project's own is a bug: it is
    raised as an error, reported in one line (exit status 1), never printed as a warning.
    A run stopped by SIGINT or SIGTERM is one line too (where it stopped, its run folder),
    exit status 130 or 143 as a shell reports a process killed by the signal.
    """
    import warnings

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            for package in ("registration", "scenarios", "cell", "models"):
                warnings.filterwarnings("error", module=package)
            status = app(args=argv, standalone_mode=False)
        if isinstance(status, int):  # click returns typer.Exit's code without standalone mode
            return status
    except typer.Exit as exc:
        return int(exc.exit_code or 0)
    except typer.Abort:
        typer.echo("twincell: aborted", err=True)
        return 130
    except typer.TyperException as exc:  # usage errors: typer prints them the click way
        click_error: Any = exc  # typer's exceptions are click's, which show themselves
        click_error.show()
        return int(getattr(exc, "exit_code", 2))
    except Warning as exc:
        typer.echo(f"twincell: internal error (an unexpected warning): {exc}", err=True)
        return 1
    except Exception as exc:
        from scenarios.scenario_errors import user_errors

        if isinstance(exc, user_errors()):
            typer.echo(f"twincell: error: {exc}", err=True)
            return 2
        raise
    except BaseException as exc:
        if "scenarios.jobs.interrupt" not in sys.modules:  # no run: nothing to interrupt
            raise
        from scenarios.jobs.interrupt import RunInterrupted

        if not isinstance(exc, RunInterrupted):
            raise
        typer.echo(f"twincell: {exc}", err=True)
        return exc.exit_status
    return 0


if __name__ == "__main__":
    sys.exit(main())
