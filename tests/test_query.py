"""``gaz query NAME``: the packaged SQL files by name, on SQLite and PostgreSQL."""

import io

import numpy as np
import pandas as pd
import pytest

from backends import BACKENDS, backend, postgres_db, postgres_url  # noqa: F401 - fixtures
from cli_helpers import invoke
from gaz_cli.results import queries
from gaz_cli.results import store as st
from gaz_cli.errors import QueryError

QUICK = ["simulate", "--engine", "reference", "--dim", "2", "--n", "20", "--length", "1e-7",
         "--duration", "2e-10"]


def test_list_names_every_packaged_file():
    res = invoke(["query", "--list"])
    assert res.exit_code == 0
    lines = res.stdout.splitlines()
    assert len(lines) == len(st.query_names())
    by_name = {line.split()[0]: line for line in lines}
    assert set(by_name) == {"bounce", "collision", "first", "lookup", "pair", "pressure", "q34", "q35", "q36", "scene",
                            "sweep", "wall"}
    assert "Q34: number of simulations for each dimension of space." in by_name["q34"]
    assert by_name["q36"].endswith("[--param si_num=...]") and "--param" not in by_name["q34"]
    frame = pd.read_csv(io.StringIO(invoke(["query", "--list", "--format", "csv"]).stdout))
    assert list(frame.FILE) == st.query_names()


def test_names_resolve_in_any_spelling():
    for name in ("q36", "Q36", "q36_momentum_per_wall", "q36_momentum_per_wall.sql"):
        assert queries.find(name).file == "q36_momentum_per_wall.sql"
    assert queries.find("pressure").parameters == ("si_num",)
    assert queries.find("q34").parameters == ()


@pytest.mark.parametrize("backend", BACKENDS, indirect=True)
def test_query_csv_is_the_query_result(backend):
    """csv output reads back with pd.read_csv, numbers as numbers, equal to the store's result."""
    assert invoke([*QUICK, "--seed", "1", "--db", backend]).exit_code == 0
    for name, params in (("q36", ["--param", "si_num=1"]), ("q35", []), ("q34", []),
                         ("pressure", ["--param", "si_num=1"])):
        res = invoke(["query", name, *params, "--db", backend, "--format", "csv"])
        assert res.exit_code == 0, res.stderr
        frame = pd.read_csv(io.StringIO(res.stdout))
        store = st.Store(backend, create=False)
        expected = store.query(queries.find(name).file, **({"si_num": 1} if params else {}))
        store.close()
        assert list(frame.columns) == list(expected.columns) and len(frame) == len(expected) > 0
        for column in frame.columns:
            assert frame[column].dtype.kind in "if"
            assert np.allclose(frame[column], expected[column], rtol=1e-15, atol=0)  # csv keeps 17 digits
    res = invoke(["query", "q36", "--param", "si_num=1", "--db", backend, "--format", "json"])
    assert res.exit_code == 0 and '"q36"' in res.stdout


@pytest.mark.parametrize("args, message", [
    (["query", "q36"], "gaz: error: query q36 needs --param si_num=VALUE\n"),
    (["query", "q34", "--param", "x=1"], "gaz: error: query q34 has no parameter 'x'; it takes no parameter\n"),
    (["query", "q36", "--param", "si_num"],
     "gaz: error: --param 'si_num' is not KEY=VALUE (e.g. --param si_num=1)\n"),
    (["query", "q36", "--param", "si_num=abc"],
     "gaz: error: --param 'si_num=abc': si_num takes a whole number (SIMULATION.SI_NUM), got 'abc'\n"),
    (["query", "q36", "--param", "si_num=1.5"],
     "gaz: error: --param 'si_num=1.5': si_num takes a whole number (SIMULATION.SI_NUM), got 1.5\n"),
    (["query", "q36", "--param", "si_num="],
     "gaz: error: --param 'si_num=': si_num takes a whole number (SIMULATION.SI_NUM), got ''\n"),
    (["query", "bounce", "--param", "si_num=1", "--param", "bins=0", "--param", "duration=1e-10"],
     "gaz: error: --param 'bins=0': bins takes a positive whole number (time bins), got 0\n"),
    (["query", "bounce", "--param", "si_num=1", "--param", "bins=4", "--param", "duration=nan"],
     "gaz: error: --param 'duration=nan': duration takes a positive number (s, the time the bins divide), "
     "got nan\n"),
    # the last one won, without a word
    (["query", "q36", "--param", "si_num=1", "--param", "si_num=2"],
     "gaz: error: --param si_num is given twice; give it once\n"),
    # answered "(no rows)", exit 0: a mistyped SI_NUM looked like a run without bounces
    (["query", "q36", "--param", "si_num=9"],
     "gaz: error: no simulation 9 in '{db}'; gaz analyse --db {db} lists them\n"),
    (["query", "scene", "--param", "si_num=2"],
     "gaz: error: no simulation 2 in '{db}'; gaz analyse --db {db} lists them\n"),
    (["query", "q99"], "gaz: error: no query named 'q99'; the packaged ones are bounce, collision, first, "
                       "lookup, pair, pressure, q34, q35, q36, scene, sweep, wall "
                       "(gaz query --list describes them)\n"),
])
def test_query_errors_are_one_line(tmp_path, args, message):
    db = str(tmp_path / "gaz.db")
    assert invoke([*QUICK, "--seed", "1", "--db", db]).exit_code == 0
    res = invoke([*args, "--db", db])
    assert (res.exit_code, res.stdout, res.stderr) == (1, "", message.replace("{db}", db))


