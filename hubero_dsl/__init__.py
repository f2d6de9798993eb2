"""hubero: declarative human-behaviour scenarios for robot research.

Pipeline, one module per stage: text -> parse -> AST -> checks -> program + activity graph ->
simulation (world, humans, planners) -> MCAP log -> analysis. The CLI is a thin layer on top.
"""

from __future__ import annotations

import importlib.util
import os
import re
import sys

__version__ = "0.1.0"


def _numpy_avx512() -> str:
    """The names of numpy's AVX-512 loops, as the installed numpy knows them (2.4 renamed
    them), read from its version file: importing numpy to ask would be too late."""
    spec = importlib.util.find_spec("numpy")
    try:
        assert spec is not None and spec.submodule_search_locations
        folder = next(iter(spec.submodule_search_locations))
        with open(os.path.join(folder, "version.py"), encoding="utf-8") as file:
            found = re.search(r'^version = "(\d+)\.(\d+)', file.read(), re.MULTILINE)
        assert found is not None
        release = (int(found[1]), int(found[2]))
    except (AssertionError, OSError, ValueError):
        return ""
    if release >= (2, 4):
        return "X86_V4 AVX512_ICL AVX512_SPR"
    return "AVX512F AVX512CD AVX512_KNL AVX512_KNM AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL"


# numpy's AVX-512 loops for exp, log, power and arctan2 round differently from the ones every
# x86-64 machine has, and a crowd's run amplifies one last bit into another jam: the same file
# and seed would give another log on another processor. Left out before numpy loads (the
# command line, and any program that imports hubero first), every machine runs the same
# loops; a choice of the user's own is kept.
if "numpy" not in sys.modules and "NPY_DISABLE_CPU_FEATURES" not in os.environ:
    os.environ["NPY_DISABLE_CPU_FEATURES"] = _numpy_avx512()
