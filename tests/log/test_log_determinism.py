"""Same scenario, same seed: the same bytes, whatever the process or its hash seed."""

from __future__ import annotations

from pathlib import Path

from tests.log.conftest import MEETING, REPO_ROOT, World, hubero, write_log


def test_two_processes_write_identical_logs(world: World, tmp_path: Path) -> None:
    scenario = world.scenario("meeting.hub", MEETING)
    outputs = []
    for hash_seed in ("1", "4242"):
        output = tmp_path / f"run-{hash_seed}.mcap"
        done = hubero("run", str(scenario), "-q", "--variant", "slow", "-o", str(output),
                      cwd=REPO_ROOT, PYTHONHASHSEED=hash_seed)
        assert done.returncode == 0, done.stderr
        outputs.append(output.read_bytes())
    assert outputs[0] == outputs[1]
    # and the same as encoding it in this process rather than in a writer process
    here = tmp_path / "here.mcap"
    write_log(scenario, here, variant="slow", writer_process=False)
    assert here.read_bytes() == outputs[0]


def test_another_seed_or_variant_gives_another_log(world: World, tmp_path: Path) -> None:
    scenario = world.scenario("meeting.hub", MEETING)
    logs = {}
    for name, variant, seed in (("a", "slow", None), ("b", "slow", 6), ("c", "fast", None)):
        logs[name] = tmp_path / f"{name}.mcap"
        write_log(scenario, logs[name], variant=variant, seed=seed)
    contents = {path.read_bytes() for path in logs.values()}
    assert len(contents) == 3


def test_the_same_file_logs_the_same_bytes_wherever_it_lies(world: World, tmp_path: Path
                                                            ) -> None:
    """However the path is typed, from whichever folder, and in a copy elsewhere: the log
    names the scenario by its file name and the map as the file writes it."""
    scenario = world.scenario("meeting.hub", MEETING)
    copy = tmp_path / "elsewhere"
    copy.mkdir()
    for name in ("meeting.hub", *(p.name for p in world.folder.glob("room*"))):
        (copy / name).write_bytes((world.folder / name).read_bytes())
    runs = [(str(scenario), REPO_ROOT), ("meeting.hub", world.folder),
            ("./meeting.hub", world.folder), ("elsewhere/meeting.hub", tmp_path)]
    logs = []
    for number, (typed, cwd) in enumerate(runs):
        output = tmp_path / f"run-{number}.mcap"
        done = hubero("run", typed, "-q", "-o", str(output), cwd=cwd)
        assert done.returncode == 0, done.stderr
        logs.append(output.read_bytes())
    assert all(log == logs[0] for log in logs[1:])
