"""Environment steps per second of `hubero/Scenario-v0`, single and vectorised, beside SocNavGym.

    python benchmarks/gym_env.py [--steps 3000] [--copies 64] [--rounds 400] [--repeat 3]
                                 [--socnavgym PYTHON]

Two workloads: the paper's living room (two humans walking their dinner scenario) with an
external robot added, and a 20-person room where everyone wanders. Each is timed through
`gymnasium.make` / `gymnasium.make_vec` with random actions, resets included, after `reset`:
the actions are drawn before the clock starts (drawing them is the policy's work, not the
environment's: gymnasium's `Box.sample` costs about 60 us, a quarter of a step of the living
room), for hubero and SocNavGym alike; the single env for `--steps` steps, the vector env
for `--rounds` steps of all its copies (400 steps are 20 s of each copy's first episode: its
people walking, then standing); each rate is the best of `--repeat` runs (other work on the
machine only ever slows a run down). Targets (issue 12): single env >= 5,000 steps/s on the
living room; 64 copies >= 50,000 env-steps/s on the living room and >= 10,000 on the crowd.

`--socnavgym PYTHON` also times SocNavGym-v1 (a CrowdNav-style Gym environment, on PyPI as
`socnavgym`) in that interpreter, in the same run: a 10 m x 10 m room with 2 and with 20
people walking by its social force policy, 50 ms steps, random actions, resets included. It
needs its own environment, for it pins gym 0.26 and needs torch and Python-RVO2 (built from its
repository): `python -m venv peer && peer/bin/pip install socnavgym pyyaml matplotlib pandas
torch`, then `peer/bin/pip install --no-build-isolation .` in a clone of
sybrenstuvel/Python-RVO2 (with Cython and wheel installed). SocNavGym imports dgl for a reward
model this benchmark does not use; the run gives it a stand-in module instead.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import tempfile
import time
from pathlib import Path

import gymnasium
import numpy as np
from arguments import at_least_one

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
    actions = [env.action_space.sample() for _ in range(steps)]  # the policy's part: untimed
    start = time.perf_counter()
    for action in actions:
        _, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def vector_rate(scenario: Path, rounds: int, copies: int) -> float:
    envs = gymnasium.make_vec(hubero_dsl.gym.ENV_ID, num_envs=copies,
                              vectorization_mode="vector_entry_point", scenario=str(scenario),
                              robot="cart")
    envs.reset(seed=0)
    envs.action_space.seed(0)
    actions = [envs.action_space.sample() for _ in range(rounds)]
    start = time.perf_counter()
    for action in actions:
        envs.step(action)
    return rounds * copies / (time.perf_counter() - start)


# A module named dgl that imports and has whatever is asked of it: SocNavGym builds a graph
# network reward model from dgl at every reset, which the DSRNN reward timed here never uses.
DGL_STAND_IN = """
import importlib.abc, importlib.machinery, sys, types
class _Anything(types.ModuleType):
    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return type(name, (), {"__init__": lambda self, *a, **k: None})
class _Finder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    def find_spec(self, name, path, target=None):
        if name == "dgl" or name.startswith("dgl."):
            return importlib.machinery.ModuleSpec(name, self, is_package=True)
        return None
    def create_module(self, spec):
        module = _Anything(spec.name)
        module.__path__ = []
        return module
    def exec_module(self, module):
        pass
sys.meta_path.insert(0, _Finder())
"""

SOCNAVGYM_RATE = """
import json, sys, time, warnings
warnings.filterwarnings("ignore")
import numpy as np
np.bool8 = np.bool_  # gym 0.26 still names it so
import gym, socnavgym
import socnavgym.envs.rewards.reward_api as reward_api
reward_api.SocNavAPI = lambda *a, **k: None  # the graph network reward model, unused
env = gym.make("SocNavGym-v1", config=sys.argv[1])
env.reset(seed=0)
env.action_space.seed(0)
steps = int(sys.argv[2])
actions = [env.action_space.sample() for _ in range(steps)]  # the policy's part: untimed
start = time.perf_counter()
for action in actions:
    _, _, terminated, truncated, _ = env.step(action)
    if terminated or truncated:
        env.reset()
