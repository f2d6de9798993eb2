"""`Simulation`: a checked program brought to life — humans, robots, planners and the clock.

    sim = Simulation(program, variant="ellipse", seed=3)
    task = sim.human("actor1").move_to((0.6, -2.0), heading=math.radians(-135))
    sim.run_until(lambda: task.done)

With `activities=True` (the default) the scenario's own activities are executed by the
scheduler through the same API; with `activities=False` the caller commands everyone.

Robots are driven by the controllers their declarations name (`controller navigator`), built
from the controller registry; `controllers={"cart": MyController}` hands a robot to a class (or
an instance) of the caller's instead, as `hubero run --controller cart=my_pkg:Planner` does.
"""

from __future__ import annotations

import dataclasses
import itertools
import zlib
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from pydantic import ValidationError

from hubero_dsl.errors import OUTSIDE_STOPS, InputError, SimulationError, failure_of
from hubero_dsl.model.params import HUMAN_PARAMS, REACTIONS, SEED_DIGITS, ParamKind
from hubero_dsl.model.program import (
    Distribution,
    ParamValue,
    Pose,
    Program,
    RobotSpec,
    unknown_variants,
)
from hubero_dsl.planners.base import GlobalPlanner, LocalPlanner, PlannerParams
from hubero_dsl.planners.guard import PlannerError, built, guarded_global, guarded_local
from hubero_dsl.planners.registry import global_planner, local_planner
from hubero_dsl.sim.arrays import FloatArray, HumanArrays
from hubero_dsl.sim.conditions import Conditions, LabelBook
from hubero_dsl.sim.engine import Engine, Steering
from hubero_dsl.sim.flows import Flows
from hubero_dsl.sim.handles import HumanHandle, RobotHandle
from hubero_dsl.sim.lockstep import Lockstep
from hubero_dsl.sim.robots import Robots, robot_body
from hubero_dsl.sim.scheduler import Scheduler
from hubero_dsl.sim.status import TaskEvent, TaskHandle
from hubero_dsl.world.scatter import crowd_places
from hubero_dsl.world.shapes import Shape, ShapeArrays

if TYPE_CHECKING:
    from hubero_dsl.controllers.base import ControllerParams, RobotController
    from hubero_dsl.diagnostics import Span
    from hubero_dsl.model.tasks import Task


def stable_seed(*parts: int | str) -> list[int]:
    """Seed material that does not depend on PYTHONHASHSEED or the order of humans."""
    return [p if isinstance(p, int) else zlib.crc32(p.encode()) for p in parts]


def draw_params(program: Program, variant: str | None,
                seed: int) -> dict[str, dict[str, ParamValue]]:
    """Every human's parameters for one run: distributions drawn once per human from the seed."""
    drawn: dict[str, dict[str, ParamValue]] = {}
    for name, values in program.resolved_params(variant).items():
        concrete: dict[str, ParamValue] = {}
        for key in sorted(values):
            value = values[key]
            if isinstance(value, Distribution):
                rng = np.random.default_rng(stable_seed(seed, "param", name, key))
                value = _draw(value, rng, key)
            concrete[key] = value
        drawn[name] = concrete
    return drawn


def _draw(distribution: Distribution, rng: np.random.Generator, key: str) -> float:
    if distribution.kind == "uniform":
        return float(rng.uniform(distribution.first, distribution.second))
    value = float(rng.normal(distribution.first, distribution.second))
    spec = HUMAN_PARAMS.get(key)
    if spec is not None and spec.positive:  # a speed of -0.1 m/s is no person: truncate
        value = max(value, 0.1 * distribution.first)
    return value


PlannerKey = tuple[str, tuple[tuple[str, float], ...]]


class GlobalPlanners:
    """Global planners kept across the runs of one program (a gym environment's episodes and
    copies), so that a goal's cost field is searched once, not once a run.

    Only planners whose class offers `for_sharing` are kept: their plans do not depend on the
    queries before them, so every run plans exactly as it would alone. Other planners are
    built afresh for each run.
    """

    def __init__(self) -> None:
        self._kept: dict[PlannerKey, GlobalPlanner] = {}
        self._grid: object = None

    def build(self, program: Program, key: PlannerKey) -> GlobalPlanner:
        if program.grid is not self._grid:  # planners serve the map they were built on
            self._kept.clear()
            self._grid = program.grid
        kept = self._kept.get(key)
        if kept is not None:
            return kept
        planner, shared = _new_global_planner(program, key, sharing=True)
        if shared:
            self._kept[key] = planner
        return planner


