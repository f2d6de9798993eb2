"""The Gymnasium environment's frames (`render_mode="rgb_array"`): what they show, and the API."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env  # noqa: E402

import hubero_dsl.gym  # noqa: E402 - registers hubero/Scenario-v0
from hubero_dsl.analysis.frame import GOAL, HUMAN, ROBOT  # noqa: E402
from hubero_dsl.errors import InputError  # noqa: E402
from tests.test_gym import _scenario  # noqa: E402


def _env(folder: Path, **options: object) -> gymnasium.Env:
    return gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(_scenario(folder)), robot="cart",
                          render_mode="rgb_array", **options)


def _colour_at(frame: np.ndarray, pixel: tuple[float, float]) -> tuple[int, ...]:
    u, v = pixel
    return tuple(int(c) for c in frame[int(v), int(u)])


def test_gymnasiums_checker_passes_with_frames(tmp_path: Path) -> None:
    env = _env(tmp_path)
    check_env(env.unwrapped)
    assert env.metadata["render_fps"] == pytest.approx(20.0)  # one frame a tick of 0.05 s


def test_a_frame_shows_the_people_the_robot_and_its_goal_where_they_are(tmp_path: Path) -> None:
    env = _env(tmp_path, render_size=300)
    env.reset(seed=1)
    for _ in range(10):
        env.step(np.array([1.0, 0.5], np.float32))
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert max(frame.shape[:2]) in (299, 300, 301)
    assert frame.shape[0] % 2 == frame.shape[1] % 2 == 0
    base = env.unwrapped
    renderer, engine = base._renderer, base._sim.engine
    for position in engine.humans.position:
        assert _colour_at(frame, renderer.pixel(tuple(position))) == HUMAN
    (x, y), heading = engine.robots.position[0], engine.robots.heading[0]
    behind = 0.5 * base.robot_spec.radius  # the centre carries the line to where it faces
    assert _colour_at(frame, renderer.pixel((x - behind * np.cos(heading),
                                             y - behind * np.sin(heading)))) == ROBOT
    gx, gy = base.robot_spec.goal
    ring = renderer.pixel((gx + base.robot_spec.goal_tolerance, gy))
    near = frame[int(ring[1]) - 2:int(ring[1]) + 3, int(ring[0]) - 2:int(ring[0]) + 3]
    assert (near == GOAL).all(axis=2).any()


def test_frames_follow_the_run_and_repeat_with_it(tmp_path: Path) -> None:
    def frames() -> list[np.ndarray]:
        env = _env(tmp_path)
        env.reset(seed=4)
        shot = [env.render()]
        for _ in range(20):
            env.step(np.array([0.8, 0.8], np.float32))
            shot.append(env.render())
        return shot

    first, second = frames(), frames()
    assert all(np.array_equal(a, b) for a, b in zip(first, second, strict=True))
    assert not np.array_equal(first[0], first[-1])  # the robot has moved


def test_without_a_render_mode_render_warns_and_draws_nothing(tmp_path: Path) -> None:
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(_scenario(tmp_path)),
                         robot="cart")
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="render_mode"):
        assert env.render() is None


def test_an_unknown_render_mode_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="render_mode must be one of rgb_array"):
        hubero_dsl.gym.ScenarioEnv(_scenario(tmp_path), "cart", render_mode="human")


def test_the_vector_env_draws_every_copy_on_one_drawn_map(tmp_path: Path) -> None:
    envs = gymnasium.make_vec(hubero_dsl.gym.ENV_ID, num_envs=3,
                              vectorization_mode="vector_entry_point",
                              scenario=str(_scenario(tmp_path)), robot="cart",
                              render_mode="rgb_array")
    envs.reset(seed=[1, 2, 3])
    envs.step(np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]], np.float32))
    frames = envs.render()
    assert len(frames) == 3 and all(f.shape == frames[0].shape for f in frames)
    assert not np.array_equal(frames[0], frames[1])
    copies = envs.unwrapped.envs
    assert all(env._renderer is copies[0]._renderer for env in copies)
    single = _env(tmp_path)
    single.reset(seed=2)
    single.step(np.array([0.0, 1.0], np.float32))
    assert np.array_equal(single.render(), frames[1])
