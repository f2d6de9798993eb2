"""hubero loads first in each test process, as on the command line, before anything imports
numpy: numpy then runs the loops every x86-64 machine has (`hubero_dsl._numpy_avx512`), and
the shipped logs and the numbers the docs quote are the same on every processor."""

import hubero_dsl  # noqa: F401
