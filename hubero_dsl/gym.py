"""A Gymnasium environment: train or test a robot's policy in any hubero scenario.

    import gymnasium
    import hubero_dsl.gym  # registers hubero/Scenario-v0

    env = gymnasium.make("hubero/Scenario-v0", scenario="scenarios/robot_among_guests.hub",
                         robot="cart")
    observation, info = env.reset(seed=3)
    observation, reward, terminated, truncated, info = env.step(env.action_space.sample())

One episode is one run of the scenario from a seed: the humans do their activities, the robot
named is driven by the actions (the scenario gives it `controller external` and a `goal`).
`reset(seed=...)` runs the scenario with that seed; the same seed and actions give the same
observations; `reset(options={"variant": NAME})` runs that episode with one of the scenario's
variants (a vector env's copies then all start it; its automatic resets keep the env's own).

- Observation (`Dict`): `robot` = (x, y, vx, vy, heading, goal x - x, goal y - y), `people` =
  the `max_people` nearest humans the robot's sensors see (relative x, y, their vx, vy,
  radius), zero-padded, with `mask` 1 for the rows that hold someone; with `map_patch=K`,
  `map` = the K x K occupancy cells around the robot (1 = blocked or unknown), north up.
- Action (`Box(2)`): `(vx, vy)` for a holonomic robot, `(v, omega)` for a unicycle, bounded by
  its `max_speed` (or twice its `speed` when unlimited) and `max_angular_speed` (or pi).
- Reward (`Reward`, pluggable): the default rewards progress towards the goal and arrival, and
  penalises collisions and intrusions into people's intimate and personal space (surface gaps
  below 0.45 m and 1.2 m, HuNavSim's bands, as docs/analysis.md defines them).
- `terminated` when the robot reaches its goal (within `goal_tolerance`) or touches a person;
  `truncated` at the scenario's `time_limit`. The last step's `info` holds the episode's
  `outcome` (reached / collision / time limit; `is_success` for Stable-Baselines3's success
  rate), the robot's social-navigation `metrics` over the episode (`hubero_dsl.socialnav`, as
  for any run; `metrics=False` leaves them out, and the positions they are computed from
  unrecorded) and the expectations' results.
- `render_mode="rgb_array"`: `render()` draws the scene top-down (`analysis.frame`: the map,
  the people, the robot and where it faces, its goal), `render_size` pixels along the map's
  longer side; `gymnasium.wrappers.RecordVideo` records episodes from it at `render_fps`,
  one frame a tick.

`HuberoVectorEnv` (`gymnasium.make_vec(..., vectorization_mode="vector_entry_point")`) steps
`num_envs` episodes of one scenario in one process, with batched observations and automatic
resets (gymnasium's next-step autoreset).

Episodes and copies share the global planners (`GlobalPlanners`): a goal's cost field is
searched once for all of them, and each episode still plans as it would alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import gymnasium
import numpy as np
import numpy.typing as npt
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, concatenate, create_empty_array

from hubero_dsl.analysis.frame import FrameRenderer
from hubero_dsl.errors import InputError
from hubero_dsl.model.program import Program, RobotSpec, unknown_variants
from hubero_dsl.sim.arrays import FloatArray, IntArray
from hubero_dsl.sim.joint import JointSteering
from hubero_dsl.sim.judge import Judge, PlanQuery, Verdict
from hubero_dsl.sim.lockstep import Lockstep, joined
from hubero_dsl.sim.loop import RunResult, summarise, summarise_robots
from hubero_dsl.sim.robots import Robots, in_view
from hubero_dsl.sim.scheduler import RunState
from hubero_dsl.sim.simulation import GlobalPlanners, Simulation
from hubero_dsl.socialnav import CONTACT, GOAL_SLACK

# observation, reward, terminated, truncated, info: what `Env.step` returns
Outcome = tuple[dict[str, npt.NDArray[Any]], float, bool, bool, dict[str, Any]]

ENV_ID = "hubero/Scenario-v0"
RENDER_MODES = ["rgb_array"]
# Bounds of the options that size what the env allocates: the people an observation lists,
# the map patch's side in cells, a frame's longer side in pixels, a vector env's copies.
MAX_PEOPLE_SEEN = 4096
MAX_MAP_PATCH = 2049
MAX_RENDER_SIZE = 4096
MAX_COPIES = 4096
INTIMATE, PERSONAL = 0.45, 1.2   # m, surface gaps (HuNavSim's bands)


class Reward:
    """The default reward; subclass and pass `reward=` to change it.

    Per step: `progress` x metres gained towards the goal, `success` on arrival, `collision`
    (negative) on touching someone, and `intimate` / `personal` (negative) x the step's seconds
    while the nearest person's surface gap is below 0.45 m / within 0.45-1.2 m.
    """

    progress = 1.0
    success = 10.0
    collision = -10.0
    intimate = -1.0
    personal = -0.2

    def __call__(self, gained: float, nearest_gap: float, reached: bool, collided: bool,
                 dt: float) -> float:
        reward = self.progress * gained
        if nearest_gap < INTIMATE:
            reward += self.intimate * dt
        elif nearest_gap < PERSONAL:
            reward += self.personal * dt
        if collided:
            reward += self.collision
        if reached:
            reward += self.success
        return float(reward)


def load_scenario(scenario: str | Path | Program, robot: str) -> tuple[Program, RobotSpec]:
    """The compiled scenario and the robot the environment drives (InputError if unfit)."""
    from hubero_dsl.pipeline import compile_file

    program = scenario if isinstance(scenario, Program) else compile_file(scenario)
    spec = next((r for r in program.robots if r.name == robot), None)
    if spec is None:
        known = ", ".join(r.name for r in program.robots) or "none"
        raise InputError(f"no robot named '{robot}' in the scenario (robots: {known})")
    if spec.controller != "external":
        raise InputError(f"robot '{robot}' must have `controller external` to be driven by "
                         f"the environment (it has controller {spec.controller})")
    if spec.goal is None:
        raise InputError(f"robot '{robot}' needs a `goal` for the environment")
    return program, spec


class ScenarioEnv(gymnasium.Env[dict[str, Any], Any]):
    """One episode at a time of a hubero scenario, the robot driven by the actions."""

    metadata: dict[str, Any] = {"render_modes": RENDER_MODES}  # noqa: RUF012 - gymnasium's API

    def __init__(self, scenario: str | Path | Program, robot: str, *,
                 variant: str | None = None, max_people: int = 8,
                 map_patch: int | None = None, reward: Reward | None = None,
                 log: str | Path | None = None, render_mode: str | None = None,
                 render_size: int = 480, metrics: bool = True) -> None:
        self.program, self.robot_spec = load_scenario(scenario, robot)
        self.render_mode = checked_render_mode(render_mode)
        whole_number("max_people", max_people, 0, MAX_PEOPLE_SEEN)
        if map_patch is not None:
            whole_number("map_patch", map_patch, 1, MAX_MAP_PATCH)
        whole_number("render_size", render_size, 16, MAX_RENDER_SIZE)
        self.metadata = {**self.metadata, "render_fps": 1.0 / self.program.step}
        self._renderer = (FrameRenderer(self.program.grid, render_size)
                          if render_mode is not None else None)
        self.robot_name = robot
        self.metrics = metrics
        self.variant = known_variant(self.program, variant)
        self.max_people = max_people
        self.map_patch = map_patch
        self.reward_function = checked_reward(reward)
        self.log_path = Path(log) if log is not None else None
        if self.log_path is not None:  # told now, not at the first reset
            from hubero_dsl.log.writer import check_log_path

            check_log_path(self.log_path, self.program, "give another log=")
        self.action_box = action_space(self.robot_spec)
        self.action_space = self.action_box
        self._action_bounds = list(zip(self.action_box.low.tolist(),
                                       self.action_box.high.tolist(), strict=True))
        self.observation_space = observation_space(self.program, max_people, map_patch)
        self._sim: Simulation | None = None
        self._judge: Judge | None = None
        self._log: Any = None
        self._ended = False   # the episode ended: step() needs a reset() first
        self._closed = False
        # episodes (and a vector env's copies) share the planners' cached fields and the
        # reference plans of the metrics' plan efficiency
        self._planners = GlobalPlanners()
        self._plan_lengths: dict[PlanQuery, float | None] = {}

    # ---- the Env API -------------------------------------------------------------------------

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, npt.NDArray[Any]], dict[str, Any]]:
        self._refuse_closed()
        super().reset(seed=seed)
        self._drop_log()
        self._ended = False
        run_seed = seed if seed is not None else int(self.np_random.integers(2**31))
        variant = self._variant_of(options)
        sim = Simulation(self.program, variant=variant, seed=run_seed, planners=self._planners)
        self._robot = sim.robot(self.robot_name)
        self._sim = sim
        self._judge = Judge(sim, record_tracks=self.metrics, plan_lengths=self._plan_lengths)
        self._last_tick = sim.engine.ticks(self.program.time_limit)
        senses = sense([sim], self.robot_spec, self.max_people)
        self._distance = self._goal_distance(senses, 0)
        if self.log_path is not None:
            from hubero_dsl.log.writer import RunLog

            self._log = RunLog(self.log_path, sim, writer_process=False)
            self._log.open()
        return self._observation(senses, 0), {"seed": run_seed, "variant": variant}

    def _variant_of(self, options: dict[str, Any] | None) -> str | None:
        """The variant of the episode `reset(options=...)` starts: `{"variant": NAME}` (None
        for the scenario as written), else the env's own."""
        unknown = sorted(set(options or {}) - {"variant"})
        if unknown:
            raise InputError(f"reset() takes the option 'variant', not {', '.join(unknown)}")
        if options is None or "variant" not in options:
            return self.variant
        return known_variant(self.program, options["variant"])

    def step(self, action: npt.NDArray[np.float32]) -> Outcome:
        self._refuse_closed()
        if self._ended:
            raise gymnasium.error.ResetNeeded("the episode has ended: call reset() before "
                                              "step()")
        self._act(action)
        sim = self._simulation()
        sim.step()
        return self._outcome(sense([sim], self.robot_spec, self.max_people), 0)

    def render(self) -> npt.NDArray[np.uint8] | None:
        """The scene now as an RGB array (`render_mode="rgb_array"`), else None."""
        if self._renderer is None:
            _warn_not_rendered()
            return None
        return self._frame()

    def _frame(self) -> npt.NDArray[np.uint8]:
        assert self._renderer is not None
        spec = self.robot_spec
        return self._renderer.draw(self._simulation(), self.robot_name, spec.goal,
                                   spec.goal_tolerance)

    def close(self) -> None:
        self._drop_log()
        self._closed = True
        super().close()

    def _refuse_closed(self) -> None:
        if self._closed:
            raise gymnasium.error.ClosedEnvironmentError("the environment is closed")

    # ---- a step in two parts, around the world's tick (a vector env ticks its copies together)

    def _simulation(self) -> Simulation:
        self._refuse_closed()
        if self._sim is None:
            raise gymnasium.error.ResetNeeded("call reset() first")
        return self._sim

    def _act(self, action: npt.NDArray[np.float32]) -> None:
        """Hand the robot the action for the coming tick (the controller is not asked)."""
        given = real_numbers(action, "an action is two finite numbers")
        if given.shape != (2,):  # the action space's shape: (1, 2) or (2, 1) are no actions
            raise ValueError(f"an action is two finite numbers, not {action!r} (an array "
                             f"of shape {given.shape}; the action space's is (2,))")
        self._act_floats(given.reshape(2).tolist(), action)

    def _act_floats(self, action: list[float], given: object) -> None:
        """`_act` with the action as two floats (`given`: as the caller gave it)."""
        self._simulation()
        first, second = action
        if not (math.isfinite(first) and math.isfinite(second)):
            raise ValueError(f"an action is two finite numbers, not {given!r}")
        (low_1, high_1), (low_2, high_2) = self._action_bounds  # the box's clipping, in floats
        self._robot.drive(min(max(first, low_1), high_1), min(max(second, low_2), high_2))

    def _outcome(self, senses: Senses, index: int) -> Outcome:
        """What the tick just made gives: observation, reward, whether and how it ended
        (`senses`: what the robot sees now, row `index` of them)."""
        return (self._observation(senses, index), *self._ending(senses, index))

    def _ending(self, senses: Senses, index: int) -> tuple[float, bool, bool, dict[str, Any]]:
        """The tick's reward, whether and how the episode ended (`_outcome` without the
        observation, which a vector env takes from `senses` for all its copies at once)."""
        sim = self._simulation()
        if self._log is not None:
            self._log.observe(sim)
        distance = self._goal_distance(senses, index)
        gained, self._distance = self._distance - distance, distance
        gap = float(senses.gap[index])
        # as the metrics and `reaches` judge it: rounding does not leave a reached goal out
        reached = distance <= self.robot_spec.goal_tolerance + GOAL_SLACK
        collided = gap < CONTACT
        assert self._judge is not None
        self._judge.observe()
        self._judge.record()
        truncated = sim.tick >= self._last_tick
        terminated = reached or collided
        reward = self.reward_function(gained, gap, reached, collided, sim.dt)
        info: dict[str, Any] = {}
        if terminated or truncated:
            outcome = "reached" if reached else "collision" if collided else "time limit"
            info, verdicts = self._episode_info(outcome)
            self._ended = True
            if self._log is not None:
                log, self._log = self._log, None
                log.close(self._episode_result(outcome, verdicts))
        return reward, terminated, truncated, info

    # ---- observations ------------------------------------------------------------------------

    def _observation(self, senses: Senses, index: int) -> dict[str, npt.NDArray[Any]]:
        assert self._sim is not None
        return senses.observation(index, self._sim, self.map_patch)

    def _goal_distance(self, senses: Senses, index: int) -> float:
        assert self.robot_spec.goal is not None
        return math.dist(senses.places[index], self.robot_spec.goal)

    # ---- the end of an episode ---------------------------------------------------------------

    def _episode_info(self, outcome: str) -> tuple[dict[str, Any], list[Verdict]]:
        """How the episode ended, the robot's social-navigation metrics over it (as
        docs/analysis.md defines them) and the scenario's expectations, judged (as `info`,
        and the verdicts themselves, for the episode's log)."""
        sim, judge = self._sim, self._judge
        assert sim is not None and judge is not None
        verdicts = judge.finish()
        info = {"outcome": outcome, "is_success": outcome == "reached", "time": sim.time,
                "expectations": {v.text: bool(v.held) for v in verdicts}}
        if self.metrics and judge.tracks is not None:
            info["metrics"] = judge.tracks.metrics(sim, self.robot_name)
        return info, verdicts

    def _episode_result(self, outcome: str, verdicts: list[Verdict]) -> RunResult:
        """How the episode ended, as a run's result, for its log (`hubero diff` and `plot`
        read it as a run's): reached is a completed run, a collision a failed one."""
        sim = self._sim
        assert sim is not None
        state, reason = {
            "reached": (RunState.COMPLETED, f"robot '{self.robot_name}' reached its goal"),
            "collision": (RunState.FAILED, f"robot '{self.robot_name}' collided"),
        }.get(outcome, (RunState.TIMED_OUT, "the time limit"))
        return RunResult(state, reason, sim.time, sim.tick, sim.variant, sim.seed,
                         list(sim.events), verdicts, summarise(sim), summarise_robots(sim))

    def _drop_log(self) -> None:
        """An episode's log that did not end (reset, closed) is dropped, not left half."""
        if self._log is None:
            return
        self._log._discard()
        self._log = None