class Simulation:
    """A run of one program variant with one seed. Deterministic: same inputs, same run."""

    def __init__(self, program: Program, *, variant: str | None = None, seed: int | None = None,
                 activities: bool = True,
                 controllers: Mapping[str, type | RobotController] | None = None,
                 planners: GlobalPlanners | None = None) -> None:
        if variant is not None and variant not in program.variants:
            raise SimulationError(unknown_variants([variant], program.variants))
        if seed is not None and (not isinstance(seed, int | np.integer)
                                 or isinstance(seed, bool) or not 0 <= seed < 10 ** SEED_DIGITS):
            raise SimulationError(f"a seed is a whole number from 0 to {SEED_DIGITS} digits, "
                                  f"not {seed!r:.40}")
        self.seed = program.seed if seed is None else int(seed)
        self.program = program = crowds_placed(program, self.seed)
        self.variant = variant
        self.params = draw_params(program, variant, self.seed)
        self._shared_planners = planners
        self.engine = self._build_engine(build_controllers(program, controllers or {}))
        self._lockstep = Lockstep()  # the engine's tick, array by array
        self._ids = itertools.count(1)
        places = {name: pose.xy for name, pose in program.places.items()}
        self._humans = {name: HumanHandle(self.engine, name, places, self._ids)
                        for name in program.human_names}
        self._robots = {spec.name: RobotHandle(self.engine, spec.name, places, self._ids)
                        for spec in program.robots}
        self.scheduler: Scheduler | None = None
        if activities:
            self.scheduler = Scheduler(program.graph, self.engine, self._command,
                                       program.time_limit, program.on_failure)
        self.flows = self._build_flows() if program.flows else None

    # ---- the API ---------------------------------------------------------------------------

    @property
    def time(self) -> float:
        return self.engine.time

    @property
    def tick(self) -> int:
        return self.engine.tick

    @property
    def dt(self) -> float:
        return self.engine.dt

    @property
    def events(self) -> list[TaskEvent]:
        """Every task status change so far, in order."""
        return self.engine.events

    def human(self, name: str) -> HumanHandle:
        try:
            return self._humans[name]
        except KeyError:
            raise SimulationError(f"no human named '{name}'") from None

    @property
    def humans(self) -> list[HumanHandle]:
        return list(self._humans.values())

    def robot(self, name: str) -> RobotHandle:
        try:
            return self._robots[name]
        except KeyError:
            raise SimulationError(f"no robot named '{name}'") from None

    @property
    def robots(self) -> list[RobotHandle]:
        return list(self._robots.values())

    def set_robot_velocity(self, name: str, vx: float, vy: float) -> None:
        """Drive robot `name` at (vx, vy) from now on (see `RobotHandle.set_velocity`)."""
        self.robot(name).set_velocity(vx, vy)

    def remove(self, name: str) -> None:
        """Make a human or robot unknown as a target: tasks that face or follow it lose it
        (they are aborted as 'disappeared'; a `move_to` under way walks on to where it was
        when it began). Its body stays where it is, an obstacle to the others, and it takes no
        more tasks; taking bodies out of the physics comes with flows of people."""
        if name not in self._humans and name not in self._robots:
            raise SimulationError(f"no human or robot named '{name}' to remove")
        self.engine.removed.add(name)

    def _command(self, actor: str, task: Task, span: Span | None) -> TaskHandle:
        """How the scheduler gives a scenario's task: through the same API as any caller,
        with the span of the step that gave it."""
        actor_handle = self._robots.get(actor) or self.human(actor)
        return actor_handle.give(dataclasses.replace(task, span=span))

    def step(self) -> None:
        """Advance one tick: the scheduler reacts to the world, then the world moves."""
        try:
            steering = self.begin_step()
            self.end_step(steering, self.engine.steer(steering))
        except PlannerError as exc:
            raise exc.at(self.time) from None

    def begin_step(self) -> Steering | None:
        """`step` up to the local planners (`Lockstep.begin_step`); `end_step` finishes it."""
        return Simulation.begin_steps([self], self._lockstep)[0]

    def end_step(self, steering: Steering | None, steered: list[FloatArray]) -> None:
        """The rest of `step`, given the local planners' answers (`Engine.steer`)."""
        Simulation.end_steps([self], [steering], [steered], self._lockstep)

    @staticmethod
    def begin_steps(sims: list[Simulation], lockstep: Lockstep) -> list[Steering | None]:
        """`begin_step` of simulations of one scenario, their engines' ticks begun together
        by `lockstep`: what each would do alone."""
        for sim in sims:
            if sim.scheduler is not None:
                sim.scheduler.update()
            sim._update_flows()
        return lockstep.begin_step([sim.engine for sim in sims])

    @staticmethod
    def end_steps(sims: list[Simulation], steerings: list[Steering | None],
                  steered: list[list[FloatArray]], lockstep: Lockstep) -> None:
        """`end_step` of simulations of one scenario, their engines' ticks ended together
        by `lockstep`: what each would do alone."""
        lockstep.end_step([sim.engine for sim in sims], steerings, steered)
        for sim in sims:
            if sim.scheduler is not None:
                sim.scheduler.after_step()

    def advance(self) -> None:
        """The world's part of a tick: flows bring people in and see them off, then everyone
        moves."""
        self._update_flows()
        engines = [self.engine]
        steering = self._lockstep.begin_step(engines)[0]
        self._lockstep.end_step(engines, [steering], [self.engine.steer(steering)])

    def _update_flows(self) -> None:
        if self.flows is not None:
            self.flows.update()

    def run_until(self, done: Callable[[], bool], *, time_limit: float | None = None) -> bool:
        """Step until `done()` holds (True) or the time limit passes (False)."""
        limit = self.program.time_limit if time_limit is None else time_limit
        last_tick = self.engine.ticks(limit)
        while not done():
            if self.tick >= last_tick:
                return False
            self.step()
        return True

    # ---- building --------------------------------------------------------------------------

    def _build_flows(self) -> Flows:
        """The flows, judging `until` with the scheduler's labels when there is one."""
        conditions = self.scheduler.conditions if self.scheduler is not None \
            else Conditions(self.engine, LabelBook())
        seed = self.seed
        flows = Flows(self.program.flows, self.engine,
                      lambda name: np.random.default_rng(stable_seed(seed, "flow", name)),
                      lambda name, task: self._humans[name].give(task), conditions.holds,
                      self.program.time_limit)
        conditions.flows = flows
        if self.scheduler is not None:
            self.scheduler.keep_alive = flows.keeps_alive
        return flows

    def _build_engine(self, controllers: dict[str, RobotController]) -> Engine:
        program, params = self.program, self.params
        names = program.human_names
        humans = _human_arrays(program, params)
        planners_by_key: dict[PlannerKey, GlobalPlanner] = {}
        global_of: list[GlobalPlanner] = []
        for name in names:
            planner_name = str(params[name]["global_planner"])
            own = _planner_values(params[name], planner_name)
            key = (planner_name, tuple(sorted(own.items())))
            if key not in planners_by_key:
                planners_by_key[key] = self._global_planner(key)
            global_of.append(planners_by_key[key])
        robots = Robots(program.robots, program.grid, program.step, controllers)
        local_of = [str(params[n]["local_planner"]) for n in names]
        local = {planner_name: _local_planner(program, params, planner_name, robots.count)
                 for planner_name in sorted(set(local_of))}
        follow_replan = np.array([float(params[n]["follow_replan"]) for n in names])  # type: ignore[arg-type]
        seed = self.seed
        return Engine(grid=program.grid, humans=humans, robots=robots, dt=program.step,
                      global_planners=global_of, local_planners=local, local_planner_of=local_of,
                      follow_replan=follow_replan,
                      groups={name: np.array([names.index(m) for m in members], dtype=np.intp)
                              for name, members in program.groups.items()},
                      rng_for=lambda purpose, i: np.random.default_rng(
                          stable_seed(seed, purpose, names[i])))


    def _global_planner(self, key: PlannerKey) -> GlobalPlanner:
        if self._shared_planners is not None:
            return self._shared_planners.build(self.program, key)
        return _new_global_planner(self.program, key, sharing=False)[0]


