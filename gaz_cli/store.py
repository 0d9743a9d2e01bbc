"""The results database, through SQLAlchemy Core.

The exam's three tables (figure 4) exactly, never changed:

- SIMULATION(SI_NUM pk, SI_DEB, SI_DUR s, SI_DIM, SI_N, SI_L m)
- PARTICULE(PA_NUM pk, PA_NOM, PA_M g, PA_R m)
- REBOND(SI_NUM fk, RE_NUM, PA_NUM fk, RE_T s, RE_DIR, RE_VIT m/s, RE_VP m/s),
  primary key (SI_NUM, RE_NUM)

and extra tables keyed by SI_NUM for everything else:

- SCENE: seed, temperature, engine, boundary, forces, restitution, placement...
- COMPOSITION(SI_NUM, PA_NUM, CO_N): the mixture.
- RESULTAT: events, collisions, kinetic energy at start and end, virial,
  wall time, events per second.
- CHOC(SI_NUM, CH_NUM, CH_T, CH_I, CH_J, CH_J_IMP): particle-particle
  collisions, written only with ``--record all``.

Table and column names are created in lower case, so that the SQL files,
written in upper case as in the exam, run unchanged on SQLite and on
PostgreSQL (which folds unquoted names to lower case).

A simulation is written in one transaction: rows are streamed in chunks into
it and committed together at the end; a run that fails or is interrupted
leaves nothing behind.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd
import sqlalchemy as sa
from sqlalchemy import exc as sa_exc

from gaz_cli import __version__
from gaz_cli.errors import StoreError
from gaz_cli.recording import Recorder, RunStats
from gaz_cli.scene import Scene
from gaz_cli.species import BUILTIN, Species

metadata = sa.MetaData()

simulation = sa.Table(
    "simulation", metadata,
    sa.Column("si_num", sa.Integer, primary_key=True, autoincrement=True),
    sa.Column("si_deb", sa.DateTime, nullable=False),
    sa.Column("si_dur", sa.Float, nullable=False),
    sa.Column("si_dim", sa.Integer, nullable=False),
    sa.Column("si_n", sa.Integer, nullable=False),
    sa.Column("si_l", sa.Float, nullable=False),
)

particule = sa.Table(
    "particule", metadata,
    sa.Column("pa_num", sa.Integer, primary_key=True, autoincrement=True),
    sa.Column("pa_nom", sa.String(64), nullable=False),
    sa.Column("pa_m", sa.Float, nullable=False),
    sa.Column("pa_r", sa.Float, nullable=False),
)

rebond = sa.Table(
    "rebond", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("re_num", sa.Integer, primary_key=True, autoincrement=False),
    sa.Column("pa_num", sa.Integer, sa.ForeignKey("particule.pa_num"), nullable=False),
    sa.Column("re_t", sa.Float, nullable=False),
    sa.Column("re_dir", sa.Integer, nullable=False),
    sa.Column("re_vit", sa.Float, nullable=False),
    sa.Column("re_vp", sa.Float, nullable=False),
    sqlite_with_rowid=False,  # the primary key is the storage order: one B-tree, not two
)

scene_table = sa.Table(
    "scene", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("sc_seed", sa.BigInteger, nullable=False),
    sa.Column("sc_temperature", sa.Float, nullable=False),
    sa.Column("sc_engine", sa.String(32), nullable=False),
    sa.Column("sc_boundary", sa.String(16), nullable=False),
    sa.Column("sc_gravity", sa.Float, nullable=False),
    sa.Column("sc_restitution", sa.Float, nullable=False),
    sa.Column("sc_tc", sa.Float, nullable=False),
    sa.Column("sc_wall_restitution", sa.Float, nullable=False),
    sa.Column("sc_dt", sa.Float),
    sa.Column("sc_drag", sa.Float, nullable=False),
    sa.Column("sc_pair_gravity", sa.Float, nullable=False),
    sa.Column("sc_placement", sa.String(16), nullable=False),
    sa.Column("sc_record", sa.String(16), nullable=False),
    sa.Column("sc_version", sa.String(16), nullable=False),
)

composition = sa.Table(
    "composition", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("pa_num", sa.Integer, sa.ForeignKey("particule.pa_num"), primary_key=True),
    sa.Column("co_n", sa.Integer, nullable=False),
)

resultat = sa.Table(
    "resultat", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("rs_events", sa.BigInteger, nullable=False),
    sa.Column("rs_bounces", sa.BigInteger, nullable=False),
    sa.Column("rs_collisions", sa.BigInteger, nullable=False),
    sa.Column("rs_ke_start", sa.Float, nullable=False),
    sa.Column("rs_ke_end", sa.Float, nullable=False),
    sa.Column("rs_virial", sa.Float, nullable=False),
    sa.Column("rs_wall_time", sa.Float, nullable=False),
)

choc = sa.Table(
    "choc", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("ch_num", sa.Integer, primary_key=True, autoincrement=False),
    sa.Column("ch_t", sa.Float, nullable=False),
    sa.Column("ch_i", sa.Integer, nullable=False),
    sa.Column("ch_j", sa.Integer, nullable=False),
    sa.Column("ch_imp", sa.Float, nullable=False),
)

EXAM_TABLES = ("simulation", "particule", "rebond")


def url_for(db: str) -> str:
    """A SQLAlchemy URL from ``--db``: a URL is kept, anything else is a SQLite file path."""
    if "://" in db:
        return db
    return f"sqlite:///{Path(db).expanduser()}"


def query_text(name: str) -> str:
    """The text of the packaged SQL file ``name`` (with or without '.sql')."""
    if not name.endswith(".sql"):
        name += ".sql"
    return resources.files("gaz_cli.sql").joinpath(name).read_text(encoding="utf-8")


def query_names() -> list[str]:
    """Names of the packaged SQL files, sorted."""
    return sorted(p.name for p in resources.files("gaz_cli.sql").iterdir()
                  if p.name.endswith(".sql"))


class Store:
    """A results database. ``create=False`` refuses to make a new one (for ``analyse``)."""

    def __init__(self, db: str, create: bool = True):
        self.db = db
        url = url_for(db)
        if url.startswith("sqlite:///") and not create:
            path = Path(url[len("sqlite:///"):])
            if not path.is_file():
                raise StoreError(f"database {db!r} does not exist; run 'gaz simulate --db {db}' first")
        try:
            self.engine = sa.create_engine(url)
            if url.startswith("sqlite"):
                sa.event.listen(self.engine, "connect", _sqlite_pragmas)
            if create:
                metadata.create_all(self.engine)
                self._seed_particules()
            else:
                names = set(sa.inspect(self.engine).get_table_names())
                missing = [t for t in EXAM_TABLES if t not in names]
                if missing:
                    raise StoreError(f"{db!r} is not a gaz database (no table {missing[0].upper()}); "
                                     "point --db at a file written by 'gaz simulate'")
        except sa_exc.ArgumentError as err:
            raise StoreError(f"--db {db!r} is not a valid path or SQLAlchemy URL ({err})") from None
        except sa_exc.NoSuchModuleError as err:
            raise StoreError(f"--db {db!r}: database driver not installed ({err})") from None
        except sa_exc.DatabaseError as err:
            msg = str(err.orig).splitlines()[0] if err.orig is not None else str(err)
            raise StoreError(f"cannot use database {db!r}: {msg}") from None

    # --- species --------------------------------------------------------------
    def _seed_particules(self) -> None:
        with self.engine.begin() as conn:
            if conn.execute(sa.select(sa.func.count()).select_from(particule)).scalar():
                return
            conn.execute(particule.insert(), [
                {"pa_num": k + 1, "pa_nom": s.name, "pa_m": s.mass_g, "pa_r": s.radius}
                for k, s in enumerate(BUILTIN.values())])

    def _pa_num(self, conn, sp: Species) -> int:
        """PA_NUM of a species; custom species get a row of their own on first use."""
        rows = conn.execute(sa.select(particule.c.pa_num, particule.c.pa_m, particule.c.pa_r)
                            .where(particule.c.pa_nom == sp.name)).all()
        for num, m_g, r in rows:
            if np.isclose(m_g, sp.mass_g, rtol=1e-12, atol=0) and np.isclose(r, sp.radius, rtol=1e-12, atol=0):
                return int(num)
        res = conn.execute(particule.insert().values(pa_nom=sp.name, pa_m=sp.mass_g, pa_r=sp.radius))
        return int(res.inserted_primary_key[0])

    # --- writing ------------------------------------------------------------
    @contextlib.contextmanager
    def simulation(self, scene: Scene, started: _dt.datetime | None = None):
        """Open one simulation's transaction; yields a :class:`SimulationWriter`.

        Everything is committed when the block ends normally and rolled back
        if it raises (KeyboardInterrupt included).
        """
        started = started or _dt.datetime.now().replace(microsecond=0)
        with self.engine.connect() as conn:
            trans = conn.begin()
            try:
                writer = SimulationWriter(self, conn, scene, started)
                yield writer
                if not writer.finished:
                    raise RuntimeError("SimulationWriter.finish() was not called")
                trans.commit()
            except BaseException:
                trans.rollback()
                raise

    # --- reading ------------------------------------------------------------
    def read_sql(self, sql: str, **params) -> pd.DataFrame:
        """Run one SQL statement (text with :named parameters) into a DataFrame."""
        with self.engine.connect() as conn:
            frame = pd.read_sql_query(sa.text(sql), conn, params=params or None)
        frame.columns = [c.upper() for c in frame.columns]
        return frame

    def query(self, name: str, **params) -> pd.DataFrame:
        """Run a packaged SQL file by name."""
        return self.read_sql(query_text(name), **params)

    def simulation_numbers(self) -> list[int]:
        with self.engine.connect() as conn:
            return [int(r[0]) for r in conn.execute(sa.select(simulation.c.si_num).order_by(simulation.c.si_num))]

    def table(self, table: sa.Table, si_num: int | None = None) -> pd.DataFrame:
        """A whole table (optionally one simulation's rows) as a DataFrame, upper-case columns."""
        stmt = sa.select(table)
        if si_num is not None and "si_num" in table.c:
            stmt = stmt.where(table.c.si_num == si_num)
        with self.engine.connect() as conn:
            frame = pd.read_sql_query(stmt, conn)
        frame.columns = [c.upper() for c in frame.columns]
        return frame


def _sqlite_pragmas(dbapi_conn, _record) -> None:
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA foreign_keys = ON")
    cur.close()


class SimulationWriter(Recorder):
    """Writes one simulation inside an open transaction; a :class:`Recorder` for engines."""

    def __init__(self, store: Store, conn, scene: Scene, started: _dt.datetime):
        self.conn = conn
        self.scene = scene
        self.want_bounces = scene.record in ("bounces", "all")
        self.want_collisions = scene.record == "all"
        self.finished = False
        self._n_bounces = 0
        self._n_collisions = 0
        res = conn.execute(simulation.insert().values(
            si_deb=started, si_dur=float(scene.duration), si_dim=int(scene.dim),
            si_n=int(scene.n), si_l=float(scene.length)))
        self.si_num = int(res.inserted_primary_key[0])
        nums = [store._pa_num(conn, sp) for sp in scene.species]
        self._pa_of_kind = np.array(nums, dtype=np.int64)
        self._pa_of_particle = self._pa_of_kind[scene.kinds()]
        conn.execute(composition.insert(), [
            {"si_num": self.si_num, "pa_num": num, "co_n": int(k)}
            for num, (_, k) in zip(nums, scene.components)])
        conn.execute(scene_table.insert().values(
            si_num=self.si_num, sc_seed=int(scene.seed), sc_temperature=float(scene.temperature),
            sc_engine=scene.engine, sc_boundary=scene.boundary, sc_gravity=float(scene.gravity),
            sc_restitution=float(scene.restitution), sc_tc=float(scene.tc),
            sc_wall_restitution=float(scene.wall_restitution),
            sc_dt=None if scene.dt is None else float(scene.dt), sc_drag=float(scene.drag),
            sc_pair_gravity=float(scene.pair_gravity), sc_placement=scene.placement,
            sc_record=scene.record, sc_version=__version__))

    def _insert_many(self, table: sa.Table, columns: list) -> None:
        """executemany of column arrays: positional tuples straight to the driver when its
        parameter style allows (SQLite: ~10x faster than dicts through Core), else dicts."""
        rows = list(zip(*[np.asarray(c).tolist() for c in columns]))
        if self.conn.dialect.paramstyle in ("qmark", "format", "numeric"):
            marks = {"qmark": "?", "format": "%s"}.get(self.conn.dialect.paramstyle)
            names = [c.name for c in table.columns]
            if marks is None:
                marks_list = [f":{k + 1}" for k in range(len(names))]
            else:
                marks_list = [marks] * len(names)
            sql = f"INSERT INTO {table.name} ({', '.join(names)}) VALUES ({', '.join(marks_list)})"
            self.conn.exec_driver_sql(sql, rows)
        else:
            keys = [c.name for c in table.columns]
            self.conn.execute(table.insert(), [dict(zip(keys, r)) for r in rows])

    def add_bounces(self, t, particle, wall, speed, vperp):
        k = len(t)
        if k == 0:
            return
        start = self._n_bounces + 1
        self._insert_many(rebond, [
            np.full(k, self.si_num), np.arange(start, start + k),
            self._pa_of_particle[np.asarray(particle)], np.asarray(t, dtype=float),
            np.asarray(wall, dtype=np.int64), np.asarray(speed, dtype=float),
            np.asarray(vperp, dtype=float)])
        self._n_bounces += k

    def add_collisions(self, t, i, j, impulse):
        k = len(t)
        if k == 0:
            return
        start = self._n_collisions + 1
        self._insert_many(choc, [
            np.full(k, self.si_num), np.arange(start, start + k), np.asarray(t, dtype=float),
            np.asarray(i, dtype=np.int64), np.asarray(j, dtype=np.int64),
            np.asarray(impulse, dtype=float)])
        self._n_collisions += k

    def finish(self, stats: RunStats, ke_start: float, ke_end: float) -> None:
        """Write the run's results; the transaction commits when the block ends."""
        self.conn.execute(resultat.insert().values(
            si_num=self.si_num, rs_events=int(stats.events), rs_bounces=int(stats.wall_bounces),
            rs_collisions=int(stats.collisions), rs_ke_start=float(ke_start),
            rs_ke_end=float(ke_end), rs_virial=float(stats.virial),
            rs_wall_time=float(stats.wall_time_s)))
        self.finished = True
