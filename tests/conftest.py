"""hubero loads first in each test process, as on the command line, before anything imports
numpy: numpy then runs the loops every x86-64 machine has (`hubero_dsl._numpy_avx512`), and
the shipped logs and the numbers the docs quote are the same on every processor."""

import hubero_dsl  # noqa: F401


def earlier_run_log(path: object) -> bytes:
    """Write at `path` the smallest file a run may write over: an MCAP log with hubero's
    provenance record (and nothing else). Returns its bytes."""
    from pathlib import Path

    from mcap.writer import Writer

    from hubero_dsl.log import schemas

    with Path(str(path)).open("wb") as stream:
        writer = Writer(stream)
        writer.start()
        writer.add_metadata(schemas.METADATA_NAME, {"format": schemas.FORMAT})
        writer.finish()
    return Path(str(path)).read_bytes()