def _new_global_planner(program: Program, key: PlannerKey, *,
                       sharing: bool) -> tuple[GlobalPlanner, bool]:
    """A new global planner for `key` (a name and its parameters) on the program's map, and
    whether it may be shared: built by its class's `for_sharing` when `sharing` asks for it
    and the class offers it. A plugin's failures are told as its own (`guard`)."""
    cls = global_planner(key[0])
    params = cls.Params.model_validate(dict(key[1]))
    share = getattr(cls, "for_sharing", None) if sharing else None
    build = cls if share is None else share
    planner = built("global", key[0], lambda: build(program.grid, params))
    return guarded_global(planner, key[0], program.grid), share is not None


def crowds_placed(program: Program, seed: int) -> Program:
    """`program` with its crowds placed by `seed`: each seed starts a crowd at places of its
    own, as each draws its own parameters. The program's own seed keeps the places it was
    compiled with (the same draw)."""
    if seed == program.seed or not program.crowds:
        return program
    taken = list(program.fixed_bodies)
    starts: dict[str, Pose] = {}
    for crowd in program.crowds:
        places = crowd_places(program.grid, crowd.name, len(crowd.members), crowd.area,
                              crowd.radius, taken, seed)
        if len(places) < len(crowd.members):
            raise SimulationError(
                f"with seed {seed} only {len(places)} of the {len(crowd.members)} people of "
                f"crowd '{crowd.name}' fit in its area (they all fit with the scenario's seed "
                f"{program.seed})", crowd.span, "make the area larger, or the crowd smaller")
        starts.update((name, Pose(x, y, crowd.heading))
                      for name, (x, y) in zip(crowd.members, places, strict=True))
    humans = tuple(dataclasses.replace(h, start=starts[h.name]) if h.name in starts else h
                   for h in program.humans)
    return dataclasses.replace(program, humans=humans)


