"""The hand-written MCAP container against the maintained `mcap.writer.Writer`, same messages.

    python benchmarks/mcap_writer.py [--humans 1000] [--time-limit 20] [--repeat 3]

Runs the crossing workload of `benchmarks/logging_cost.py` without a log and with an in-process
log (`log/frames.py` formats the JSON, `log/container.py` writes it): the difference is what the
whole log costs. Then reads every message of that log back and writes them again with
`mcap.writer.Writer` (same chunk size, zstd): the JSON is given, so this is the container's work
alone. Best of `--repeat` for each; the ratio is the Writer's time over the whole hand-written log.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from arguments import at_least_one
from logging_cost import crossing_scenario
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from hubero_dsl.pipeline import compile_file
from hubero_dsl.simulate import simulate

CHUNK_SIZE = 4 << 20  # as RunLog's default


def rewrite(source: Path, target: Path) -> float:
    """Seconds `mcap.writer.Writer` takes to write every message of `source` into `target`."""
    with source.open("rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None
        messages = [(m.channel_id, m.sequence, m.log_time, m.data)
                    for _, _, m in reader.iter_messages(log_time_order=False)]
    start = time.perf_counter()
    with target.open("wb") as stream:
        writer = Writer(stream, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD)
        writer.start()
        schemas = {key: writer.register_schema(schema.name, schema.encoding, schema.data)
                   for key, schema in summary.schemas.items()}
        channels = {key: writer.register_channel(channel.topic, channel.message_encoding,
                                                 schemas.get(channel.schema_id, 0))
                    for key, channel in summary.channels.items()}
        for channel, sequence, stamp, data in messages:
            writer.add_message(channels[channel], stamp, data, stamp, sequence)
        writer.finish()
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--humans", type=at_least_one, default=1000)
    parser.add_argument("--time-limit", type=float, default=20.0, help="simulated seconds")
    parser.add_argument("--repeat", type=at_least_one, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        program = compile_file(crossing_scenario(folder, args.humans, args.time_limit))
        log = folder / "crossing.mcap"
        bare, logged, maintained = [], [], []
        for _ in range(args.repeat):
            start = time.perf_counter()
            simulate(program)
            bare.append(time.perf_counter() - start)
            start = time.perf_counter()
            simulate(program, log=log, log_rate=10.0, writer_process=False)
            logged.append(time.perf_counter() - start)
            maintained.append(rewrite(log, folder / "rewritten.mcap"))
        hand = min(logged) - min(bare)
        print(f"crossing: {args.humans} humans, {args.time_limit:g} s at 10 Hz, "
              f"{log.stat().st_size / 1e6:.1f} MB; best of {args.repeat}")
        print(f"  run without a log                        {min(bare):7.3f} s")
        print(f"  whole hand-written log (format + write)  {hand:7.3f} s")
        print(f"  mcap.writer.Writer, messages given       {min(maintained):7.3f} s "
              f"({min(maintained) / hand:.2f}x the hand-written log)")


if __name__ == "__main__":
    main()
