"""The packaged SQL queries by name: what ``gaz query`` runs.

Each file of ``sql/`` (installed as ``gaz_cli.sql``) is one query: its
leading comment describes it (the first sentence is its one-line
description) and its ``:name`` placeholders are its parameters. A query is
called by its short name -- the file name's first word, ``q34``, ``q36``,
``pressure`` -- or by the whole file name, in any case.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from gaz_cli.errors import QueryError

_PARAMETER = re.compile(r"(?<![:\w]):([A-Za-z_]\w*)")

PARAMETERS = {
    "si_num": ("a whole number", "SIMULATION.SI_NUM"),
    "re_num": ("a whole number", "REBOND.RE_NUM"),
    "lo": ("a whole number", "the first RE_NUM"),
    "hi": ("a whole number", "the last RE_NUM"),
    "bins": ("a positive whole number", "time bins"),
    "duration": ("a positive number", "s, the time the bins divide"),
    "t_lo": ("a number", "s"),
    "t_hi": ("a number", "s"),
}
"""Every parameter of the packaged queries: what its value must be, and what it is. The SQL
would compare any other value (``si_num=abc``, ``bins=0``) and answer with no row, or rows
of nonsense, without a word."""


@dataclass(frozen=True)
class Query:
    """One packaged query: short ``name``, ``file`` name, one-line ``description``,
    ``parameters`` (its :name placeholders, in order of appearance) and ``sql``."""

    name: str
    file: str
    description: str
    parameters: tuple[str, ...]
    sql: str


def catalogue() -> list[Query]:
    """Every packaged query, sorted by file name."""
    from gaz_cli.results.store import query_names, query_text

    files = query_names()
    stems = [f[:-len(".sql")] for f in files]
    firsts = [s.split("_", 1)[0] for s in stems]
    out = []
    for file, stem, first in zip(files, stems, firsts):
        sql = query_text(file)
        comment = " ".join(line.strip()[2:].strip() for line in sql.splitlines()
                           if line.strip().startswith("--"))
        code = "\n".join(line.split("--", 1)[0] for line in sql.splitlines())
        params = tuple(dict.fromkeys(_PARAMETER.findall(code)))
        sentence = re.split(r"(?<=\.)\s", comment, maxsplit=1)[0]
        out.append(Query(first if firsts.count(first) == 1 else stem, file, sentence, params, sql))
    return out


def find(name: str) -> Query:
    """The query called ``name`` (short name, file name, with or without .sql; any case)."""
    key = name.lower().removesuffix(".sql")
    queries = catalogue()
    for q in queries:
        if key in (q.name.lower(), q.file.lower().removesuffix(".sql")):
            return q
    raise QueryError(f"no query named {name!r}; the packaged ones are "
                     f"{', '.join(q.name for q in queries)} (gaz query --list describes them)")


def parse_parameters(query: Query, pairs) -> dict:
    """``KEY=VALUE`` strings -> the query's parameters (ints and floats converted).

    Raises QueryError naming a malformed pair, an unknown key or a missing one.
    """
    params = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        key = key.strip()
        if not sep or not key:
            raise QueryError(f"--param {pair!r} is not KEY=VALUE (e.g. --param si_num=1)")
        if key not in query.parameters:
            takes = (f"takes {', '.join(query.parameters)}" if query.parameters else "takes no parameter")
            raise QueryError(f"query {query.name} has no parameter {key!r}; it {takes}")
        if key in params:
            raise QueryError(f"--param {key} is given twice; give it once")
        params[key] = _number(value.strip())
        if isinstance(params[key], int) and not -2 ** 63 <= params[key] < 2 ** 63:
            raise QueryError(f"--param {pair!r}: {key} is beyond a 64-bit integer, the largest the "
                             "database holds; no stored value matches it")
        _check_kind(pair, key, params[key])
    missing = [p for p in query.parameters if p not in params]
    if missing:
        raise QueryError(f"query {query.name} needs {' '.join(f'--param {p}=VALUE' for p in missing)}")
    return params


def _check_kind(pair: str, key: str, value) -> None:
    """Refuse a value that is not what :data:`PARAMETERS` says ``key`` takes."""
    kind, what = PARAMETERS.get(key, ("a number", key))
    number = isinstance(value, (int, float)) and math.isfinite(value)
    if (not number or ("whole" in kind and not isinstance(value, int))
            or ("positive" in kind and value <= 0)):
        raise QueryError(f"--param {pair!r}: {key} takes {kind} ({what}), got {value!r}")


def run(db: str, name: str, pairs=()) -> tuple[Query, "pd.DataFrame"]:  # noqa: F821
    """Run the packaged query ``name`` on the database ``db`` with ``KEY=VALUE`` parameters."""
    from gaz_cli.results.store import Store

    query = find(name)
    params = parse_parameters(query, pairs)
    with Store(db, create=False) as store:
        _check_columns(query, store)
        _check_simulation(params, store)
        return query, store.read_sql(query.sql, **params)


def stored_scene_file(db: str, si_num: int) -> str:
    """The scene file stored with simulation ``si_num`` in ``db`` (SCENE.SC_FILE, the packaged
    query ``scene``), made runnable by today's gaz
    (:func:`gaz_cli.scenes.files.without_builtin_clash`). QueryError for an ``si_num`` not
    stored; StoreError for a run stored without its scene file."""
    from gaz_cli.errors import StoreError
    from gaz_cli.scenes.files import without_builtin_clash

    _, frame = run(db, "scene", [f"si_num={int(si_num)}"])  # refuses an si_num not stored
    text = frame.iloc[0, 1]
    if not isinstance(text, str) or not text:
        raise StoreError(f"simulation {si_num} was stored without its scene file (by a gaz older than schema "
                         "version 3, or by other software with no SCENE row): there is no SCENE.SC_FILE to print")
    return without_builtin_clash(text)


def _check_simulation(params: dict, store) -> None:
    """Refuse, in one line, an ``si_num`` the database does not hold: the query would answer
    with no row and exit 0, a mistyped number looking like a run without bounces."""
    if "si_num" in params and params["si_num"] not in store.simulation_numbers():
        raise QueryError(f"no simulation {params['si_num']} in {store.shown!r}; "
                         f"gaz analyse --db {store.shown} lists them")


def _check_columns(query: Query, store) -> None:
    """Refuse, in one line, a query that reads a column the database's (older) schema
    version lacks, rather than let the database say "no such column"."""
    from gaz_cli.results.schema import metadata

    version = store.schema_version()
    code = re.sub(r"--[^\n]*", "", query.sql).lower()
    for table in metadata.sorted_tables:
        for column in table.columns:
            since = column.info.get("since", 1)
            if since > version and re.search(rf"\b{column.name.lower()}\b", code):
                raise QueryError(
                    f"query {query.name} reads {table.name.upper()}.{column.name.upper()}, added in schema "
                    f"version {since}; {store.shown!r} is at version {version} (an older gaz): it is migrated "
                    f"forward the next time gaz writes to it (gaz simulate --db {store.shown} ...), and runs "
                    "stored before keep no value there")


def _number(text: str):
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text