def test_every_packaged_parameter_says_what_it_takes():
    """A new query's :name must say what its values are (queries.PARAMETERS), or
    `--param name=abc` would run and answer with no row, exit 0."""
    for q in queries.catalogue():
        assert set(q.parameters) <= set(queries.PARAMETERS), (q.file, q.parameters)


def test_query_without_name_or_database(tmp_path):
    res = invoke(["query"])
    assert res.exit_code == 2 and "give a query NAME, or --list to see them" in res.stderr
    res = invoke(["query", "q34", "--db", str(tmp_path / "none.db")])
    assert res.exit_code == 1 and "does not exist" in res.stderr and res.stderr.count("\n") == 1
    with pytest.raises(QueryError):
        queries.parse_parameters(queries.find("q36"), ["si_num=1", "extra=2"])


@pytest.mark.parametrize("backend", BACKENDS, indirect=True)
def test_a_column_newer_than_the_database_is_named(backend):
    """`gaz query scene` and `gaz scene` on a database of schema version 1 (no SC_FILE):
    one line naming the column, the versions and what migrates it; queries of the exam's
    columns still run there."""
    from test_store import _version_1

    _version_1(backend)
    for args in (["query", "scene", "--param", "si_num=1"], ["scene", "1"]):
        res = invoke(args + ["--db", backend])
        assert res.exit_code == 1 and len(res.stderr.splitlines()) == 1
        assert "SCENE.SC_FILE, added in schema version 3" in res.stderr and "at version 1" in res.stderr
    res = invoke(["query", "q34", "--db", backend, "--format", "csv"])
    assert res.exit_code == 0 and "2,1" in res.stdout  # one simulation in 2D
    with st.Store(backend, create=False) as store:
        assert store.schema_version() == 1  # reading did not migrate


@pytest.mark.postgres
def test_messages_naming_the_database_hide_its_password(postgres_db):
    """Every message that names --db hides its password, as the store's own do: --no-db with
    --db, a simulation not in the database (gaz scene), a query that needs a newer schema
    version, gaz analyse of a simulation not in it (each printed the URL whole: 'no simulation
    9 in 'postgresql://gaz:s3cret@...'').
    (The test server trusts its socket: the password is given, and not checked.)"""
    import sqlalchemy as sa
    from test_store import _version_1

    db = sa.make_url(postgres_db).set(password="s3cret").render_as_string(hide_password=False)
    said = []
    res = invoke([*QUICK, "--no-db", "--db", db])
    assert res.exit_code == 2 and "drop --no-db" in res.stderr
    said.append(res.stderr)
    assert invoke([*QUICK, "--seed", "1", "--db", db]).exit_code == 0
    res = invoke(["scene", "9", "--db", db])
    assert res.exit_code == 1 and "no simulation 9 in" in res.stderr
    said.append(res.stderr)
    res = invoke(["analyse", "--sim", "9", "--db", db])
    assert res.exit_code == 1 and "simulation 9 is not in" in res.stderr
    said.append(res.stderr)
    with st.Store(postgres_db) as store, store.engine.begin() as conn:  # back to schema version 1
        for table in reversed(st.metadata.sorted_tables):
            conn.exec_driver_sql(f"DROP TABLE {table.name} CASCADE")
    _version_1(postgres_db)
    res = invoke(["scene", "1", "--db", db])
    assert res.exit_code == 1 and "added in schema version 3" in res.stderr
    said.append(res.stderr)
    for err in said:
        assert "s3cret" not in err and "gaz:***@" in err, err