def _warn_not_rendered() -> None:
    gymnasium.logger.warn("render() needs render_mode='rgb_array' when the environment is "
                          "made; it draws nothing")


def known_variant(program: Program, variant: object) -> str | None:
    """`variant` when the scenario has it (or None, the scenario as written); else InputError."""
    if variant is not None and (not isinstance(variant, str) or variant not in program.variants):
        raise InputError(unknown_variants([variant], program.variants))
    return variant


def checked_reward(reward: object) -> Reward:
    """The reward an env computes: `reward` when it is one (an object called with the step's
    facts, like `Reward()`), else InputError; `Reward()` for None."""
    if reward is None:
        return Reward()
    if isinstance(reward, type):
        raise InputError(f"reward is the class {reward.__name__}: give an instance of it, "
                         f"reward={reward.__name__}()")
    if not callable(reward):
        raise InputError(f"reward must be a callable object like Reward(), not {reward!r:.60}")
    return cast(Reward, reward)


def whole_number(name: str, value: object, low: int, high: int) -> None:
    """InputError unless `value` is an int from `low` to `high` (an option of the env: the
    arrays it sizes are allocated at once)."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) \
            or not low <= value <= high:
        raise InputError(f"{name} must be a whole number from {low:,} to {high:,}, "
                         f"not {value!r}")


def checked_render_mode(render_mode: str | None) -> str | None:
    if render_mode not in (None, *RENDER_MODES):
        raise InputError(f"render_mode must be one of {', '.join(RENDER_MODES)} or None, "
                         f"not {render_mode!r}")
    return render_mode


def action_space(spec: RobotSpec) -> spaces.Box:
    top = spec.max_speed if math.isfinite(spec.max_speed) else 2.0 * spec.speed
    if spec.kinematics == "holonomic":
        return spaces.Box(-top, top, shape=(2,), dtype=np.float32)
    turn = spec.max_angular_speed if math.isfinite(spec.max_angular_speed) else math.pi
    return spaces.Box(np.array([-top, -turn], dtype=np.float32),
                      np.array([top, turn], dtype=np.float32), dtype=np.float32)


SPEED_BOUND = 20.0  # m/s: no body of a scenario moves faster


def observation_space(program: Program, max_people: int, map_patch: int | None) -> spaces.Dict:
    """Bounded by the map: positions within it, offsets within its diagonal."""
    grid = program.grid
    x0, y0, x1, y1 = grid.bounds
    reach = float(math.hypot(x1 - x0, y1 - y0))
    robot_low = np.array([x0, y0, -SPEED_BOUND, -SPEED_BOUND, -math.pi, -reach, -reach])
    robot_high = np.array([x1, y1, SPEED_BOUND, SPEED_BOUND, math.pi, reach, reach])
    person_low = np.tile([-reach, -reach, -SPEED_BOUND, -SPEED_BOUND, 0.0], (max_people, 1))
    person_high = np.tile([reach, reach, SPEED_BOUND, SPEED_BOUND, 5.0], (max_people, 1))
    entries: dict[str, spaces.Space[Any]] = {
        "robot": spaces.Box(robot_low.astype(np.float32), robot_high.astype(np.float32),
                            dtype=np.float32),
        "people": spaces.Box(person_low.astype(np.float32), person_high.astype(np.float32),
                             dtype=np.float32),
        "mask": spaces.Box(0, 1, shape=(max_people,), dtype=np.int8),
    }
    if map_patch is not None:
        entries["map"] = spaces.Box(0, 1, shape=(map_patch, map_patch), dtype=np.int8)
    return spaces.Dict(entries)


@dataclass(slots=True)
class Senses:
    """What the robots of several episodes see now, as their observations lay it out (row i:
    episode i): `robot` (E, 7), `people` (E, max_people, 5) and `mask` (E, max_people), and
    `gap`, the smallest surface gap between each robot and a person (inf: nobody there);
    `places`, each robot's (x, y), unrounded."""

    robot: npt.NDArray[np.float32]
    people: npt.NDArray[np.float32]
    mask: npt.NDArray[np.int8]
    gap: FloatArray
    places: list[list[float]]

    def observation(self, index: int, sim: Simulation, map_patch: int | None
                    ) -> dict[str, npt.NDArray[Any]]:
        """Episode `index`'s observation (`sim`: its simulation, for the map patch)."""
        observation = {"robot": self.robot[index], "people": self.people[index],
                       "mask": self.mask[index]}
        if map_patch is not None:
            x, y = self.places[index]
            observation["map"] = _patch(sim, (x, y), map_patch)
        return observation