def build_controllers(program: Program, given: Mapping[str, type | RobotController]
                      ) -> dict[str, RobotController]:
    """Each robot's controller: the caller's (a class is built with the robot and default
    parameters), else the registered one its declaration names, with its parameters."""
    from hubero_dsl.controllers.registry import controller_class

    unknown = sorted(set(given) - {spec.name for spec in program.robots})
    if unknown:
        raise SimulationError(f"no robot named '{unknown[0]}' to hand a controller to")
    built: dict[str, RobotController] = {}
    for spec in program.robots:
        body = robot_body(spec, program.grid, program.step)
        chosen = given.get(spec.name)
        if chosen is not None and not isinstance(chosen, type):
            if not callable(getattr(chosen, "command", None)):  # told now, not at a tick
                raise InputError(f"robot '{spec.name}': its controller must be a class or an "
                                 f"object with a command(observation) method, not "
                                 f"{chosen!r:.60}")
            built[spec.name] = chosen
            continue
        cls = chosen or controller_class(spec.controller)
        params = _controller_params(spec, cls, handed=chosen is not None)
        try:
            built[spec.name] = cls(body, params)
        except OUTSIDE_STOPS:
            raise
        except BaseException as exc:  # user code: its failure is the user's error
            raise SimulationError(f"robot '{spec.name}': controller {cls.__name__} cannot be "
                                  f"built: {failure_of(exc)}") from None
    return built


def check_handed_controllers(program: Program,
                             given: Mapping[str, type | RobotController]) -> None:
    """Refuse (InputError, at the robot's statement) a class handed over for a robot that does
    not take the scenario's parameters for it, as a run would, without building anything."""
    for spec in program.robots:
        chosen = given.get(spec.name)
        if isinstance(chosen, type):
            _controller_params(spec, chosen, handed=True)


