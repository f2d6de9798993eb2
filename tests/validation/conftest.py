"""The command-line helpers of tests/cli, for `hubero validate` and `hubero calibrate`."""

from tests.cli.conftest import cli  # noqa: F401  (a fixture, used by name)