def sense(sims: list[Simulation], spec: RobotSpec, max_people: int) -> Senses:
    """What robot `spec` sees now in each simulation (one scenario's episodes, all at once):
    itself and its goal, and the `max_people` nearest humans within its sensor range and
    field of view (`Robots.seen_rows`), nearest first; every episode's rows as alone."""
    episodes = len(sims)
    states = [_robot_state(sim.engine.robots, spec.name) for sim in sims]  # x, y, vx, vy, h
    assert spec.goal is not None
    goal_x, goal_y = spec.goal
    robot = np.array([[*state, goal_x - state[0], goal_y - state[1]] for state in states],
                     dtype=np.float32)
    places = [state[:2] for state in states]
    here = np.array(places)
    humans = [sim.engine.humans for sim in sims]
    counts = [h.count for h in humans]
    world = (np.zeros(counts[0], dtype=np.intp) if episodes == 1
             else np.repeat(np.arange(episodes), counts))
    position = joined([h.position for h in humans])
    radius = joined([h.radius for h in humans])
    offset = position - (here if episodes == 1 else here[world])  # one robot: broadcast
    distance = np.hypot(offset[:, 0], offset[:, 1])
    surface = distance - radius
    gap = _nearest_gaps(surface, counts) - spec.radius
    seen, rank = _nearest_seen(offset, distance, surface, world, states, spec, max_people)
    # row `max_people * episode + rank` of the flattened arrays: one index per person seen
    people = np.zeros((episodes * max_people, 5), dtype=np.float32)
    mask = np.zeros(episodes * max_people, dtype=np.int8)
    if len(seen):
        slot = slice(0, len(seen)) if episodes == 1 else world[seen] * max_people + rank
        people[slot, 0:2] = offset[seen]
        people[slot, 2:4] = joined([h.velocity for h in humans])[seen]
        people[slot, 4] = radius[seen]
        mask[slot] = 1
    return Senses(robot, people.reshape(episodes, max_people, 5),
                  mask.reshape(episodes, max_people), gap, places)