def _controller_params(spec: RobotSpec, cls: type, *, handed: bool) -> ControllerParams:
    """The parameters `cls` is built with for `spec`: a class handed over takes the scenario's
    when it declares a model of its own (validated by it); one that declares none, none."""
    from hubero_dsl.controllers.base import ControllerParams, params_of

    params_model = params_of(cls)
    values = (spec.controller_params
              if not handed or params_model is not ControllerParams else {})
    try:
        params: ControllerParams = params_model.model_validate(dict(values))
    except ValidationError as exc:  # the class handed over does not fit the file: input
        raise InputError(f"robot '{spec.name}': controller {cls.__name__} "
                         f"{_refused_params(exc, spec.controller, cls.__name__)}",
                         span=spec.span) from None
    return params


def _refused_params(error: ValidationError, written_as: str, cls: str) -> str:
    """What a controller's parameter model said of the scenario's parameters, as the file
    names them (`navigator.safety_margin`), without pydantic's wording."""
    problems = []
    for item in error.errors():
        name = ".".join(str(part) for part in item["loc"])
        if item["type"] == "extra_forbidden":
            problems.append(f"does not take the scenario's `{written_as}.{name}` (declare "
                            f"{name} in {cls}.Params, or leave it out)")
        else:
            problems.append(f"refuses `{written_as}.{name}`: {item['msg']}")
    return "; ".join(problems)


def _planner_values(values: dict[str, ParamValue], planner: str) -> dict[str, float]:
    prefix = planner + "."
    return {k[len(prefix):]: float(v) for k, v in values.items()  # type: ignore[arg-type]
            if k.startswith(prefix)}


def _local_planner(program: Program, params: dict[str, dict[str, ParamValue]], name: str,
                   robot_count: int) -> LocalPlanner:
    cls = local_planner(name)
    rows: list[PlannerParams] = [cls.Params.model_validate(_planner_values(params[h], name))
                                 for h in program.human_names]
    rows += [cls.Params() for _ in range(robot_count)]
    return guarded_local(built("local", name, lambda: cls(program.grid, rows)), name)


def _human_arrays(program: Program, params: dict[str, dict[str, ParamValue]]) -> HumanArrays:
    names = program.human_names
    count = len(names)

    def column(key: str) -> np.ndarray:
        return np.array([float(params[n][key]) for n in names], dtype=np.float64)  # type: ignore[arg-type]

    shapes: list[Shape] = [params[n]["personal_space"] for n in names]  # type: ignore[misc]
    starts = [human.start for human in program.humans]
    quantities = {k: column(k) for k, spec in HUMAN_PARAMS.items()
                  if spec.kind is ParamKind.QUANTITY}
    return HumanArrays(
        names=list(names),
        position=np.array([s.xy for s in starts], dtype=np.float64).reshape(count, 2),
        velocity=np.zeros((count, 2)),
        heading=np.array([s.heading or 0.0 for s in starts], dtype=np.float64),
        posture=np.zeros(count, dtype=np.int8),
        shapes=shapes, personal_space=ShapeArrays.from_shapes(shapes),
        **{k: quantities[k] for k in ("speed", "max_speed", "run_speed", "radius",
                                      "relaxation_time", "goal_tolerance", "goal_strength",
                                      "avoidance_strength", "obstacle_strength",
                                      "interaction_range", "field_of_view")},
        moving=np.zeros(count, dtype=bool), with_group=np.zeros(count, dtype=bool),
        desired_speed=np.zeros(count),
        goal=np.full((count, 2), np.nan), stop_distance=np.zeros(count),
        heading_goal=np.full(count, np.nan), teleop_velocity=np.zeros((count, 2)),
        teleop=np.zeros(count, dtype=bool), path_length=np.zeros(count),
        reaction=_reactions(names, params))


def _reactions(names: list[str], params: dict[str, dict[str, ParamValue]]
               ) -> npt.NDArray[np.int8] | None:
    """Each human's reaction to robots as an index into REACTIONS; None when all are regular
    (the engine then spends nothing on reactions)."""
    codes = np.array([REACTIONS.index(str(params[n]["robot_reaction"])) for n in names],
                     dtype=np.int8)
    return codes if codes.any() else None
