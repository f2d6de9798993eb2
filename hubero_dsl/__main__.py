"""`python -m hubero_dsl ...` runs the command line, like the `hubero` script."""

import os
import sys

# `python -m` puts the current directory first on the import path: a scenario's folder could
# then shadow any module hubero imports. Run as the `hubero` script does, without it; code of
# the user's own is handed over by name (`--controller ROBOT=MODULE:CLASS`) and must be
# importable (installed, or on PYTHONPATH).
if sys.path and sys.path[0] in ("", os.getcwd()):
    del sys.path[0]

from hubero_dsl.cli.main import program

raise SystemExit(program())