def _robot_state(robots: Robots, name: str) -> list[float]:
    """x, y, vx, vy, heading of robot `name`, as floats."""
    i = robots.index_of(name)
    return [*robots.position[i].tolist(), *robots.velocity[i].tolist(), float(robots.heading[i])]


def _nearest_gaps(surface: FloatArray, counts: list[int]) -> FloatArray:
    """The smallest of each episode's `surface` gaps (its `counts` rows; inf: none)."""
    if len(counts) == 1:
        return surface.min(keepdims=True) if counts[0] else np.array([math.inf])
    gap = np.full(len(counts), math.inf)
    someone = np.flatnonzero(counts)
    if len(someone):
        gap[someone] = np.minimum.reduceat(surface, np.cumsum([0, *counts])[someone])
    return gap


def _nearest_seen(offset: FloatArray, distance: FloatArray, surface: FloatArray,
                  world: IntArray, states: list[list[float]], spec: RobotSpec, max_people: int
                  ) -> tuple[IntArray, IntArray]:
    """The rows each robot sees (within its sensor range and field of view), nearest first
    and at most `max_people` of each episode (`world`), and each one's rank among them
    (`states`: each robot's `_robot_state`)."""
    heading = (states[0][4] if len(states) == 1
               else np.array([state[4] for state in states])[world])
    visible = in_view(spec, offset, surface, heading)
    rows = visible.nonzero()[0]
    if len(states) == 1:  # one episode: nearest first, its rank its place
        if len(rows) > 1:
            rows = rows[np.argsort(distance[rows], kind="stable")][:max_people]
        return rows, np.arange(len(rows))
    rows = rows[np.lexsort((distance[rows], world[rows]))]  # by episode, then nearest first
    worlds = world[rows]
    rank = np.arange(len(rows)) - np.searchsorted(worlds, worlds)
    kept = rank < max_people
    return rows[kept], rank[kept]


