"""The documentation keeps its promises (issue 42).

- Every code block marked ``<!-- test -->`` on the line before its fence in docs/tutorials/
  and docs/how-to/ runs: one test per page, the page's blocks in order, in one fresh
  temporary folder holding a copy of ``examples/`` and ``sql/``, with the ``gaz`` installed
  next to ``sys.executable`` first on the PATH. ``bash`` blocks run in ``bash -euo
  pipefail``; consecutive ``python`` blocks run as one script with ``sys.executable`` (a
  tutorial's later cells use its earlier ones' names, as in a notebook). A block marked
  ``<!-- test needs=TOOL[,TOOL] -->`` runs only where each TOOL is a program on the PATH (a
  bash block: sqlite3, sqlite-utils) or an importable module (a python block: MDAnalysis,
  freud, ovito, pyvista): skipped elsewhere, and said so in the test's output. ``needs=postgres``
  runs against the server of GAZ_TEST_POSTGRES_URL (.ci/run starts one), the page's example
  URL (:data:`EXAMPLE_URL`) replaced by a fresh schema of it. Blocks without a marker are not
  run: installing, creating a database, a Dask cluster on machines of your own, a graphical program
  (ParaView, OVITO's window), and the full-size versions of commands whose small version is
  marked.
- The rule for the command-line reference: docs/reference/cli.md is rendered with
  mkdocs-click, as the site renders it, and the result must hold a section for every command
  of the ``gaz`` group (walked recursively), headed by its full name, naming every option
  flag of that command; mkdocs-click leaves hidden options out, so a hidden option fails
  this test too.
- Every packaged SQL file is included in docs/reference/sql.md; every table and column of
  sql/schema/sqlite.sql has a row in docs/reference/database.md.
- The README stays a landing page: at most 200 lines, no link out of the repository.

The docs build itself (``mkdocs build --strict``) runs in .ci/run, after the suites.
"""

from __future__ import annotations

import contextlib
import importlib.util
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import click
import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
PAGES = sorted([*(DOCS / "tutorials").glob("*.md"), *(DOCS / "how-to").glob("*.md")])
BLOCK = re.compile(r"^<!-- test(?: needs=(?P<needs>[\w.,-]+))? -->\n```(?P<lang>bash|python)\n(?P<code>.*?)^```$",
                   re.MULTILINE | re.DOTALL)
BLOCK_TIMEOUT_S = 600  # a hang guard: every block takes seconds


def blocks(page: Path) -> list[dict]:
    """The marked blocks of ``page``, in order: lang, code, needs (list of tools)."""
    text = page.read_text(encoding="utf-8")
    return [{"lang": m["lang"], "code": m["code"], "needs": (m["needs"] or "").split(",") if m["needs"] else [],
             "line": text.count("\n", 0, m.start()) + 1} for m in BLOCK.finditer(text)]


def have(tool: str, lang: str, path: str) -> bool:
    """A bash block needs a program on ``path``, a python block an importable module."""
    if tool == "postgres":  # a server to write to (tests/backends.py's)
        return bool(os.environ.get("GAZ_TEST_POSTGRES_URL"))
    if lang == "bash":
        return shutil.which(tool, path=path) is not None
    return importlib.util.find_spec(tool) is not None


def groups(page_blocks: list[dict]):
    """Consecutive python blocks merged into one script, which needs every tool any of them
    needs; each bash block on its own."""
    out: list[dict] = []
    for block in page_blocks:
        if block["lang"] == "python" and out and out[-1]["lang"] == "python":
            out[-1]["code"] += "\n" + block["code"]
            out[-1]["needs"] = [*out[-1]["needs"], *(n for n in block["needs"] if n not in out[-1]["needs"])]
        else:
            out.append(dict(block))
    return out


def test_the_pages_have_marked_blocks():
    """The marker is spelled right on every page that has code to run (a typo would make the
    page's test pass without running anything)."""
    unmarked = [p.name for p in PAGES if p.name != "index.md" and not blocks(p)
                and p.name != "postgresql.md"]
    assert not unmarked, f"pages without a '<!-- test -->' block: {unmarked}"
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        assert text.count("<!-- test") == len(blocks(page)), f"{page.name}: a marker not followed by a bash/python block"


EXAMPLE_URL = "postgresql://user@localhost/gaz"
"""The PostgreSQL URL the pages show; a block marked ``needs=postgres`` runs against the
server of GAZ_TEST_POSTGRES_URL (.ci/run starts one), in a schema of its own."""


def _postgres_schema():
    """A URL into a fresh schema of the test server, dropped after (tests/backends.py)."""
    from backends import fresh_schema

    return fresh_schema(os.environ["GAZ_TEST_POSTGRES_URL"], prefix="gaz_docs")


