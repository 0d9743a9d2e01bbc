"""Drive ``gaz`` in-process through its real entry point, stdout and stderr apart."""

from click.testing import CliRunner

from gaz_cli import cli as cli_mod


class Result:
    def __init__(self, exit_code, stdout, stderr):
        self.exit_code, self.stdout, self.stderr = exit_code, stdout, stderr
        self.output = stdout + stderr

    def __iter__(self):  # code, out, err = invoke(...)
        return iter((self.exit_code, self.stdout, self.stderr))


def invoke(args) -> Result:
    """Run ``gaz ARGS`` through ``gaz_cli.cli.main`` (one-line errors, exit codes),
    inside CliRunner's isolation so that stdout and stderr are captured apart."""
    runner = CliRunner()
    with runner.isolation() as streams:
        try:
            cli_mod.main(list(args))
            code = 0
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        out, err = streams[0].getvalue(), streams[1].getvalue()
    return Result(code, out.decode(), err.decode())
