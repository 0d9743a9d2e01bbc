"""The command line: parse, call one library function, print.

No physics and no SQL here. Every library error (:mod:`gaz_cli.errors`) and
every usage error becomes one line on stderr and a non-zero exit.
"""

from __future__ import annotations

import errno
import gc
import io
import json
import math
import os
import signal
import stat
import sys
import warnings

import click

from gaz_cli import __version__, interrupts
from gaz_cli.model.scene import OPTIONS
from gaz_cli.errors import GazError, GazWarning

TABLE_FORMATS = ("table", "csv", "json")
"""What --format prints: a table, CSV or JSON (data on stdout)."""


# --- shared options -----------------------------------------------------------
def _not_empty(ctx, param, value):
    """--db '' would quietly mean the default file (simulate) or a database named ''."""
    if value is not None and not value.strip():
        raise click.BadParameter(f"{value!r} names no database; give a file path or a URL, or leave "
                                 "--db out for gaz.db", param_hint="--db")
    return value


def db_option(default: str | None = "gaz.db", note: str = ""):
    return click.option("--db", default=default, show_default=True, metavar="PATH_OR_URL", callback=_not_empty,
                        help="SQLite file path, or any SQLAlchemy URL (e.g. postgresql://user@host/gaz)." + note)


def seed_option(f=None, *, default="a fresh seed, recorded in the database and the summary"):
    def decorate(f):
        return click.option("--seed", type=click.IntRange(0, 2 ** 63 - 1), default=None,
                            help=f"Random seed; same seed, same rows. Default: {default}.")(f)
    return decorate(f) if f is not None else decorate


_CLICK_TYPES = {"real": float, "int": int, "str": str}


def scene_option(name: str):
    """The click option of scene option ``name``, read from its row of the table
    (:data:`gaz_cli.model.scene.OPTIONS`): flag, type (a choice, a range), help. Its default is
    None (a flag not given leaves a scene file's value), a list for ``--plane``, False for a switch."""
    row = OPTIONS[name]
    if row.kind == "bool":
        return click.option(row.flag, name, is_flag=True, help=row.help)
    if row.kind == "planes":
        return click.option(row.flag, name, multiple=True, metavar="X,Y[,Z]:NX,NY[,NZ][:E]", help=row.help)
    kind = _CLICK_TYPES[row.kind]
    if row.rule and row.rule[0] == "one of":
        kind = click.Choice(list(row.rule[1]))
    elif row.rule and row.rule[0] == "whole at least zero":
        kind = click.IntRange(0)
    return click.option(row.flag, name, type=kind, default=None, help=row.help)


def format_option(f):
    return click.option("--format", "fmt", type=click.Choice(TABLE_FORMATS), default="table",
                        show_default=True, help="Output format.")(f)


def positive(name):
    """A click callback refusing values <= 0 or not finite."""
    def check(ctx, param, value):
        if value is None:
            return value
        if math.isnan(value):
            raise click.UsageError(f"{name} {value} is not a number; give a number > 0", ctx)
        if not math.isfinite(value) or value <= 0:
            raise click.UsageError(f"{name} {value:g} must be a finite number > 0", ctx)
        return value
    return check


def image_file(ctx, param, value):
    """A click callback accepting a file name whose extension matplotlib can save (png, svg, pdf...)."""
    if value is None:
        return value
    from matplotlib.backend_bases import FigureCanvasBase

    kinds = sorted(FigureCanvasBase.get_supported_filetypes())
    suffix = os.path.splitext(value)[1].lower().lstrip(".")
    if suffix not in kinds:
        raise click.BadParameter(f"{value!r} is not an image format matplotlib writes; end the name "
                                 f"with one of .{', .'.join(kinds)}", param_hint=param.opts[0])
    return value


