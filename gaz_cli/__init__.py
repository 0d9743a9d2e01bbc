"""gaz: hard-sphere gases in a box, every wall bounce in a SQL database."""

__version__ = "0.1.0"
