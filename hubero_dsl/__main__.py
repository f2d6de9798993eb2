"""`python -m hubero_dsl`: the same as the `hubero` command."""

from __future__ import annotations

from hubero_dsl.cli.main import main

raise SystemExit(main())