# --- output helpers -----------------------------------------------------------
def emit_frames(frames: dict, fmt: str) -> None:
    """Print named DataFrames (or dicts of scalars) as table, csv or json.

    csv: one table alone is plain csv, which pandas.read_csv reads as is; several each
    follow a ``# name`` line."""
    import pandas as pd

    if fmt == "json":
        out = {}
        for name, frame in frames.items():
            out[name] = (frame.astype(object).where(frame.notna(), None).to_dict(orient="records")
                         if isinstance(frame, pd.DataFrame) else frame)
        click.echo(json.dumps(_finite(out), indent=2, default=_jsonable))
        return
    first = True
    for name, frame in frames.items():
        if not isinstance(frame, pd.DataFrame):
            frame = pd.DataFrame([frame]) if isinstance(frame, dict) else pd.DataFrame(frame)
        if fmt == "csv":
            if len(frames) > 1:
                click.echo(f"# {name}")
            click.echo(frame.to_csv(index=False), nl=False)
        else:
            if not first:
                click.echo()
            click.echo(f"== {name} ==")
            with pd.option_context("display.width", 200, "display.max_columns", 50,
                                   "display.float_format", "{:.6g}".format):
                click.echo(frame.to_string(index=False) if len(frame) else "(no rows)")
        first = False


