"""The store's edges: what a run that is refused, fails or is interrupted leaves on disk (nothing),
and names SQLite would read otherwise than as written."""

import sqlite3

from cli_helpers import invoke

# a run of the exam's own engine (no JIT to wait for), a few ms long
QUICK = ["simulate", "--engine", "reference", "--dim", "2", "--n", "20", "--length", "1e-7",
         "--duration", "2e-10", "--seed", "1"]


def simulations(path):
    con = sqlite3.connect(path)
    try:
        return [r[0] for r in con.execute("SELECT si_num FROM simulation ORDER BY si_num")]
    finally:
        con.close()


def test_a_file_uri_as_db_is_refused_and_a_dotted_path_is_that_file(tmp_path, monkeypatch):
    """SQLite reads a name starting with 'file:' as a URI: --db file:x.db wrote x.db, while
    gaz analyse --db file:x.db looked for a file named 'file:x.db' ("does not exist"). Both
    commands refuse it in one line naming the two fixes, creating nothing; ./file:x.db is the file
    of that name, written and read; sqlite:///file:x.db (no ?uri=true) is refused alike."""
    monkeypatch.chdir(tmp_path)
    for command in (QUICK, ["analyse"], ["query", "q34"]):
        for db in ("file:x.db", "sqlite:///file:x.db"):
            res = invoke([*command, "--db", db])
            assert res.exit_code == 1 and res.stdout == "", res.output
            assert res.stderr.count("\n") == 1, res.stderr
            assert "reads a name starting with 'file:' as a URI" in res.stderr and "'x.db'" in res.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    res = invoke([*QUICK, "--db", "./file:x.db"])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file:x.db"]
    assert simulations(tmp_path / "file:x.db") == [1]
    res = invoke(["analyse", "--db", "./file:x.db", "--format", "json"])
    assert res.exit_code == 0, res.output
