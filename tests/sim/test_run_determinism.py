"""Same file, same seed: the same run, whatever process or PYTHONHASHSEED runs it."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.loop import run_program
from hubero_dsl.sim.simulation import Simulation

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "house_party.hub"

TRAJECTORY_DIGEST = """
import hashlib, sys
import numpy as np
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.loop import run_program
from hubero_dsl.sim.simulation import Simulation
frames = []
sim = Simulation(compile_file(sys.argv[1]), variant=sys.argv[2], seed=int(sys.argv[3]))
result = run_program(sim, [lambda s: frames.append(s.engine.humans.position.copy())])
digest = hashlib.sha256(np.stack(frames).tobytes())
digest.update(repr([(e.tick, e.human, e.kind, e.status.value) for e in result.events]).encode())
print(digest.hexdigest())
"""


def digest_in_subprocess(hash_seed: str, seed: int) -> str:
    env = {**os.environ, "PYTHONHASHSEED": hash_seed}
    out = subprocess.run([sys.executable, "-c", TRAJECTORY_DIGEST, str(SCENARIO), "calm",
                          str(seed)], capture_output=True, text=True, env=env, check=True)
    return out.stdout.strip()


def test_two_processes_with_different_hash_seeds_give_identical_trajectories() -> None:
    assert digest_in_subprocess("1", 3) == digest_in_subprocess("4242", 3)


def test_a_different_seed_changes_the_run() -> None:
    assert digest_in_subprocess("1", 3) != digest_in_subprocess("1", 4)


def test_distributions_are_drawn_per_human_from_the_seed() -> None:
    program = compile_file(SCENARIO)  # guests draw speed from normal(1.29 m/s, 0.10 m/s)
    speeds = [Simulation(program, variant=None, seed=seed, activities=False).params
              for seed in (1, 1, 2)]
    assert speeds[0] == speeds[1]
    assert speeds[0]["guest1"]["speed"] != speeds[2]["guest1"]["speed"]
    assert speeds[0]["guest1"]["speed"] != speeds[0]["guest2"]["speed"]
    assert speeds[0]["host"]["speed"] == 1.1  # a fixed value is not drawn


def test_move_around_paths_depend_on_the_seed() -> None:
    program = compile_file(SCENARIO)

    def guest1_path(seed: int) -> bytes:
        sim = Simulation(program, seed=seed)
        frames: list[np.ndarray] = []
        run_program(sim, [lambda s: frames.append(s.engine.humans.position[1].copy())])
        return hashlib.sha256(np.stack(frames).tobytes()).digest()

    assert guest1_path(5) == guest1_path(5)
    assert guest1_path(5) != guest1_path(6)


EXP_DIGEST = """
import hashlib, os, sys
if sys.argv[1] == "hubero first":
    import hubero_dsl
import numpy as np
x = np.linspace(-30.0, 3.0, 100_001)
values = np.concatenate([np.exp(x), np.log1p(np.abs(x)), np.arctan2(x, x[::-1]), np.abs(x) ** 1.7])
print(hashlib.sha256(values.tobytes()).hexdigest())
print(os.environ.get("NPY_DISABLE_CPU_FEATURES"))
"""


def _exp_digest(order: str, **env: str) -> tuple[str, str]:
    done = subprocess.run([sys.executable, "-c", EXP_DIGEST, order], capture_output=True,
                          text=True, check=True,
                          env={**{k: v for k, v in os.environ.items()
                                  if k != "NPY_DISABLE_CPU_FEATURES"}, **env})
    digest, features = done.stdout.splitlines()
    return digest, features


def test_hubero_loaded_first_runs_numpys_loops_of_every_x86_64_machine() -> None:
    from hubero_dsl import _numpy_avx512

    digest, features = _exp_digest("hubero first")
    assert features == _numpy_avx512()
    assert digest == _exp_digest("numpy alone", NPY_DISABLE_CPU_FEATURES=features)[0]


def test_a_users_own_choice_of_numpys_loops_is_kept() -> None:
    assert _exp_digest("hubero first", NPY_DISABLE_CPU_FEATURES="AVX512_SPR")[1] == "AVX512_SPR"
