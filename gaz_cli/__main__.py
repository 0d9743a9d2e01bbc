"""Allow ``python -m gaz_cli``."""

from gaz_cli.cli import main

main()
