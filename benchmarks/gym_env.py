"""Environment steps per second of `hubero/Scenario-v0`, single and vectorised.

    python benchmarks/gym_env.py [--steps 3000] [--copies 64]

Two workloads: the paper's living room (two humans walking their dinner scenario) with an
external robot added, and a 20-person room where everyone wanders. Each is timed through
`gymnasium.make` / `gymnasium.make_vec` with random actions, resets included, after a warm-up
episode step. Targets (issue 12): single env >= 5,000 steps/s on the living room; 64 copies
>= 50,000 env-steps/s on the living room and >= 10,000 on the crowd.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import gymnasium
import numpy as np

import hubero_dsl.gym
from hubero_dsl.world.mapfile import load_map

REPO_ROOT = Path(__file__).resolve().parents[1]

LIVING_ROOM_ROBOT = """
robot cart at (-4.4, 4.8) {
    controller external; goal (3.5, 0.5); radius 0.3 m; speed 0.7 m/s; max_speed 1 m/s
}
"""


def living_room(folder: Path) -> Path:
    text = (REPO_ROOT / "scenarios" / "living_room.hub").read_text(encoding="utf-8")
    text = text.replace('map "../maps/living_room.yaml"',
                        f'map "{REPO_ROOT / "maps" / "living_room.yaml"}"')
    file = folder / "living_room_gym.hub"
    file.write_text(text + LIVING_ROOM_ROBOT, encoding="utf-8")
    return file


def crowd(folder: Path, people: int = 20) -> Path:
    """People at seeded free places (0.6 m from walls and from each other) in the lounge."""
    grid = load_map(REPO_ROOT / "maps" / "living_room.yaml")
    rng = np.random.default_rng(1)
    lines = ['scenario "gym crowd"', f'map "{REPO_ROOT / "maps" / "living_room.yaml"}"',
             "time_limit 60 s", LIVING_ROOM_ROBOT]
    placed: list[tuple[float, float]] = []
    while len(placed) < people:
        x, y = float(rng.uniform(-4.5, 3.0)), float(rng.uniform(0.5, 5.0))
        if grid.clearance_at((x, y)) > 0.6 and all(
                (x - a) ** 2 + (y - b) ** 2 > 0.36 for a, b in placed):
            placed.append((x, y))
            lines.append(f"human p{len(placed) - 1} at ({x:.2f}, {y:.2f})")
    steps = "\n".join(f"    p{i} move_around in rect((-4.5, 0.5), (3.0, 5.0)) for 60 s"
                      for i in range(people))
    lines.append("activity { parallel {\n" + steps + "\n} }")
    file = folder / "crowd_gym.hub"
    file.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return file


def single_rate(scenario: Path, steps: int) -> float:
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(scenario), robot="cart")
    env.reset(seed=0)
    env.action_space.seed(0)
    start = time.perf_counter()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def vector_rate(scenario: Path, steps: int, copies: int) -> float:
    envs = gymnasium.make_vec(hubero_dsl.gym.ENV_ID, num_envs=copies,
                              vectorization_mode="vector_entry_point", scenario=str(scenario),
                              robot="cart")
    envs.reset(seed=0)
    envs.action_space.seed(0)
    rounds = max(1, steps // copies)
    start = time.perf_counter()
    for _ in range(rounds):
        envs.step(envs.action_space.sample())
    return rounds * copies / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--copies", type=int, default=64)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        for label, scenario, single_target, vector_target in (
                ("living room (2 people)", living_room(folder), 5_000, 50_000),
                ("crowd (20 people)", crowd(folder), None, 10_000)):
            single = single_rate(scenario, args.steps)
            vector = vector_rate(scenario, args.steps, args.copies)
            targets = (f"target {single_target:,}" if single_target else "no target")
            print(f"{label}: single env {single:,.0f} steps/s ({targets}); "
                  f"{args.copies} copies {vector:,.0f} env-steps/s (target {vector_target:,})")


if __name__ == "__main__":
    main()