@pytest.mark.parametrize("page", [p for p in PAGES if blocks(p)], ids=lambda p: f"{p.parent.name}/{p.name}")
def test_the_marked_blocks_run(page, tmp_path, capsys):
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    shutil.copytree(ROOT / "sql", tmp_path / "sql", ignore=shutil.ignore_patterns("__init__.py", "__pycache__"))
    env = dict(os.environ, PATH=os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")]),
               MPLBACKEND="Agg")
    env.pop("PYTHONPATH", None)
    skipped = []
    stack = contextlib.ExitStack()  # the PostgreSQL schemas of the blocks that need one
    try:
        for block in groups(blocks(page)):
            missing = [tool for tool in block["needs"] if not have(tool, block["lang"], env["PATH"])]
            if missing:
                skipped.append(f"line {block['line']} (needs {', '.join(missing)})")
                continue
            if "postgres" in block["needs"]:  # the page's example URL becomes a fresh schema of the test server
                url = stack.enter_context(_postgres_schema())
                block = {**block, "code": block["code"].replace(EXAMPLE_URL, f"'{url}'")}
            if block["lang"] == "bash":
                argv = ["bash", "-euo", "pipefail", "-c", block["code"]]
            else:
                argv = [sys.executable, "-c", block["code"]]
            done = subprocess.run(argv, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=BLOCK_TIMEOUT_S,
                                  stdin=subprocess.DEVNULL)
            assert done.returncode == 0, (f"{page.relative_to(ROOT)} line {block['line']} exit {done.returncode}\n"
                                          f"--- code\n{block['code']}--- stdout\n{done.stdout[-3000:]}"
                                          f"--- stderr\n{done.stderr[-3000:]}")
    finally:
        stack.close()
    if skipped:
        with capsys.disabled():
            print(f"\n{page.relative_to(ROOT)}: not run here: {'; '.join(skipped)}")


def commands(group: click.Command, path: tuple[str, ...] = ("gaz",)):
    """(path, command) for the group and every command under it, recursively."""
    yield path, group
    if isinstance(group, click.Group):
        for name, sub in group.commands.items():
            yield from commands(sub, (*path, name))


def test_every_command_and_option_is_in_the_cli_reference():
    """Rendered as the site renders it, the page has a section per command, headed by the
    command's full name (``gaz simulate``), and each section names every option flag of its
    command (its own section only: ``--dim`` of place does not document ``--dim`` of simulate)."""
    import markdown  # mkdocs-click's own dependency; both in the test extra

    from gaz_cli.cli import cli

    page = (DOCS / "reference" / "cli.md").read_text(encoding="utf-8")
    assert "::: mkdocs-click" in page
    html = markdown.Markdown(extensions=["attr_list", "tables", "mkdocs-click"]).convert(page)
    parts = re.split(r"<h\d[^>]*>(.*?)</h\d>", html)  # text, heading, text, heading, text...
    sections = {re.sub(r"<[^>]+>", "", head).strip(): re.sub(r"<[^>]+>", " ", body)
                for head, body in zip(parts[1::2], parts[2::2])}
    missing = []
    for path, command in commands(cli):
        name = " ".join(path)
        if name not in sections:
            missing.append(f"{name} (no section)")
            continue
        for param in command.params:
            if isinstance(param, click.Option):
                missing += [f"{name} {flag}" for flag in (*param.opts, *param.secondary_opts)
                            if not re.search(rf"(?<![\w-]){re.escape(flag)}(?![\w-])", sections[name])]
    assert not missing, f"not in docs/reference/cli.md as rendered: {missing}"


def test_every_packaged_sql_file_is_in_the_reference():
    page = (DOCS / "reference" / "sql.md").read_text(encoding="utf-8")
    missing = [f.name for f in sorted((ROOT / "sql").glob("*.sql")) if f'--8<-- "sql/{f.name}"' not in page]
    assert not missing, f"add to docs/reference/sql.md: {missing}"


def test_every_table_and_column_is_in_the_schema_reference():
    ddl = (ROOT / "sql" / "schema" / "sqlite.sql").read_text(encoding="utf-8")
    page = (DOCS / "reference" / "database.md").read_text(encoding="utf-8")
    names = re.findall(r"CREATE TABLE IF NOT EXISTS (\w+) \((.*?)\n\)", ddl, re.DOTALL)
    assert len(names) >= 8
    missing = []
    for table, body in names:
        if not re.search(rf"^## {table.upper()}\b", page, re.MULTILINE):
            missing.append(table)
        for column in re.findall(r"^\t(\w+) [A-Z]", body, re.MULTILINE):
            if column.upper() in ("PRIMARY", "FOREIGN"):
                continue
            if f"| `{column.upper()}` |" not in page:
                missing.append(f"{table}.{column}")
    assert not missing, f"add to docs/reference/database.md: {missing}"


def test_the_readme_is_a_landing_page():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) <= 200
    targets = re.findall(r"\]\(([^)]+)\)", readme)
    outside = [t for t in targets if t.startswith("..") or "://" in t]
    assert not outside, f"links out of the repository: {outside}"
    missing = [t for t in targets if not (ROOT / t.split("#")[0]).exists()]
    assert not missing, f"links to files that do not exist: {missing}"
    for command in ("pip install -e '.[test]' && python -m pytest", "pip install -e '.[docs]' && mkdocs build --strict"):
        assert command in readme
