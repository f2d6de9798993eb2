"""hubero: declarative human-behaviour scenarios for robot research.

Pipeline, one module per stage: text -> parse -> AST -> checks -> program + activity graph ->
simulation (world, humans, planners) -> MCAP log -> analysis. The CLI is a thin layer on top.
"""

from __future__ import annotations

__version__ = "0.1.0"
