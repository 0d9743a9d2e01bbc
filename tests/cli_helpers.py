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


def wait_for_diagnostics(proc, lines: int = 3) -> None:
    """Read a running ``gaz simulate --engine step`` child's stderr until it has printed
    ``lines`` diagnostics lines ("time=..."): the run is under way. Fails with the child's
    output if it ended first."""
    seen = 0
    while seen < lines:
        line = proc.stderr.readline()
        assert line, proc.communicate()  # (the run ended or failed instead)
        seen += line.startswith("time=")