def _patch(sim: Simulation, centre: tuple[float, float], size: int) -> npt.NDArray[np.int8]:
    """The size x size cells around `centre` (1: blocked or unknown or off the map), north up."""
    grid = sim.program.grid
    (row, col), = grid.world_to_cell([centre])
    half = size // 2
    blocked = grid.occupied  # unknown cells included
    out = np.ones((size, size), dtype=np.int8)
    rows = np.arange(row - half, row - half + size)
    cols = np.arange(col - half, col - half + size)
    inside_r = (rows >= 0) & (rows < blocked.shape[0])
    inside_c = (cols >= 0) & (cols < blocked.shape[1])
    out[np.ix_(inside_r, inside_c)] = blocked[np.ix_(rows[inside_r], cols[inside_c])]
    return out[::-1]  # grid row 0 is the lowest y; the patch's first row is the northmost


def real_numbers(given: object, words: str) -> npt.NDArray[np.float64]:
    """`given` as an array of floats; ValueError (`words`, and what it was) for anything but
    real numbers: None, strings, complex numbers, booleans."""
    try:
        array = np.asarray(given)
    except (ValueError, TypeError):  # ragged sequences
        array = np.asarray(None)
    if array.dtype.kind not in "iuf":
        raise ValueError(f"{words}, not {given!r}")
    return array.astype(np.float64)