print(json.dumps(steps / (time.perf_counter() - start)))
"""


def socnavgym_config(people: int) -> dict[str, object]:
    """SocNavGym's own example configuration (exp1), with `people` dynamic humans walking by
    its social force policy, no furniture, 50 ms steps, a square 10 m room."""
    zero = ("static_humans", "tables", "plants", "laptops", "h_h_dynamic_interactions",
            "h_h_dynamic_interactions_non_dispersing", "h_h_static_interactions",
            "h_h_static_interactions_non_dispersing", "human_in_h_h_interactions",
            "h_l_interactions", "h_l_interactions_non_dispersing")
    env: dict[str, object] = {
        "margin": 0.5, "max_advance_human": 0.1, "max_rotation_human": 1.57,
        "max_advance_robot": 0.1, "max_rotation": 0.387596899, "wall_segment_size": 1.0,
        "speed_threshold": 0.005, "crowd_dispersal_probability": 0.0,
        "human_laptop_dispersal_probability": 0.0, "crowd_formation_probability": 0.0,
        "human_laptop_formation_probability": 0.0, "reward_file": "dsrnn", "cuda_device": 0,
        "min_dynamic_humans": people, "max_dynamic_humans": people,
        "get_padded_observations": False, "set_shape": "square", "add_corridors": False,
        "min_map_x": 10, "max_map_x": 10, "min_map_y": 10, "max_map_y": 10}
    env.update({f"{bound}_{name}": 0 for name in zero for bound in ("min", "max")})
    return {
        "rendering": {"resolution_view": 1000, "milliseconds": 30},
        "episode": {"episode_length": 400, "time_step": 0.05, "end_with_collision": True},
        "robot": {"robot_radius": 0.25, "goal_radius": 0.35, "robot_type": "diff-drive"},
        "human": {"human_diameter": 0.72, "human_goal_radius": 0.25, "human_policy": "sfm",
                  "gaze_angle": 3.14159, "fov_angle": 6.2831853, "prob_to_avoid_robot": 0.0},
        "laptop": {"laptop_width": 0.4, "laptop_length": 0.6}, "plant": {"plant_radius": 0.4},
        "table": {"table_width": 1.5, "table_length": 3.0}, "wall": {"wall_thickness": 0.2},
        "human-human-interaction": {"interaction_radius": 0.72, "interaction_goal_radius": 1.44,
                                    "noise_variance": 0.005},
        "human-laptop-interaction": {"human_laptop_distance": 0.3},
        "env": env}


def socnavgym_rate(python: str, folder: Path, people: int, steps: int) -> float:
    """SocNavGym-v1's steps per second, in the interpreter `python` (JSON is YAML)."""
    config = folder / f"socnavgym_{people}.yaml"
    config.write_text(json.dumps(socnavgym_config(people)), encoding="utf-8")
    (folder / "sitecustomize.py").write_text(DGL_STAND_IN, encoding="utf-8")
    done = subprocess.run([python, "-c", SOCNAVGYM_RATE, str(config), str(steps)],
                          capture_output=True, text=True, check=False,
                          env={**os.environ, "PYTHONPATH": str(folder)})
    if done.returncode != 0:
        raise SystemExit(f"SocNavGym could not be timed:\n{done.stderr[-2000:]}")
    return float(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=at_least_one, default=3000)
    parser.add_argument("--copies", type=at_least_one, default=64)
    parser.add_argument("--rounds", type=at_least_one, default=400,
                        help="steps of all the vector env's copies")
    parser.add_argument("--repeat", type=at_least_one, default=3,
                        help="runs of each measurement, the best reported")
    parser.add_argument("--socnavgym", metavar="PYTHON",
                        help="an interpreter with SocNavGym installed, to time it alongside")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        for label, people, scenario, single_target, vector_target in (
                ("living room (2 people)", 2, living_room(folder), 5_000, 50_000),
                ("crowd (20 people)", 20, crowd(folder), None, 10_000)):
            single = max(single_rate(scenario, args.steps) for _ in range(args.repeat))
            vector = max(vector_rate(scenario, args.rounds, args.copies)
                         for _ in range(args.repeat))
            targets = (f"target {single_target:,}" if single_target else "no target")
            print(f"{label}: single env {single:,.0f} steps/s ({targets}); "
                  f"{args.copies} copies {vector:,.0f} env-steps/s (target {vector_target:,})")
            if args.socnavgym:
                peer = max(socnavgym_rate(args.socnavgym, folder, people,
                                          max(args.steps // 10, 100))
                           for _ in range(args.repeat))
                print(f"  SocNavGym-v1, {people} people: {peer:,.0f} steps/s; hubero's single "
                      f"env {single / peer:.1f}x, {args.copies} copies {vector / peer:.1f}x")


if __name__ == "__main__":
    main()
