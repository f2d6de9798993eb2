"""The Gymnasium environment, tested with gymnasium's own checker and its make/make_vec."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env  # noqa: E402

import hubero_dsl.gym  # noqa: E402 - registers hubero/Scenario-v0
from hubero_dsl.analysis.socialnav_log import robot_social_metrics  # noqa: E402
from hubero_dsl.errors import InputError  # noqa: E402
from hubero_dsl.log.reader import load_run  # noqa: E402
from hubero_dsl.socialnav import CONTACT, METRICS  # noqa: E402
from hubero_dsl.world.mapfile import save_map  # noqa: E402
from tests.sim.conftest import room_grid  # noqa: E402

SCENARIO = """\
scenario "gym room"
map "room.yaml"
seed 2
time_limit 20 s
human alice at (5, 6)
human bob at (8, 2)
robot cart at (1, 1) {{
    controller external; kinematics {kinematics}; goal (8, 6); radius 0.3 m
    speed 0.8 m/s; max_speed 1 m/s; max_angular_speed 2.0
}}
activity {{ parallel {{ alice move_to (5, 1); bob move_around for 20 s }} }}
expect cart reaches (8, 6) within 20 s
"""


def _scenario(folder: Path, kinematics: str = "holonomic") -> Path:
    save_map(room_grid(), folder / "room.yaml")
    file = folder / f"gym_{kinematics}.hub"
    file.write_text(SCENARIO.format(kinematics=kinematics), encoding="utf-8")
    return file


@pytest.mark.parametrize("kinematics", ["holonomic", "unicycle"])
def test_gymnasiums_checker_passes(tmp_path: Path, kinematics: str) -> None:
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(_scenario(tmp_path, kinematics)),
                         robot="cart", map_patch=16)
    check_env(env.unwrapped, skip_render_check=True)
    observation, _ = env.reset(seed=0)
    assert env.observation_space.contains(observation)
    assert observation["map"].shape == (16, 16)


def test_same_seed_and_actions_same_observations(tmp_path: Path) -> None:
    file = str(_scenario(tmp_path))
    runs = []
    for _ in range(2):
        env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=file, robot="cart")
        observation, _ = env.reset(seed=11)
        seen = [observation["people"].copy()]
        rng = np.random.default_rng(5)
        for _ in range(60):
            observation, *_ = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
            seen.append(observation["people"].copy())
        runs.append(np.stack(seen))
    assert np.array_equal(runs[0], runs[1])
    env.reset(seed=12)
    other = [env.step(np.zeros(2, np.float32))[0]["people"] for _ in range(60)]
    assert not np.array_equal(np.stack(other), runs[0][1:])


def test_driving_to_the_goal_terminates_with_success_and_metrics(tmp_path: Path) -> None:
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(_scenario(tmp_path)), robot="cart",
                         log=str(tmp_path / "reached.mcap"))
    observation, _ = env.reset(seed=1)
    total, info, terminated, truncated = 0.0, {}, False, False
    while not (terminated or truncated):
        to_goal = observation["robot"][5:7]
        action = to_goal / max(float(np.linalg.norm(to_goal)), 1e-6)
        observation, reward, terminated, truncated, info = env.step(action.astype(np.float32))
        total += reward
    assert terminated and info["outcome"] == "reached" and info["is_success"]
    metrics = info["metrics"]
    assert metrics["path_length"] > 7.0 and metrics["time_to_goal"] < 15.0
    assert info["expectations"] == {"cart reaches (8, 6) within 20 s": True}
    assert total > 10.0
    # the robot's social-navigation metrics over the episode, every one a run has
    assert set(METRICS) <= set(metrics)
    assert metrics["collisions"] == 0 and metrics["min_distance"] > 0.0
    assert 0.0 < metrics["path_efficiency"] <= 1.0 and 0.0 < metrics["plan_efficiency"] <= 1.0
    assert metrics["time_to_goal"] <= info["time"]
    result = load_run(tmp_path / "reached.mcap").result  # the log says so too
    assert result is not None and (result.state, result.reason) == (
        "completed", "robot 'cart' reached its goal")
    assert result.succeeded and result.time == pytest.approx(info["time"])


def test_episode_metrics_can_be_left_out(tmp_path: Path) -> None:
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(_scenario(tmp_path)), robot="cart",
                         metrics=False)
    env.reset(seed=1)
    assert env.unwrapped._judge.tracks is None  # nothing recorded for them
    info: dict[str, object] = {}
    for _ in range(1000):
        *_, terminated, truncated, info = env.step(np.array([1.0, 0.7], np.float32))
        if terminated or truncated:
            break
    assert info["outcome"] in ("reached", "collision", "time limit") and "metrics" not in info


def test_driving_into_a_person_is_a_collision(tmp_path: Path) -> None:
    file = tmp_path / "bump.hub"
    save_map(room_grid(), tmp_path / "room.yaml")
    file.write_text('scenario "bump"\nmap "room.yaml"\nhuman alice at (3, 1)\n'
                    "robot cart at (1, 1) { controller external; goal (8, 1) }\n")
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(file), robot="cart",
                         log=str(tmp_path / "bump.mcap"))
    env.reset(seed=0)
    for _ in range(100):
        _, reward, terminated, _, info = env.step(np.array([1.0, 0.0], np.float32))
        if terminated:
            break
    assert info["outcome"] == "collision" and not info["is_success"] and reward < 0
    result = load_run(tmp_path / "bump.mcap").result
    assert result is not None and (result.state, result.reason) == ("failed",
                                                                    "robot 'cart' collided")
    assert info["metrics"]["collisions"] == 1 and info["metrics"]["min_distance"] < CONTACT
    assert info["metrics"]["time_to_goal"] == float("inf")
    # the episode's log, its positions rounded to 0.1 mm, sees the same contact
    assert robot_social_metrics(load_run(tmp_path / "bump.mcap"), "cart")["collisions"] == 1


def test_actions_are_clipped_to_the_box_and_must_be_finite(tmp_path: Path) -> None:
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(_scenario(tmp_path)), robot="cart")
    env.reset(seed=0)
    for _ in range(40):  # 9 m/s asked along +x: the robot goes at its 1 m/s at most
        observation, *_ = env.step(np.array([9.0, 0.0], np.float32))
    assert observation["robot"][2] == pytest.approx(1.0)
    with pytest.raises(ValueError, match="two finite numbers"):
        env.step(np.array([np.nan, 0.0], np.float32))
    observation, *_ = env.step(np.array([1e308, 1e308]))  # finite: clipped as any other
    assert math.hypot(*observation["robot"][2:4]) == pytest.approx(1.0, abs=0.01)
    for wrong in (np.zeros(3), None, np.array([1j, 0.0]), "ab", [True, False], [0.1, [0.2]],
                  np.zeros((1, 2)), np.zeros((2, 1))):  # the space's shape is (2,)
        with pytest.raises(ValueError, match=r"^an action is two finite numbers, not "):
            env.step(wrong)


def _people_seen(env: gymnasium.Env, seed: int, steps: int = 120) -> np.ndarray:
    observation, _ = env.reset(seed=seed)
    seen = [observation["people"].copy()]
    for _ in range(steps):
        observation, *_ = env.step(np.array([0.3, 0.2], np.float32))
        seen.append(observation["people"].copy())
    return np.stack(seen)


ZIGZAG = """\
scenario "gym zigzag"
map "zigzag.yaml"
time_limit 30 s
human alice at (1.5, 6)
human bob at (8, 2)
human carol at (4.5, 7)
robot cart at (1, 1) { controller external; goal (8, 6); radius 0.3 m; speed 0.8 m/s }
activity { parallel {
    alice move_to (9, 6.5)
    bob move_around in rect((1, 1), (9, 7)) for 30 s
    { carol move_to (1.5, 1.5); carol move_to (9, 1.5) }
} }
"""


def test_episodes_share_plans_and_each_plans_as_if_alone(tmp_path: Path) -> None:
    # two partitions: every walk but the shortest goes round one of them (a search)
    save_map(room_grid(walls=((3.0, 2.5, 3.3, 8.0), (6.5, 0.0, 6.8, 5.5))),
             tmp_path / "zigzag.yaml")
    (tmp_path / "zigzag.hub").write_text(ZIGZAG, encoding="utf-8")
    file = str(tmp_path / "zigzag.hub")
    alone = _people_seen(gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=file, robot="cart"), 11)
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=file, robot="cart")
    _people_seen(env, 12)
    _people_seen(env, 13)
    navfn = env.unwrapped._planners._kept["navfn", ()]
    remembered, known = navfn.remembered_plans, len(navfn._plans)
    assert np.array_equal(_people_seen(env, 11), alone)  # after other episodes' plans
    assert len(navfn._plans) > known  # bob wanders elsewhere with another seed
    remembered, known = navfn.remembered_plans, len(navfn._plans)
    assert np.array_equal(_people_seen(env, 11), alone)
    # the same episode again asks the same questions: every plan is remembered, none searched
    assert navfn.remembered_plans >= remembered + 3 and len(navfn._plans) == known


def test_an_episode_is_saved_as_a_log(tmp_path: Path) -> None:
    log = tmp_path / "episode.mcap"
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(_scenario(tmp_path)), robot="cart",
                         log=str(log))
    env.reset(seed=4)
    truncated = terminated = False
    while not (terminated or truncated):
        _, _, terminated, truncated, _ = env.step(np.array([0.2, 0.1], np.float32))
    run = load_run(log)
    assert set(run.humans) == {"alice", "bob"} and set(run.robots) == {"cart"}
    assert run.robots["cart"].position[-1][0] > 1.0
    # how it ended, as a run's log says it (a log with no result read as a run cut short)
    assert run.result is not None and run.result.state == "timed_out"
    assert run.result.reason == "the time limit" and run.result.time == pytest.approx(20.0)
    assert [e["text"] for e in run.result.expectations] == ["cart reaches (8, 6) within 20 s"]


def test_the_vector_env_batches_and_resets_by_itself(tmp_path: Path) -> None:
    envs = gymnasium.make_vec(hubero_dsl.gym.ENV_ID, num_envs=3,
                              vectorization_mode="vector_entry_point",
                              scenario=str(_scenario(tmp_path)), robot="cart")
    observations, info = envs.reset(seed=7)
    assert list(info["seed"]) == [7, 8, 9] and info["_seed"].all()  # each copy's, batched
    assert observations["robot"].shape == (3, 7) and observations["people"].shape == (3, 8, 5)
    assert envs.observation_space.contains(observations)
    ended = np.zeros(3, dtype=bool)
    for _ in range(450):  # the 20 s limit is 400 steps: every episode ends and restarts
        observations, rewards, terminated, truncated, _ = envs.step(
            np.tile([0.0, 0.0], (3, 1)).astype(np.float32))
        ended |= terminated | truncated
    assert ended.all() and rewards.shape == (3,)
    with pytest.raises(ValueError, match="one row of two numbers per copy, 3 x 2"):
        envs.step(np.zeros((2, 2), dtype=np.float32))
    with pytest.raises(ValueError, match="two finite numbers"):
        envs.step(np.array([[0.0, 0.0], [np.nan, 0.0], [0.0, 0.0]], dtype=np.float32))
    envs.close()


def test_the_vector_envs_copies_are_the_single_envs_exactly(tmp_path: Path) -> None:
    # its copies are steered in one call, each a world of its own: the same observations,
    # rewards and ends, bit for bit, as single environments given the same seeds and actions
    # a robot that sees only ahead and nearby, and its map patch: every part of the observation
    limited = _scenario(tmp_path).read_text(encoding="utf-8").replace(
        "radius 0.3 m", "radius 0.3 m; sensor_range 4 m; field_of_view 200 deg")
    (tmp_path / "limited.hub").write_text(limited, encoding="utf-8")
    file, copies = str(tmp_path / "limited.hub"), 3
    envs = gymnasium.make_vec(hubero_dsl.gym.ENV_ID, num_envs=copies,
                              vectorization_mode="vector_entry_point", scenario=file,
                              robot="cart", map_patch=8)
    observations, _ = envs.reset(seed=5)
    singles = [gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=file, robot="cart", map_patch=8)
               for _ in range(copies)]
    alone = [env.reset(seed=5 + i)[0] for i, env in enumerate(singles)]
    rng, done, met = np.random.default_rng(1), np.zeros(copies, dtype=bool), 0
    for _ in range(450):  # past the 20 s limit: every copy ends and starts again
        actions = rng.uniform(-1.0, 1.0, size=(copies, 2)).astype(np.float32)
        observations, rewards, terminated, truncated, _ = envs.step(actions)
        for i, env in enumerate(singles):
            if done[i]:
                alone[i], _ = env.reset()
                continue
            alone[i], reward, *ended, _ = env.step(actions[i])
            assert reward == rewards[i] and ended == [terminated[i], truncated[i]]
        for key in observations:
            np.testing.assert_array_equal(np.stack([o[key] for o in alone]), observations[key])
        met += int((observations["mask"].sum(axis=1) > 0).sum())
        done = terminated | truncated
    assert 100 < met < 3 * 450  # the robots saw people, and not always (range, view)


LOUNGE = Path(__file__).resolve().parents[1] / "scenarios" / "lounge_crowd.hub"


def test_copies_among_a_crowd_a_group_and_a_robot_are_the_single_envs_exactly(
        tmp_path: Path) -> None:
    # the shipped lounge crowd (8 visitors wandering, a family walking as a group, a robot
    # with the reference navigator, metric expectations) with a driven robot added, which
    # a child meets curiously: every part of a tick done for the copies together
    text = LOUNGE.read_text(encoding="utf-8").replace(
        'map "../maps/', f'map "{LOUNGE.parents[1] / "maps"}/').replace(
        "radius 0.15 m; speed 0.9 m/s", "radius 0.15 m; speed 0.9 m/s; robot_reaction curious")
    file = tmp_path / "lounge_gym.hub"
    file.write_text(text + "robot bot at (-4.0, 1.0) { controller external; goal (2.0, 4.5) }\n",
                    encoding="utf-8")
    copies = 3
    envs = gymnasium.make_vec(hubero_dsl.gym.ENV_ID, num_envs=copies,
                              vectorization_mode="vector_entry_point", scenario=str(file),
                              robot="bot")
    observations, _ = envs.reset(seed=5)
    singles = [gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(file), robot="bot")
               for _ in range(copies)]
    alone = [env.reset(seed=5 + i)[0] for i, env in enumerate(singles)]
    rng = np.random.default_rng(1)
    steps = 0
    while steps < 300:
        steps += 1
        actions = rng.uniform(-1.0, 1.0, size=(copies, 2)).astype(np.float32)
        observations, rewards, terminated, truncated, _ = envs.step(actions)
        ended = []
        for i, env in enumerate(singles):
            alone[i], reward, single_terminated, single_truncated, _ = env.step(actions[i])
            assert (reward, single_terminated, single_truncated) == (
                rewards[i], terminated[i], truncated[i])
            ended.append(single_terminated or single_truncated)
        for key in observations:
            np.testing.assert_array_equal(np.stack([o[key] for o in alone]), observations[key])
        if any(ended):  # a random walk into someone: the copies went alike until here
            break
    assert steps >= 200
    assert observations["mask"].sum() > 0  # the driven robots see people


def test_an_observation_holds_whom_the_robots_sensors_see(tmp_path: Path) -> None:
    limited = _scenario(tmp_path).read_text(encoding="utf-8").replace(
        "radius 0.3 m", "radius 0.3 m; sensor_range 4 m; field_of_view 200 deg")
    (tmp_path / "limited.hub").write_text(limited, encoding="utf-8")
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(tmp_path / "limited.hub"),
                         robot="cart", max_people=1)
    env.reset(seed=3)
    rng, counts = np.random.default_rng(2), set()
    for _ in range(300):
        observation, *_ = env.step(rng.uniform(-1.0, 1.0, 2).astype(np.float32))
        sim = env.unwrapped._sim
        robots, humans = sim.engine.robots, sim.engine.humans
        seen = robots.seen_rows(0, humans.position, humans.radius)
        counts.add(len(seen))
        expected = np.zeros((1, 5), np.float32)
        expected[:len(seen[:1]), 0:2] = humans.position[seen[:1]] - robots.position[0]
        expected[:len(seen[:1]), 2:4] = humans.velocity[seen[:1]]
        expected[:len(seen[:1]), 4] = humans.radius[seen[:1]]
        np.testing.assert_array_equal(observation["people"], expected)
        assert observation["mask"].tolist() == [int(len(seen) > 0)]
    assert counts >= {0, 1, 2}  # nobody, one, and more than max_people seen


def test_each_copy_of_a_vector_env_writes_its_own_log(tmp_path: Path) -> None:
    envs = gymnasium.make_vec(hubero_dsl.gym.ENV_ID, num_envs=2,
                              vectorization_mode="vector_entry_point",
                              scenario=str(_scenario(tmp_path)), robot="cart",
                              log=str(tmp_path / "run.mcap"))
    envs.reset(seed=[1, 2])
    for _ in range(401):  # the 20 s limit: both episodes end and are written
        envs.step(np.tile([0.1, 0.0], (2, 1)).astype(np.float32))
    envs.close()
    first, second = load_run(tmp_path / "run-0.mcap"), load_run(tmp_path / "run-1.mcap")
    assert not (tmp_path / "run.mcap").exists()
    assert (first.metadata.seed, second.metadata.seed) == (1, 2)


def test_a_robot_the_environment_cannot_drive_is_refused(tmp_path: Path) -> None:
    file = tmp_path / "nav.hub"
    save_map(room_grid(), tmp_path / "room.yaml")
    file.write_text('scenario "nav"\nmap "room.yaml"\n'
                    "robot cart at (1, 1) { controller navigator; goal (8, 1) }\n")
    with pytest.raises(InputError, match="must have `controller external`"):
        gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(file), robot="cart")


@pytest.mark.parametrize(("option", "value", "words"), [
    ("max_people", -2, "max_people must be a whole number from 0 to 4,096, not -2"),
    ("max_people", 10**7, "max_people must be a whole number from 0 to 4,096, not 10000000"),
    ("max_people", 2.5, "max_people must be a whole number from 0 to 4,096, not 2.5"),
    ("map_patch", 0, "map_patch must be a whole number from 1 to 2,049, not 0"),
    ("map_patch", 10**6, "map_patch must be a whole number from 1 to 2,049, not 1000000"),
    ("map_patch", True, "map_patch must be a whole number from 1 to 2,049, not True"),
    ("render_size", 10**6, "render_size must be a whole number from 16 to 4,096"),
])
def test_options_that_size_the_arrays_are_bounded(tmp_path: Path, option: str, value: object,
                                                  words: str) -> None:
    # refused when the env is made, before anything is allocated (a million-cell patch
    # would be a terabyte)
    with pytest.raises(InputError, match=words):
        gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(_scenario(tmp_path)), robot="cart",
                       render_mode="rgb_array", **{option: value})


def test_a_vector_envs_copies_and_seeds_are_checked(tmp_path: Path) -> None:
    for copies in (0, 10**6, 2.5):
        with pytest.raises(InputError, match="num_envs must be a whole number from 1 to 4,096"):
            gymnasium.make_vec(hubero_dsl.gym.ENV_ID, num_envs=copies,
                               vectorization_mode="vector_entry_point",
                               scenario=str(_scenario(tmp_path)), robot="cart")
    envs = gymnasium.make_vec(hubero_dsl.gym.ENV_ID, num_envs=3,
                              vectorization_mode="vector_entry_point",
                              scenario=str(_scenario(tmp_path)), robot="cart")
    with pytest.raises(ValueError, match="one seed per copy \\(3\\) or one seed, not a list of 2"):
        envs.reset(seed=[1, 2])
    _, info = envs.reset(seed=(4, 5, 6))  # a tuple, as a list
    assert list(info["seed"]) == [4, 5, 6]
    for loose in (np.zeros(6), np.zeros((3, 1, 2))):  # one row of two per copy, no other shape
        with pytest.raises(ValueError, match="one row of two numbers per copy, 3 x 2"):
            envs.step(loose.astype(np.float32))


def test_the_autoreset_step_tells_the_new_episodes_seed(tmp_path: Path) -> None:
    # gymnasium's own vector envs do, so that an episode that went wrong can be replayed
    envs = gymnasium.make_vec(hubero_dsl.gym.ENV_ID, num_envs=2,
                              vectorization_mode="vector_entry_point",
                              scenario=str(_scenario(tmp_path)), robot="cart")
    envs.reset(seed=3)
    done = np.zeros(2, dtype=bool)
    while not done.any():
        _, _, terminated, truncated, _ = envs.step(np.zeros((2, 2), np.float32))
        done = terminated | truncated
    _, rewards, _, _, info = envs.step(np.zeros((2, 2), np.float32))
    assert info["_seed"].tolist() == done.tolist() and rewards[done].tolist() == [0.0] * done.sum()
    replay = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(_scenario(tmp_path)),
                            robot="cart")
    assert replay.reset(seed=int(info["seed"][done][0]))[1]["seed"] == info["seed"][done][0]


def test_an_ended_or_closed_episode_is_not_stepped_on(tmp_path: Path) -> None:
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(_scenario(tmp_path)), robot="cart",
                         render_mode="rgb_array")
    with pytest.raises(gymnasium.error.ResetNeeded, match="call reset\\(\\) first"):
        env.unwrapped.render()  # it said "before step()"
    env.reset(seed=1)
    terminated = truncated = False
    while not (terminated or truncated):
        _, _, terminated, truncated, _ = env.step(np.zeros(2, np.float32))
    with pytest.raises(gymnasium.error.ResetNeeded, match="the episode has ended"):
        env.step(np.zeros(2, np.float32))   # it went on, and judged the episode again
    env.close()  # closed after an episode that ended: closed, not ended, is what it says
    with pytest.raises(gymnasium.error.ClosedEnvironmentError):
        env.step(np.zeros(2, np.float32))   # it went on simulating


def test_a_goal_reached_to_the_last_bit_is_reached(tmp_path: Path) -> None:
    # 1 m/s for 116 ticks stopped 0.2 m + 4e-15 from the goal: the episode ran to its time
    # limit as a failure, while its metrics said the goal was reached at 5.8 s
    save_map(room_grid(), tmp_path / "room.yaml")
    scenario = tmp_path / "open.hub"
    scenario.write_text('scenario "open"\nmap "room.yaml"\ntime_limit 20 s\n'
                        "robot cart at (1.0, 4.0) { controller external; radius 0.3 m; "
                        "max_speed 1.0 m/s; max_acceleration 100; goal (7.0, 4.0) }\n",
                        encoding="utf-8")
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(scenario), robot="cart")
    env.reset(seed=1)
    info: dict[str, object] = {}
    for step in range(400):
        _, _, terminated, truncated, info = env.step(
            np.array([1.0, 0.0] if step < 116 else [0.0, 0.0], np.float32))
        if terminated or truncated:
            break
    assert info["outcome"] == "reached" and info["is_success"]
    assert info["time"] == pytest.approx(info["metrics"]["time_to_goal"])  # type: ignore[index]


def test_an_episode_can_run_a_variant_of_the_scenario(tmp_path: Path) -> None:
    file = _scenario(tmp_path)
    file.write_text(file.read_text(encoding="utf-8")
                    + "variant brisk { speed 1.7 m/s }\n", encoding="utf-8")
    env = gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(file), robot="cart")
    _, info = env.reset(seed=3, options={"variant": "brisk"})
    assert info["variant"] == "brisk"
    assert (env.unwrapped._sim.engine.humans.speed == 1.7).all()
    _, info = env.reset(seed=3)                       # the next episode: the env's own
    assert info["variant"] is None and (env.unwrapped._sim.engine.humans.speed != 1.7).all()
    with pytest.raises(InputError, match="unknown variant 'slow' \\(variants: brisk\\)"):
        env.reset(options={"variant": "slow"})
    with pytest.raises(InputError, match="takes the option 'variant', not crowd"):
        env.reset(options={"crowd": 3})
    envs = gymnasium.make_vec(hubero_dsl.gym.ENV_ID, num_envs=2,
                              vectorization_mode="vector_entry_point", scenario=str(file),
                              robot="cart")
    envs.reset(seed=0, options={"variant": "brisk"})
    assert all((copy._sim.engine.humans.speed == 1.7).all() for copy in envs.unwrapped.envs)
    # an env made with an unknown variant is refused when made, not at its first reset
    with pytest.raises(InputError, match="unknown variant 'slow'"):
        gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(file), robot="cart", variant="slow")


@pytest.mark.parametrize(("reward", "message"), [
    (hubero_dsl.gym.Reward, r"the class Reward: give an instance of it, reward=Reward\(\)"),
    ("foo", r"reward must be a callable object like Reward\(\), not 'foo'")])
def test_a_reward_that_cannot_be_called_is_refused_when_the_env_is_made(
        tmp_path: Path, reward: object, message: str) -> None:
    with pytest.raises(InputError, match=message):
        gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(_scenario(tmp_path)), robot="cart",
                       reward=reward)


def test_an_env_never_closed_leaves_no_temporary_log(tmp_path: Path) -> None:
    # the program ends with its env open (no close()): the episode's log is unfinished, and
    # its temporary file, hidden beside where the log would be, must not outlive the program
    import subprocess
    import sys

    map_path = Path(__file__).resolve().parents[1] / "maps" / "living_room.yaml"
    script = tmp_path / "left_open.py"
    script.write_text(
        "from hubero_dsl.gym import ScenarioEnv\n"
        "from hubero_dsl.pipeline import compile_source\n"
        f"text = 'scenario \"g\"\\nmap \"{map_path}\"\\nhuman a at (6.3, 2.5)\\n"
        "robot r at (2.0, 0.0) { controller external; goal (3.0, 1.0) }\\n"
        "activity { a move_to (5.5, 1.0) }\\n'\n"
        "env = ScenarioEnv(compile_source(text, 'g.hub'), 'r', log='ep.mcap')\n"
        "env.reset(seed=1)\n"
        "for _ in range(5):\n"
        "    env.step(env.action_space.sample())\n", encoding="utf-8")
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["left_open.py"]


def test_a_log_is_never_written_over_a_users_file(tmp_path: Path) -> None:
    notes = tmp_path / "notes.txt"
    notes.write_text("my notes", encoding="utf-8")
    with pytest.raises(InputError, match="notes.txt exists and is not an MCAP log: not "
                                         r"writing over it \(give another log=\)"):
        gymnasium.make(hubero_dsl.gym.ENV_ID, scenario=str(_scenario(tmp_path)), robot="cart",
                       log=str(notes))
    assert notes.read_text(encoding="utf-8") == "my notes"


def test_a_run_of_the_api_never_writes_its_log_over_a_users_file(tmp_path: Path) -> None:
    from hubero_dsl.pipeline import compile_file
    from hubero_dsl.simulate import simulate

    notes = tmp_path / "notes.mcap"
    notes.write_text("my notes", encoding="utf-8")
    with pytest.raises(InputError, match="is not an MCAP log: not writing over it"):
        simulate(compile_file(_scenario(tmp_path)), log=notes, writer_process=False)
    assert notes.read_text(encoding="utf-8") == "my notes"
