"""The packaged SQL queries (plain SQL files, valid in SQLite and PostgreSQL).

Installed as ``gaz_cli.sql``; read them with :func:`gaz_cli.results.store.query_text`.
"""
