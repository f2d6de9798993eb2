"""`hubero export RUN.mcap --ros2 DIR` from the command line: a bag, or exit 2 and a message."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from hubero_dsl.pipeline import compile_file
from hubero_dsl.simulate import simulate

pytest.importorskip("rosbags.rosbag2")

ROOT = Path(__file__).resolve().parents[2]


def test_the_command_writes_a_bag_and_refuses_bad_input(tmp_path: Path, cli: Any) -> None:
    log = tmp_path / "run.mcap"
    simulate(compile_file(ROOT / "scenarios" / "living_room.hub"), log=log,
             writer_process=False)
    done = cli("export", str(log), "--ros2", str(tmp_path / "bag"))
    assert done.status == 0, done.err
    assert (tmp_path / "bag" / "metadata.yaml").is_file()
    again = cli("export", str(log), "--ros2", str(tmp_path / "bag"))
    assert again.status == 2 and "not an empty folder" in again.err
    (tmp_path / "notes.txt").write_text("root:x:0:0:secret\n")
    wrong = cli("export", str(tmp_path / "notes.txt"), "--ros2", str(tmp_path / "b2"))
    assert wrong.status == 2 and "not an MCAP file" in wrong.err
    assert "secret" not in wrong.err and "114, 111" not in wrong.err
    nowhere = cli("export", str(log), "--ros2", str(tmp_path / "no" / "such" / "bag"))
    assert nowhere.status == 2
    assert "Traceback" not in again.err + wrong.err + nowhere.err
    assert not (tmp_path / "b2").exists()


def test_a_link_to_an_empty_folder_takes_the_bag_and_a_dangling_one_is_refused(
        tmp_path: Path, cli: Any) -> None:
    log = tmp_path / "run.mcap"
    simulate(compile_file(ROOT / "scenarios" / "living_room.hub"), log=log,
             writer_process=False)
    (tmp_path / "real").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "real")
    done = cli("export", str(log), "--ros2", str(tmp_path / "link"))
    assert done.status == 0, done.err
    assert (tmp_path / "link").is_symlink() and (tmp_path / "real" / "metadata.yaml").is_file()
    (tmp_path / "dangling").symlink_to(tmp_path / "gone")
    refused = cli("export", str(log), "--ros2", str(tmp_path / "dangling"))
    assert refused.status == 2 and "which does not exist" in refused.err
    assert not (tmp_path / "gone").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dangling", "link", "real", "run.mcap"]