def _finite(value):
    """``value`` with every NaN and infinity as None: JSON has no such numbers (Python's
    NaN and Infinity tokens are refused by jq, JavaScript and strict parsers)."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):  # a numpy scalar
        try:
            value = value.item()
        except (ValueError, TypeError):
            return value
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def _jsonable(obj):
    try:
        return obj.item()
    except AttributeError:
        return str(obj)


# --- the group ----------------------------------------------------------------
class _PipeClosed(Exception):
    """stdout's reader went away (``gaz place ... | head``): carries the BrokenPipeError past
    click, whose own handler of it exits 1 without a word, even outside standalone mode."""


class _Stopped(Exception):
    """A SIGINT or SIGTERM (a KeyboardInterrupt, ``interrupt``) carried past click, which would
    write an empty line on stderr first (for the terminal's ^C, also after a SIGTERM or into a
    log file) and turn it into Abort."""

    def __init__(self, interrupt: KeyboardInterrupt):
        super().__init__()
        self.interrupt = interrupt


class _Group(click.Group):
    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except BrokenPipeError:
            raise _PipeClosed() from None
        except KeyboardInterrupt as exc:
            raise _Stopped(exc) from None


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(__version__, prog_name="gaz")
def cli():
    """gaz: hard rods, disks and spheres bouncing in a box; every wall bounce
    lands in a SQL database (tables SIMULATION, PARTICULE, REBOND).

    \b
    A first session:
      gaz place --dim 2 --n 5 --radius 0.5 --length 10 --seed 1
      gaz simulate --dim 2 --n 200 --length 1e-6 --duration 1e-8 --seed 1 --db gaz.db
      gaz analyse --db gaz.db
      sqlite3 gaz.db "SELECT SI_NUM, COUNT(*) FROM REBOND GROUP BY SI_NUM"

    SI units everywhere: metres, seconds, kelvin, kilograms (grams in PARTICULE.PA_M).
    """


# --- place --------------------------------------------------------------------
@cli.command()
@click.option("--dim", type=int, required=True, help="Dimension of space: 1, 2 or 3.")
@click.option("--n", "n", type=int, required=True, help="Number of particles.")
@click.option("--radius", type=float, required=True, callback=positive("--radius"), help="Particle radius, m.")
@click.option("--length", type=float, required=True, callback=positive("--length"), help="Box side L, m.")
@click.option("--method", type=click.Choice(["auto", "rejection", "rapid", "lattice", "grow"]),
              default="auto", show_default=True,
              help="rapid: the exam's Q10 (1D, exactly uniform); rejection: random sequential "
                   "addition on a cell grid; lattice/grow: dense starts. auto: rapid in 1D, else "
                   "rejection when dilute, a dense method when not.")
@seed_option(default="a fresh seed each time, printed nowhere (give --seed to place the same particles again)")
@click.option("--repeat", type=click.IntRange(1), default=None,
              help="Q12 study: repeat the placement K times and histogram the centres along x.")
@click.option("--bins", type=click.IntRange(1), default=50, show_default=True, help="Histogram bins (with --repeat).")
@click.option("--histogram", type=click.Path(dir_okay=False, writable=True), default=None,
              callback=image_file,
              help="With --repeat: also plot the histogram to this image file (.png, .svg, .pdf...).")
def place(dim, n, radius, length, method, seed, repeat, bins, histogram):
    """Place N non-overlapping particles at random in [0, L]^D; print the centres as CSV.

    \b
    Examples:
      gaz place --dim 1 --n 5 --radius 0.5 --length 10 --seed 1
      gaz place --dim 1 --n 2 --radius 1 --length 10 --repeat 20000 --bins 40 --histogram q12.png
    """
    from gaz_cli.analysis import placements as analysis
    from gaz_cli.scenes.validate import check_placement

    check_placement(dim, n, radius, length)
    if repeat is None:
        if histogram:
            raise click.UsageError("--histogram needs --repeat K")
        ctx = click.get_current_context()
        if ctx.get_parameter_source("bins") is not click.core.ParameterSource.DEFAULT:
            raise click.UsageError("--bins needs --repeat K (the histogram of K placements); "
                                   "drop --bins, or add --repeat")
        positions = analysis.place_once(dim, n, radius, length, method, seed)
        axes = "xyz"[:dim]
        click.echo(",".join(axes))
        for row in positions:
            click.echo(",".join(repr(float(c)) for c in row))
        return
    frame = analysis.placement_histogram(dim, n, radius, length, method, seed, repeat, bins,
                                         plot=histogram)
    click.echo(frame.to_csv(index=False), nl=False)
    if histogram:
        click.echo(f"histogram written to {histogram}", err=True)


# --- simulate -----------------------------------------------------------------
@cli.command()
@click.argument("scene_file", metavar="[SCENE.toml]", required=False, type=click.Path(dir_okay=False))
@scene_option("dim")
@click.option("--n", "n", type=int, default=None, help="Number of particles (or give counts in --species).")
@scene_option("length")
@click.option("--packing", type=float, default=None, callback=positive("--packing"),
              help="Packing fraction (the particles' share of the box) instead of --length: the box "
                   "side follows from it, as a scene file's packing key.")
@scene_option("duration")
@click.option("--species", default=None, metavar="NAME|NAME:COUNT,...",
              help="Built-in gas (He Ne Ar Kr Xe H2 N2 O2 CO2 CH4; default Ar) or a mixture Ar:500,He:500.")
@click.option("--radius", type=float, default=None, help="Custom particle radius, m (with --mass).")
@click.option("--mass", type=float, default=None, help="Custom particle mass, kg (with --radius).")
@scene_option("temperature")
@seed_option
@db_option(default=None, note=" Default: the scene file's [output] db, else gaz.db.")
@click.option("--no-db", is_flag=True, help="Write no database (summary only).")
@scene_option("engine")
@scene_option("boundary")
@scene_option("gravity")
@scene_option("restitution")
@scene_option("tc")
@scene_option("record")
@scene_option("placement")
@scene_option("dt")
@scene_option("drag")
@scene_option("pair_gravity")
@scene_option("softening")
@scene_option("wall_restitution")
@scene_option("planes")
@scene_option("print_every")
@click.option("--preset", default=None,
              help="A packaged scene file: comet (seed 003), marbles (seed 002). Flags given with it "
                   "override it, or are refused when its initial state depends on them.")
@click.option("--write-scene", type=click.Path(dir_okay=False), default=None,
              help="Write the run's scene file (seed and tc as used) to FILE.toml.")
@click.option("--trajectory", type=click.Path(dir_okay=False), default=None,
              help="Write snapshots to FILE.h5md (HDF5, H5MD 1.1: mda.Universe('FILE.h5md'); .h5 too), "
                   "FILE.gsd (GSD: OVITO, HOOMD, freud; needs gaz[gsd]) or FILE.pvd (VTK for ParaView).")
@click.option("--every", type=float, default=None, help="Simulated seconds between trajectory snapshots.")
@click.option("--save-state", type=click.Path(dir_okay=False), default=None,
              help="Write the final state as CSV: species,x[,y[,z]],vx[,vy[,vz]].")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as one JSON object.")
@click.option("--quiet", is_flag=True,
              help="No progress bar and no compile notice on stderr (shown only on a terminal, "
                   "for runs longer than about a second).")
@click.option("--threads", type=click.IntRange(1), default=None,
              help="Threads of the step engine, one patch of the box each (default: NUMBA_NUM_THREADS, "
                   "else every core). The rows do not depend on it.")
@scene_option("force")
def simulate(scene_file, as_json, db, no_db, save_state, trajectory, every, write_scene, quiet, threads, **options):
    """Place particles, draw Maxwell-Boltzmann velocities, simulate T seconds, record every wall bounce.

    The scene comes from the options, or from SCENE.toml (a scene file, docs/reference/scene-file.md) or
    --preset NAME with the options given overriding it.

    \b
    Examples:
      gaz simulate --dim 3 --n 1000 --length 1e-7 --duration 1e-9 --seed 1
      gaz simulate --dim 2 --species Ar:500,He:500 --length 2e-7 --duration 1e-9 --json
      gaz simulate --dim 3 --n 4000 --boundary periodic --length 2e-8 --duration 1e-10 --record none
      gaz simulate examples/exam.toml --seed 7 --write-scene run.toml
    """
    from gaz_cli import api, progress
    from gaz_cli.scenes import options as opts
    from gaz_cli.run import runner
    from gaz_cli.scenes import files as scenefile

    if no_db and db is not None:
        from gaz_cli.results.store import shown

        raise click.UsageError(f"--no-db writes no database; drop --db {shown(db)!r}, or drop --no-db")
    if threads is not None:  # read by Numba when it starts (set_num_threads if it already has)
        if "numba" in sys.modules:  # (not the variable then: a compile after would see it change and fail)
            sys.modules["numba"].set_num_threads(min(threads, sys.modules["numba"].config.NUMBA_NUM_THREADS))
        else:
            os.environ["NUMBA_NUM_THREADS"] = str(threads)
    scene, outputs = opts.from_options(scene_file=scene_file, **options)
    if threads is not None:
        from gaz_cli.scenes.validate import validate

        engine = validate(scene).engine
        if engine != "step":
            raise click.UsageError(f"--threads {threads} applies to --engine step only (the {engine} engine "
                                   "runs on one thread and would ignore it); set --engine step, or drop --threads")
    db = None if no_db else scenefile.database(db, outputs)
    trajectory = trajectory if trajectory is not None else outputs.get("trajectory")
    every = every if every is not None else outputs.get("every")
    save_state = save_state if save_state is not None else outputs.get("save_state")
    diagnostics = _print_diagnostic if scene.print_every else None  # --print-every: step engine only
    summary = api.simulate(scene, db=db, save_state=save_state, trajectory=trajectory, every=every,
                           diagnostics=diagnostics, write_scene=write_scene, progress=progress.wanted(quiet),
                           inputs={"the scene file": scene_file} if scene_file else None).summary
    if as_json:
        click.echo(json.dumps(summary, default=_jsonable))
    else:
        click.echo(runner.describe(summary))
    overlapping = summary.get("overlapping_collisions") or 0
    if overlapping:
        click.echo(f"gaz simulate: warning: {overlapping} collisions found their pair already "
                   "overlapping: the start overlapped, or a collision was missed (please report "
                   "it with the command line if the start did not overlap)", err=True)


@cli.command("scene")
@click.argument("si_num", type=int)
@db_option()
def scene_command(si_num, db):
    """Print the scene file of stored simulation SI_NUM, to run it again (same seed, same rows).

    \b
    Example:
      gaz scene 1 --db gaz.db > again.toml
      gaz simulate again.toml --db again.db
    """
    from gaz_cli.results.queries import stored_scene_file

    click.echo(stored_scene_file(db, si_num), nl=False)


def _print_diagnostic(values: dict) -> None:
    click.echo("  ".join(f"{k}={v:.6g}" if isinstance(v, float) else f"{k}={v}"
                         for k, v in values.items()), err=True)


# --- analyse ------------------------------------------------------------------
@cli.command()
@db_option()
@click.option("--sim", type=int, default=None, help="Only this simulation (SI_NUM).")
@format_option
@click.option("--plot", type=click.Path(file_okay=False), default=None, help="Write PNG figures into DIR.")
@click.option("--table", "table", default=None, metavar="NAME",
              help="Print only this table (csv: one table, readable by pandas.read_csv). NAME: "
                   "q34, q35, q36, overview, simulation, pressure, collisions, contact, speed, gravity, cooling, "
                   "figures.")
@click.option("--vs", "vs", default=None, metavar="KEY",
              help="Across runs: the pressure, Z = PV/(NkT) and collision rate against KEY (packing, "
                   "temperature, n, length, density), averaged over seeds, beside theory (with a sweep). "
                   "One series per scene apart from KEY, named in column SCENE: against packing, length "
                   "or density one per N; against n one per packing (a sweep at packings held) or per box "
                   "side (at a box held), whichever gives fewer series.")
def analyse(db, sim, fmt, plot, table, vs):
    """Run the packaged SQL queries (Q34, Q35, Q36, pressure) and compare with theory.

    Without --sim: one line per simulation, measured pressure beside the ideal
    gas and the best theory. With --sim N: per wall pressure with its error
    and deviation in standard errors; collision rate against Enskog; Q35's
    mean wall-hit speed against the flux-weighted mean; under gravity floor
    minus ceiling force against N m g; with restitution < 1 the cooling
    against Haff's law. Errors: reblocking of 512 time bins plus the spread of
    the initial draw that too few collisions have not relaxed (ESTIMATOR,
    N_EFF). Pressures are forces per wall measure: Pa (3D), N/m (2D), N (1D),
    column P_UNIT. A value that does not exist is empty (csv), null (json) or
    NaN, the reason in NOTE. --plot DIR writes DIR/sim{N}_*.png.

    \b
    Examples:
      gaz analyse --db gaz.db
      gaz analyse --db gaz.db --sim 1 --format json
      gaz analyse --db gaz.db --sim 1 --format csv --table q36 > walls.csv
      gaz analyse --db iso.db --vs packing --plot figs      # after gaz sweep
    """
    with interrupts.saying(interrupts.STOPPED_ANALYSIS):    # a second of imports
        from gaz_cli import api
        from gaz_cli.analysis import report as analysis

    if vs is not None:
        if sim is not None or table is not None:
            raise click.UsageError("--vs tabulates across runs; drop --sim and --table")
        emit_frames({f"against {vs}": api.versus(db, vs, plot=plot)}, fmt)
        return
    if table is not None and table not in analysis.TABLES:
        raise click.BadParameter(f"{table!r} is not one of {', '.join(analysis.TABLES)}", param_hint="--table")
    frames = api.analyse(db, sim=sim, plot=plot)
    if table is not None:
        title = analysis.TABLES[table]
        frame = api.pick_table(frames, table, sim, plot)
        if fmt == "csv":
            import pandas as pd

            click.echo((frame if isinstance(frame, pd.DataFrame) else pd.DataFrame([frame])).to_csv(index=False),
                       nl=False)
            return
        frames = {title: frame}
    elif fmt == "csv" and len(frames) > 1:
        click.echo("gaz analyse: several tables, each after a '# name' line; pick one with --table NAME "
                   "for pandas.read_csv", err=True)
    emit_frames(frames, fmt)


# --- sweep --------------------------------------------------------------------
@cli.command()
@click.argument("scene_file", type=click.Path(exists=True, dir_okay=False))
@click.option("--vary", multiple=True, required=True, metavar="KEY=V1,V2,...|KEY=START:STOP:COUNT",
              help="A key of the scene file and its values (COUNT values from START to STOP, both "
                   "included); 'count' varies the number of particles. Repeat for a grid.")
@click.option("--seeds", type=click.IntRange(1), default=1, show_default=True,
              help="Runs per point, seeds from the file's seed on (1 if it has none).")
@click.option("--workers", type=click.IntRange(1), default=None,
              help="Worker processes of the local Dask cluster, at most the core count.  "
                   "[default: the core count]")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Run on an existing Dask cluster (e.g. tcp://host:8786) instead of a local one.")
@db_option(default=None, note=" Default: the scene file's [output] db, else gaz.db.")
@click.option("--quiet", is_flag=True, help="No progress bar.")
@format_option
def sweep(scene_file, vary, seeds, workers, scheduler, db, quiet, fmt):
    """Run a scene file over a grid of values and seeds, on Dask; every run stored in --db.

    The runs go to a Dask cluster (a local one with --workers processes, or
    --scheduler's); workers send their results back and this process alone
    writes them, so a SQLite file works. A run already stored (same scene,
    same seed) is skipped: the same command finishes an interrupted sweep. A
    point the scene's checks refuse (a packing beyond the densest...) stops the
    sweep before any run; a run failing on its worker is reported and the
    others go on (exit 1 if any failed). A progress bar on a terminal shows
    runs done, running, failed and the time left.

    \b
    Examples:
      gaz sweep examples/isotherm_2d.toml --vary packing=0.1:0.6:6 --seeds 3 --db iso.db
      gaz analyse --db iso.db --vs packing --plot figs
      gaz sweep examples/exam.toml --vary temperature=100,300,1000 --vary count=100,400 --db t.db
    """
    import pandas as pd

    from gaz_cli import api

    report = api.sweep(scene_file, list(vary), seeds=seeds, db=db, workers=workers, scheduler=scheduler,
                       progress=False if quiet else None)
    rows = [{**dict(p.values), "SEED": p.seed, "STATUS": status,
             "SI_NUM": si_num if si_num is not None else pd.NA, "NOTE": why}
            for p, status, si_num, why in report.rows]
    emit_frames({"runs": pd.DataFrame(rows)}, fmt)
    counts = ", ".join(f"{report.count(s)} {s}" for s in ("stored", "skipped", "failed"))
    from gaz_cli.results.store import shown

    click.echo(f"gaz sweep: {len(report.rows)} runs: {counts} (--db {shown(report.db)})", err=True)
    if report.helpers:
        click.echo(f"gaz: error: {report.helpers}", err=True)
    if report.failed or report.helpers:
        raise SystemExit(1)


# --- query --------------------------------------------------------------------
@cli.command()
@click.argument("name", required=False)
@db_option()
@click.option("--param", "params", multiple=True, metavar="KEY=VALUE",
              help="A parameter of the query, e.g. --param si_num=1. Repeatable.")
@format_option
@click.option("--list", "list_only", is_flag=True, help="Name the packaged queries, with what each returns.")
def query(name, db, params, fmt, list_only):
    """Run a packaged SQL query (Q34, Q35, Q36, pressure, ...) by NAME on the database.

    The queries are plain SQL files shipped with gaz (valid in SQLite and
    PostgreSQL); --list names them with their parameters. csv output is one
    table that pandas.read_csv reads as is.

    \b
    Examples:
      gaz query --list
      gaz query q34 --db gaz.db
      gaz query q36 --param si_num=1 --db gaz.db --format csv
    """
    from gaz_cli.results import queries

    if list_only and (name is not None or params):
        given = " and ".join(w for w, g in ((f"NAME {name!r}", name is not None), ("--param", params)) if g)
        raise click.UsageError(f"--list names the packaged queries and runs none; drop {given}, or drop --list")
    if list_only:
        import pandas as pd

        catalogue = queries.catalogue()
        if fmt == "table":
            width = max(len(q.name) for q in catalogue)
            for q in catalogue:
                params = " ".join(f"--param {p}=..." for p in q.parameters)
                click.echo(f"{q.name:<{width}}  {q.description}" + (f" [{params}]" if params else ""))
            return
        frame = pd.DataFrame([{"NAME": q.name, "PARAMETERS": " ".join(q.parameters),
                               "FILE": q.file, "DESCRIPTION": q.description} for q in catalogue])
        name = "queries"
    elif name is None:
        raise click.UsageError("give a query NAME, or --list to see them")
    else:
        found, frame = queries.run(db, name, params)
        name = found.name
    if fmt == "csv":
        click.echo(frame.to_csv(index=False), nl=False)
    else:
        emit_frames({name: frame}, fmt)


# --- animate ------------------------------------------------------------------
@cli.command()
@click.argument("trajectory", type=click.Path(exists=True, dir_okay=False))
@click.option("--output", "-o", type=click.Path(dir_okay=False), default=None,
              help="GIF file to write, FILE.gif (default: the trajectory's name with .gif).")
@click.option("--fps", type=click.IntRange(1, 100), default=20, show_default=True, help="Frames per second.")
def animate(trajectory, output, fps):
    """Render a trajectory (FILE.h5md, FILE.gsd or FILE.pvd from --trajectory) to an animated GIF.

    One frame per snapshot, each particle a disk of its true radius coloured by species: 1D rods
    on a line, 2D disks in the box, 3D spheres as a side view (x across, z up, the gravity axis;
    y is not shown). In a periodic box a disk across an edge is drawn on both sides. A
    trajectory of more than 400 snapshots is subsampled evenly to 400 frames (the title gives
    each frame's time).

    \b
    Example:
      gaz simulate --dim 2 --n 50 --length 1e-7 --duration 1e-9 --trajectory run.h5md --every 1e-11
      gaz animate run.h5md -o run.gif
    """
    from gaz_cli.outputs import animate as anim

    from gaz_cli.scenes import paths

    output = os.path.splitext(trajectory)[0] + ".gif" if output is None else output
    anim.check_output(output)
    paths.check(inputs={"the trajectory": trajectory}, outputs={"-o": output})
    anim.render_gif(trajectory, output, fps=fps)
    click.echo(f"animation written to {output}", err=True)


# --- entry point --------------------------------------------------------------
_default_showwarning = warnings.showwarning


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """The library's warnings (GazWarning) as one line on stderr; others as Python shows them."""
    if issubclass(category, GazWarning):
        click.echo(f"gaz: warning: {message}", err=True)
    else:
        _default_showwarning(message, category, filename, lineno, file, line)


def _usage_command_path(exc: click.UsageError, argv, prog: str) -> str:
    """The command a usage error belongs to ("gaz simulate"), for its message and the --help it
    points at. Click leaves ``exc.ctx`` unset for an option's missing or unwanted value
    ("Option '--db' requires an argument"): the command is then the first word of ``argv``
    that names one, else ``prog``."""
    if exc.ctx is not None:
        return exc.ctx.command_path
    args = sys.argv[1:] if argv is None else list(argv)
    name = next((a for a in args if not a.startswith("-")), None)
    return f"{prog} {name}" if name in cli.commands else prog


class _StdoutError(Exception):
    """Standard output could not be written (a full device, a closed descriptor)."""

    def __init__(self, err: OSError):
        super().__init__(err.strerror or str(err))


class _Stdout:
    """sys.stdout, whose write failures (other than a reader gone: BrokenPipeError, which
    keeps its meaning) become :class:`_StdoutError`; None: a closed descriptor."""

    def __init__(self, stream):
        self._stream = stream

    def _call(self, name, *args):
        if self._stream is None:
            raise _StdoutError(OSError(errno.EBADF, os.strerror(errno.EBADF)))
        try:
            return getattr(self._stream, name)(*args)
        except BrokenPipeError:
            raise
        except OSError as err:
            raise _StdoutError(err) from None

    def write(self, text):
        return self._call("write", text)

    def flush(self):
        return self._call("flush")

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _stdout_problem() -> str | None:
    """Why standard output cannot take a command's output, known before it runs: a closed
    descriptor, or /dev/full; None if none is known (a failure later is caught as it comes)."""
    if sys.stdout is None:
        return "it is closed"
    try:
        st = os.fstat(sys.stdout.fileno())
    except (OSError, ValueError, AttributeError, io.UnsupportedOperation):
        return None  # no real descriptor (a test's capture): its writes will tell
    if stat.S_ISCHR(st.st_mode) and st.st_rdev == os.makedev(1, 7):
        return "it is /dev/full, which takes nothing"
    return None


LIBRARY_LOGGERS = ("psycopg", "sqlalchemy")
"""Libraries that log their secondary failures: psycopg's "error ignored terminating Copy" and
"query cancellation failed" (a server gone in the middle of a COPY), SQLAlchemy's pool's
"Exception during reset". Python's last-resort handler printed them on stderr, before gaz's
own line for the error that ended the command (the one to tell); with GAZ_DEBUG=1 they are
printed as before."""


def _quiet_library_logs() -> None:
    """Give :data:`LIBRARY_LOGGERS` a handler that drops their records, unless GAZ_DEBUG is set
    or the program configured a handler of its own (then it is theirs to show)."""
    import logging

    if os.environ.get("GAZ_DEBUG"):
        return
    for name in LIBRARY_LOGGERS:
        logger = logging.getLogger(name)
        if not logger.handlers:
            logger.addHandler(logging.NullHandler())


def main(argv=None) -> None:
    """Console entry point: one line on stderr and a non-zero exit for every error. Started by
    ``mpiexec -n P`` (P > 1): rank 0 runs the command, the others serve its step-engine runs
    (gaz_cli/engines/step/mpi.py)."""
    if {"PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MPI_LOCALNRANKS", "GAZ_MPI"} & os.environ.keys():  # mpi.LAUNCH_SIZE
        from gaz_cli.engines.step import mpi

        if mpi.launched():
            mpi.main(_main, argv)  # exits
    _main(argv)


def _main(argv=None) -> None:
    """:func:`main` in one process."""
    prog = "gaz"
    _quiet_library_logs()
    args = sys.argv[1:] if argv is None else list(argv)
    command = next((a for a in args if not a.startswith("-")), None)
    problem = _stdout_problem()
    if problem and command not in (None, "animate") and not {"-h", "--help", "--version"} & set(args):
        # refused before anything runs: a run would be stored and its summary lost
        click.echo(f"{prog}: error: cannot write to standard output: {problem}; redirect it to a "
                   "file or /dev/null", err=True)
        sys.exit(1)
    real_stdout = sys.stdout
    sys.stdout = _Stdout(real_stdout)
    try:
        # SIGTERM as SIGINT from here on: its default action ends the process without a word,
        # and a command's imports (NumPy, pandas, SQLAlchemy...) take about a second
        with interrupts.from_the_start(), warnings.catch_warnings():  # both restored on the way out
            warnings.simplefilter("always", GazWarning)
            warnings.showwarning = _show_warning
            cli.main(args=argv, prog_name=prog, standalone_mode=False)
            sys.stdout.flush()  # a failure to write it is this command's, not the exit's
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except (_Stopped, click.Abort, KeyboardInterrupt) as exc:
        # the run's Interrupted, carried past click (_Stopped), or turned by it into Abort
        # (outside a command: its cause), or raised before click ran
        cause = (exc.interrupt if isinstance(exc, _Stopped) else
                 exc if isinstance(exc, KeyboardInterrupt) else exc.__cause__)
        signum = getattr(cause, "signum", signal.SIGINT)
        if signum == signal.SIGINT and sys.stderr.isatty():
            click.echo(err=True)  # after the ^C the terminal wrote
        left = getattr(cause, "left", "nothing was written for the interrupted run")
        click.echo(f"{prog}: interrupted by {signal.Signals(signum).name}; {left}", err=True)
        sys.exit(128 + signum)
    except click.exceptions.NoArgsIsHelpError as exc:
        click.echo(exc.ctx.get_help() if exc.ctx is not None else exc.format_message())
        sys.exit(0)
    except click.UsageError as exc:
        cmd = _usage_command_path(exc, argv, prog)
        click.echo(f"{cmd}: error: {exc.format_message()} (see '{cmd} --help')", err=True)
        sys.exit(2)
    except click.ClickException as exc:
        click.echo(f"{prog}: error: {exc.format_message()}", err=True)
        sys.exit(exc.exit_code)
    except GazError as exc:
        from gaz_cli.scenes.options import message

        click.echo(f"{prog}: error: {message(exc)}", err=True)
        sys.exit(1)
    except MemoryError as exc:
        # beyond what the door estimated (gaz_cli.scenes.validate.check_memory_limit): the run
        # unwound, its transaction rolled back and its outputs' temporary files removed
        from gaz_cli.scenes.validate import memory_limit

        limit = memory_limit()
        under = f" under {limit[2]} ({limit[0] / 1e9:.3g} GB)" if limit else ""
        detail = " ".join(str(exc).split())
        click.echo(f"{prog}: error: out of memory{under}" + (f" ({detail})" if detail else "") +
                   "; the run that ran out was not stored; lower --n (or --duration, --repeat, --record), "
                   "or run it where more memory is free", err=True)
        sys.exit(1)
    except _StdoutError as exc:
        click.echo(f"{prog}: error: cannot write to standard output: {exc}", err=True)
        sys.exit(1)
    except (BrokenPipeError, _PipeClosed):
        # the reader has what it wanted: exit 0, and point stdout at /dev/null so that the
        # interpreter's last flush of it does not fail again ("Exception ignored", exit 120)
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError, AttributeError):  # no real descriptor (a test's capture)
            pass
        sys.exit(0)
    except Exception as exc:  # noqa: BLE001 - last line of defence: one line, no traceback
        from gaz_cli.interrupts import signal_of

        signum = signal_of(exc)
        if signum is not None:  # Ctrl-C raised while a Numba kernel's result was boxed
            click.echo(f"{prog}: interrupted by {signal.Signals(signum).name}; nothing was "
                       "written for the interrupted run", err=True)
            sys.exit(128 + signum)
        if os.environ.get("GAZ_DEBUG"):
            raise
        click.echo(f"{prog}: internal error: {type(exc).__name__}: {exc} "
                   "(set GAZ_DEBUG=1 for a traceback; please report it)", err=True)
        sys.exit(3)
    finally:
        sys.stdout = real_stdout
        # the objects left (Numba's compiler state, mostly) live until exit: a last garbage
        # collection over them slowed every run's exit (measurements:
        # docs/explanation/engine_measurements.md#cli)
        gc.freeze()
    sys.exit(0)
