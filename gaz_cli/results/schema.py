"""The results database's layout: SQLAlchemy tables, their columns, the schema versions.

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
- PROFIL(SI_NUM, PR_AXIS, PR_BLOCK, PR_BIN, PR_SAMPLES, PR_COUNT): the density profile
  along each axis, for the scenes whose wall pressure is compared with the middle's density.
- SCHEMA_VERSION(SV_VERSION): one row, the version of this layout
  (:data:`SCHEMA_VERSION`); a database without it is version 1.

Table and column names are created in lower case, so that the SQL files,
written in upper case as in the exam, run unchanged on SQLite and on
PostgreSQL (which folds unquoted names to lower case). A column added in a
later version carries ``info={"since": v}``; :mod:`gaz_cli.results.migrations`
brings an older database forward. The SQLite DDL shipped in
``sql/schema/sqlite.sql`` is generated from this metadata
(:func:`gaz_cli.results.sqlite.generated_schema`).
"""

from __future__ import annotations

import sqlalchemy as sa

from gaz_cli.model.species import NAME_MAX

metadata = sa.MetaData()

ROW_NUMBER = sa.Integer().with_variant(sa.BigInteger(), "postgresql")
"""RE_NUM, CH_NUM: a run's rows numbered 1, 2, ...; past 2^31 - 1 in a long run (the README
example's gas records ~1.8e13 wall bounces a second of simulated time: 2^31 after 1.2e-4 s, minutes
of engine), so BIGINT on PostgreSQL (schema 6); INTEGER on SQLite, whose integers are 64-bit (and
the SQLite schema stays as it was)."""

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
    sa.Column("pa_nom", sa.String(NAME_MAX), nullable=False),
    sa.Column("pa_m", sa.Float, nullable=False),
    sa.Column("pa_r", sa.Float, nullable=False),
)

rebond = sa.Table(
    "rebond", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("re_num", ROW_NUMBER, primary_key=True, autoincrement=False),
    sa.Column("pa_num", sa.Integer, sa.ForeignKey("particule.pa_num"), nullable=False),
    sa.Column("re_t", sa.Float, nullable=False),
    sa.Column("re_dir", sa.Integer, nullable=False),
    sa.Column("re_vit", sa.Float, nullable=False),
    sa.Column("re_vp", sa.Float, nullable=False),
    sqlite_with_rowid=False,  # the primary key is the storage order: one B-tree, not two
    # PostgreSQL (schema 4): one partition per run, attached whole at its commit
    # (gaz_cli.results.postgres.PostgresRun);
    # the same columns and keys, the exam's queries unchanged
    postgresql_partition_by="RANGE (si_num)",
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
    sa.Column("sc_file", sa.Text, info={"since": 3}),
)

composition = sa.Table(
    "composition", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("pa_num", sa.Integer, sa.ForeignKey("particule.pa_num"), primary_key=True),
    sa.Column("co_n", sa.Integer, nullable=False),
    sa.Column("co_rank", sa.Integer, info={"since": 3}),
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
    sa.Column("ch_num", ROW_NUMBER, primary_key=True, autoincrement=False),
    sa.Column("ch_t", sa.Float, nullable=False),
    sa.Column("ch_i", sa.Integer, nullable=False),
    sa.Column("ch_j", sa.Integer, nullable=False),
    sa.Column("ch_imp", sa.Float, nullable=False),
    postgresql_partition_by="RANGE (si_num)",  # as REBOND (schema 5)
)

profil = sa.Table(
    "profil", metadata,
    sa.Column("si_num", sa.Integer, sa.ForeignKey("simulation.si_num"), primary_key=True),
    sa.Column("pr_axis", sa.Integer, primary_key=True, autoincrement=False),
    sa.Column("pr_block", sa.Integer, primary_key=True, autoincrement=False),
    sa.Column("pr_bin", sa.Integer, primary_key=True, autoincrement=False),
    sa.Column("pr_samples", sa.Integer, nullable=False),
    sa.Column("pr_count", sa.Integer, nullable=False),
    info={"since": 7},
)
"""The time-averaged density profile (schema 7): along axis PR_AXIS (1..D), the centres in
bin PR_BIN of [0, L] (width L/32) whose other coordinates lie in the box's middle half,
summed over the PR_SAMPLES position samples of block PR_BLOCK (the run's samples, evenly
spaced in time, in 64 blocks). Written for one species at walls without forces
(:func:`gaz_cli.model.recording.profile_wanted`): the density in the box's middle that the
wall pressure is compared with."""

schema_version = sa.Table(
    "schema_version", metadata,
    sa.Column("sv_version", sa.Integer, nullable=False),
)

EXAM_TABLES = ("simulation", "particule", "rebond")

SCHEMA_VERSION = 7
"""Version of the layout this gaz writes into SQLite. 1: the tables above but SCHEMA_VERSION
(rollback journal, PostgreSQL's PARTICULE sequence left at 1 by seeding); 2: adds
SCHEMA_VERSION, WAL mode, PARTICULE's sequence past its rows; 3: adds SCENE.SC_FILE
(the scene file that re-runs the simulation) and COMPOSITION.CO_RANK (the species'
place in the scene: particles come in blocks, rank 0 first, so CHOC's particle
indices map to species); 7: adds the table PROFIL (SQLite has no 4 to 6: PostgreSQL's
alone). A column added in version v carries ``info={"since": v}``, a table too."""

POSTGRES_SCHEMA_VERSION = 7
"""Version of the layout this gaz writes into PostgreSQL. 4: 3, and REBOND partitioned by
RANGE (SI_NUM), one partition per run (``rebond_<SI_NUM>``) plus a default partition
(``rebond_default``) for rows written any other way; same columns, same keys. 5: CHOC
partitioned the same way (``choc_<SI_NUM>``, ``choc_default``). 6: RE_NUM and CH_NUM
BIGINT (:data:`ROW_NUMBER`) in a new database; one migrated from 5 keeps its 32-bit
columns (widening them rewrites every row), and a run whose rows would number past them is
refused at its start (:meth:`gaz_cli.results.store.Store.check_row_numbers`), the ALTER TABLE that widens them
named. 7: adds PROFIL, as SQLite's 7. SQLite has no version 4 to 6 (nothing changed there)."""

PARTITIONED = ("rebond", "choc")
"""PostgreSQL: the tables of one row per event, partitioned by run (schema 4 and 5)."""


def latest_version(dialect_name: str) -> int:
    """The schema version this gaz writes for a backend ('sqlite', 'postgresql', ...)."""
    return POSTGRES_SCHEMA_VERSION if dialect_name == "postgresql" else SCHEMA_VERSION