def copy_log(log: str | Path | None, index: int, copies: int) -> Path | None:
    """Where copy `index` of a vector env writes its episodes: `run.mcap` becomes
    `run-0.mcap`, `run-1.mcap`, ... (one copy keeps the name as given)."""
    if log is None:
        return None
    path = Path(log)
    return path if copies == 1 else path.with_name(f"{path.stem}-{index}{path.suffix}")


class HuberoVectorEnv(VectorEnv[dict[str, Any], Any, Any]):
    """`num_envs` episodes of one scenario in one process, batched, with next-step autoreset."""

    metadata: dict[str, Any] = {  # noqa: RUF012 - gymnasium's own API
        "render_modes": RENDER_MODES, "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, scenario: str | Path | Program, robot: str, num_envs: int = 1,
                 **options: Any) -> None:
        program, _ = load_scenario(scenario, robot)
        whole_number("num_envs", num_envs, 1, MAX_COPIES)
        self.num_envs = num_envs
        log = options.pop("log", None)
        self.envs = [ScenarioEnv(program, robot, log=copy_log(log, i, num_envs), **options)
                     for i in range(num_envs)]
        first = self.envs[0]
        for env in self.envs[1:]:  # one set of planners' fields and one drawn map for all
            env._planners, env._renderer = first._planners, first._renderer
            env._plan_lengths = first._plan_lengths
        self.render_mode = first.render_mode
        self.metadata = {**self.metadata, "render_fps": first.metadata["render_fps"]}
        self.single_action_space = self.envs[0].action_space
        self.single_observation_space = self.envs[0].observation_space
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self._done = np.zeros(num_envs, dtype=bool)
        self._steering = JointSteering()
        self._lockstep = Lockstep()

    def reset(self, *, seed: int | list[int] | None = None, options: dict[str, Any] | None = None
              ) -> tuple[dict[str, npt.NDArray[Any]], dict[str, Any]]:
        super().reset(seed=seed if isinstance(seed, int) else None)
        if isinstance(seed, list | tuple) and len(seed) != self.num_envs:
            raise ValueError(f"reset() takes one seed per copy ({self.num_envs}) or one "
                             f"seed, not a list of {len(seed)}")
        seeds = list(seed) if isinstance(seed, list | tuple) else [
            None if seed is None else seed + i for i in range(self.num_envs)]
        observations: list[dict[str, npt.NDArray[Any]]] = []
        infos: dict[str, Any] = {}
        for i, (env, s) in enumerate(zip(self.envs, seeds, strict=True)):
            observation, info = env.reset(seed=s, options=options)
            observations.append(observation)
            infos = self._add_info(infos, info, i)  # each copy's seed and variant
        self._done[:] = False
        batch = self._empty_observations()
        concatenate(self.single_observation_space, observations, batch)  # fills `batch`
        return batch, infos

    def step(self, actions: npt.NDArray[np.float32]
             ) -> tuple[dict[str, npt.NDArray[Any]], npt.NDArray[np.float64],
                        npt.NDArray[np.bool_], npt.NDArray[np.bool_], dict[str, Any]]:
        going = np.flatnonzero(~self._done).tolist()
        senses = self._tick(actions, going)
        observations = self._observations(senses, going)
        rewards = np.zeros(self.num_envs)
        terminated = np.zeros(self.num_envs, dtype=bool)
        truncated = np.zeros(self.num_envs, dtype=bool)
        infos: dict[str, Any] = {}
        if senses is not None:
            for row, i in enumerate(going):
                rewards[i], terminated[i], truncated[i], info = self.envs[i]._ending(senses,
                                                                                     row)
                if info:
                    infos = self._add_info(infos, info, i)
        for i in np.flatnonzero(self._done).tolist():
            # next-step autoreset: this step only resets the episode (its seed and variant in
            # the infos, as gymnasium's own vector envs give them)
            observation, info = self.envs[i].reset()
            for key, value in observation.items():
                observations[key][i] = value
            infos = self._add_info(infos, info, i)
        self._done = terminated | truncated
        return observations, rewards, terminated, truncated, infos

    def _tick(self, actions: npt.NDArray[np.float32], going: list[int]) -> Senses | None:
        """One tick of the copies whose episodes go on (`going`), their array work done for
        all of them at once (`Lockstep`, `JointSteering`, `sense`): what their robots see
        (None: no episode goes on)."""
        given = real_numbers(actions, "actions are one row of two numbers per copy")
        if given.shape != (self.num_envs, 2):
            raise ValueError(f"actions are one row of two numbers per copy, "
                             f"{self.num_envs} x 2, not an array of shape {given.shape}")
        rows = given.reshape(self.num_envs, 2).tolist()
        envs = [self.envs[i] for i in going]
        for i, env in zip(going, envs, strict=True):
            env._act_floats(rows[i], actions[i])
        sims = [env._simulation() for env in envs]
        if not sims:
            return None
        steerings = Simulation.begin_steps(sims, self._lockstep)
        steered = self._steering.steer([sim.engine for sim in sims], steerings)
        Simulation.end_steps(sims, steerings, steered, self._lockstep)
        return sense(sims, self.envs[0].robot_spec, self.envs[0].max_people)

    def _observations(self, senses: Senses | None, going: list[int]
                      ) -> dict[str, npt.NDArray[Any]]:
        """Every copy's observation, one array per key: the going copies' rows from `senses`,
        the others' zero until their resets fill them."""
        seen: dict[str, npt.NDArray[Any]] = {}
        if senses is not None:
            seen = {"robot": senses.robot, "people": senses.people, "mask": senses.mask}
            size = self.envs[0].map_patch
            if size is not None:
                seen["map"] = np.stack([_patch(self.envs[i]._simulation(), (x, y), size)
                                        for i, (x, y) in zip(going, senses.places,
                                                             strict=True)])
            if len(going) == self.num_envs:
                return seen
        observations = self._empty_observations()
        for key, array in seen.items():
            observations[key][going] = array
        return observations

    def _empty_observations(self) -> dict[str, npt.NDArray[Any]]:
        empty = create_empty_array(self.single_observation_space, self.num_envs, fn=np.zeros)
        assert isinstance(empty, dict)
        return empty

    def render(self) -> tuple[npt.NDArray[np.uint8], ...] | None:
        """Each copy's scene now (`render_mode="rgb_array"`), else None."""
        if self.render_mode is None:
            _warn_not_rendered()
            return None
        return tuple(env._frame() for env in self.envs)

    def close_extras(self, **kwargs: Any) -> None:
        for env in self.envs:
            env.close()


gymnasium.register(id=ENV_ID, entry_point="hubero_dsl.gym:ScenarioEnv",
                   vector_entry_point="hubero_dsl.gym:HuberoVectorEnv")
