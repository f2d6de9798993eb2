"""`hubero export RUN.mcap --ros2 DIR`: a run log as a ROS 2 bag of standard messages.

    hubero export runs/living_room.mcap --ros2 living_room_bag
    ros2 bag play living_room_bag --clock

The bag (MCAP storage, with metadata.yaml) has /clock, /map (nav_msgs/OccupancyGrid), /tf (a
frame per human and robot), /people (people_msgs/People), /people/poses and /robots/poses
(geometry_msgs/PoseArray) and /people/markers (visualization_msgs/MarkerArray), stamped in
simulated time; docs/ros2.md lists them. DIR must not exist, or be an empty folder. Exit 0 when
written, 2 for an unreadable log or a DIR that cannot be written.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "export", help="write a run log as a ROS 2 bag", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("log", metavar="RUN.mcap", help="a run log written by hubero run")
    parser.add_argument("--ros2", metavar="DIR", type=Path, required=True,
                        help="write a rosbag2 (MCAP storage) into this new folder")
    return parser


def run(args: argparse.Namespace) -> int:
    from hubero_dsl.analysis.ros2 import export_ros2

    written = export_ros2(args.log, args.ros2)
    print(f"bag written to {written}")
    return 0
