"""Physics parameters as scenario data: the ``[physics]`` table of a scenario TOML.

Every field has a documented default (:class:`PhysicsConfig`); an unknown key is an error
naming the scenario file and the key. Motor strengths per robot per wheel live in
``[physics.motor_strength]``, e.g. ``J = { left_wheel = 0.6 }``: 1.0 is a healthy motor, 0.6 a
motor with 60 % of a healthy one's gain and torque limit. This is what ``--damage
ROBOT:left_wheel=0.6`` sets in the physics world (in the grid world the same flag sets a
success probability). The learner never sees any of these numbers.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from typing import TYPE_CHECKING, Any

from mirl.world.actions import STEP_SECONDS
from mirl.world.faults import WHEELS
from mirl.world.motion import PIVOTS, turns_without_wheels

if TYPE_CHECKING:
    from mirl.world.domain import FeatureMap

__all__ = [
    "PhysicsConfig",
    "SECTION",
    "physics_config",
    "scenario_physics",
    "with_motor_strength",
    "physical_feature_map",
    "PIVOTS",
]

SECTION = "physics"
"""The scenario table these parameters are read from (one of
:data:`mirl.world.world_sections.WORLD_SECTIONS`)."""


def physical_feature_map(feature_map: FeatureMap) -> FeatureMap:
    """ξ as this world's motion has it: the scenario's, with the wheels removed from the turns.

    The paper's ξ has a damaged wheel fail the turns it drives. Here a pivot needs at most
    69 °/s to finish within a decision step (a quarter turn in 2 s with the controller's
    approach), and the one wheel that drives it gives 88 °/s at 0.6 strength; in proportion, a
    motor pivots in time down to about 0.47 of its strength (measured at 0.6: ``calibrate`` and
    the isolated pivots of ``tests/physics/test_patrol.py`` succeed whichever wheel is weak; the
    0.47 is the proportion, not a measurement). A weaker
    motor shows in forward steps, which need both wheels, and in the robot's lateral drift;
    charging the turns to a wheel would pin the wheel that drives the patrol's many left turns
    near 1 and blame the other one for every forward failure (docs/design.md, "Fault
    verdicts").

    Parameters
    ----------
    feature_map : FeatureMap
        The scenario's ξ.

    Returns
    -------
    FeatureMap
        ξ without the wheels in the subsets of turn_left and turn_right.
    """
    return turns_without_wheels(feature_map)


PHYSICAL_ERROR_MODEL = "stop"
"""Where a failed step ends in this world: where it started. A weak motor's forward step that
does not reach the next cell ends short of it, in the same cell, and a pivot that does not
finish leaves the heading; no failure sends a robot where another action would have
(Eq. 5's uniform error model, which sends two thirds of them there). Measured
(``calibrate(scenario, steps=300, seeds=range(20, 23)).stayed()`` on boyd2-healthy, boydright
and office, healthy and with I's left or J's right motor at 0.6): 98–99 % of a weak robot's
failed moving steps stay put and 81–95 % of a healthy robot's few (39–162); at most 4 of
any 660 end in another action's state (docs/design.md, "The physical world")."""


@dataclass(frozen=True)
class PhysicsConfig:
    """The physical world's parameters, the ``[physics]`` table of a scenario.

    Read one with :func:`physics_config` (or :func:`scenario_physics`), which checks every field.

    Parameters
    ----------
    timestep : float, default 0.01
        Seconds, MuJoCo's integration step; at most a control tick.
    control_hz : float, default 10.0
        Controller, localisation and detection updates per second.
    step_seconds : float, default STEP_SECONDS (2.0)
        Seconds a decision step (:data:`~mirl.world.actions.STEP_SECONDS`, the grid's).
    localisation_sigma : float, default 0.05
        Cells (metres on a 1 m grid), the standard deviation of the AMCL-like pose error the
        patrollers decide from (temporally correlated).
    localisation_sigma_deg : float, default 3.0
        Degrees, its heading error's standard deviation.
    localisation_tau : float, default 1.0
        Seconds, the correlation time of the localisation error.
    measurement_sigma : float, default 0.05
        Cells (metres on a 1 m grid), the standard deviation of the noise on the poses L's
        camera reports.
    measurement_sigma_deg : float, default 5.0
        Degrees, that of the noise on their yaw.
    camera_fov_deg : float, default 57.0
        L's camera's field of view (a Kinect's).
    camera_range : float, optional
        Metres L's camera sees; None: far enough to reach the scenario's visible cells
        (:func:`~mirl.physics.camera.observer_camera`).
    camera_pose : (float, float, float), optional
        L's camera's x, y (m) and yaw (degrees); None: at L's door, looking out.
    patroller_fov_deg : float, default 57.0
        The patrollers' cameras' field of view.
    patroller_range : float, optional
        Metres the patrollers' cameras see; None: the scenario's ``detect_distance`` cells.
    max_speed : float, default 0.7
        Cruise speed of the patrol controller, cells a second (m/s on a 1 m grid).
    max_accel : float, default 1.0
        The controller's acceleration limit, m/s².
    turn_speed : float, default 1.2
        The pivot turns' rate limit, rad/s.
    lane_offset : float, default 0.23
        Cells right of the hallway's centre line a robot keeps in company.
    keep_right_within : float, default 6.0
        Cells: a robot coming the other way this close makes a robot keep right.
    pass_distance : float, default 1.2
        Cells: another robot this close ahead makes a robot pass slowly.
    pass_speed : float, default 0.2
        Cells a second while passing.
    drift_per_gap : float, default 0.25
        The cells of lateral drift κ per unit gap between a robot's wheels' success
        probabilities; measured (``python benchmarks/calibrate_drift.py``: 0.260 by least squares
        on boyd2-healthy, 0.258 on boydright), not assumed.
    drift_spread : float, default 0.3
        The drift's relative spread, twice the measured (0.12–0.16), because other maps and
        strengths were measured less (docs/design.md, "Which side").
    motor_strength : mapping of str to mapping of str to float, default {}
        Per robot, per wheel (``left_wheel``, ``right_wheel``), the motor's strength in [0, 1]
        (1.0 healthy, 0.6 a motor with 60 % of a healthy one's gain and torque limit).
    """

    timestep: float = 0.01  # s, MuJoCo integration step
    control_hz: float = 10.0  # controller, localisation and detection checks per second
    step_seconds: float = STEP_SECONDS  # one decision step, the grid's
    localisation_sigma: float = 0.05  # m, AMCL-like pose error (temporally correlated)
    localisation_sigma_deg: float = 3.0  # degrees
    localisation_tau: float = 1.0  # s, correlation time of the localisation error
    measurement_sigma: float = 0.05  # m, noise on the poses L's camera reports
    measurement_sigma_deg: float = 5.0
    camera_fov_deg: float = 57.0  # L's camera (Kinect)
    camera_range: float | None = None  # m; None: reaches the scenario's visible cells (see camera)
    camera_pose: tuple[float, float, float] | None = None  # x, y (m), yaw (deg); None: at L's door
    patroller_fov_deg: float = 57.0
    patroller_range: float | None = None  # m; None: detect_distance cells
    max_speed: float = 0.7  # m/s cruise of the patrol controller
    max_accel: float = 1.0  # m/s^2
    turn_speed: float = 1.2  # rad/s, pivot turns
    lane_offset: float = 0.23  # cells right of the hallway's centre line, kept in company
    keep_right_within: float = 6.0  # cells: a robot coming the other way this close -> keep right
    pass_distance: float = 1.2  # cells: another robot this close ahead -> pass slowly
    pass_speed: float = 0.2  # m/s (per 1 m cell) while passing
    # cells of lateral drift per unit gap between the wheels' success probabilities (κ), and its
    # relative spread: measured, not assumed (`python benchmarks/calibrate_drift.py`: 0.260 by
    # least squares over both robots' either motor at 0.5 and 0.7 strength, seeds 100-101,
    # boyd2-healthy, relative sd 0.16; boydright 0.258, 0.12); the spread is twice the measured
    # because other maps and strengths were measured less (docs/design.md, "Which side")
    drift_per_gap: float = 0.25
    drift_spread: float = 0.3
    motor_strength: Mapping[str, Mapping[str, float]] = field(default_factory=dict)

    def strength(self, robot: str, wheel: str) -> float:
        """A wheel motor's strength.

        Parameters
        ----------
        robot : str
            The robot's name.
        wheel : str
            ``left_wheel`` or ``right_wheel``.

        Returns
        -------
        float
            Its strength in [0, 1]; 1.0 (healthy) unless :attr:`motor_strength` says otherwise.
        """
        return float(self.motor_strength.get(robot, {}).get(wheel, 1.0))

    def with_strength(self, robot: str, wheel: str, value: float) -> PhysicsConfig:
        """A copy with one wheel motor's strength set.

        Parameters
        ----------
        robot : str
            The robot's name.
        wheel : str
            ``left_wheel`` or ``right_wheel``.
        value : float
            The strength, in [0, 1].

        Returns
        -------
        PhysicsConfig
            The copy.

        Raises
        ------
        ValueError
            Another part than a wheel, or a strength outside [0, 1].
        """
        if wheel not in WHEELS:
            raise ValueError(
                f"in the physics world damage is a wheel motor's strength: '{wheel}' is "
                f"not one of {', '.join(WHEELS)}"
            )
        if not 0.0 <= value <= 1.0:
            raise ValueError(f"motor strength for {robot}:{wheel} must be in [0, 1]")
        ms = {k: dict(v) for k, v in self.motor_strength.items()}
        ms.setdefault(robot, {})[wheel] = float(value)
        return replace(self, motor_strength=ms)

    @property
    def ticks_per_step(self) -> int:
        """Control ticks in a decision step."""
        return int(round(self.step_seconds * self.control_hz))

    @property
    def substeps(self) -> int:
        """MuJoCo steps in a control tick (at least 1)."""
        return max(1, int(round(1.0 / (self.control_hz * self.timestep))))


_FIELDS = {f.name for f in fields(PhysicsConfig)}


def physics_config(
    data: Mapping[str, Any] | None, source: str = "<memory>", robots: tuple[str, ...] = ()
) -> PhysicsConfig:
    """Validate a ``[physics]`` table.

    Parameters
    ----------
    data : mapping, optional
        The table as read from TOML; None or empty for the defaults.
    source : str, default "<memory>"
        The scenario file, named by every message.
    robots : tuple of str, default ()
        The scenario's robots, which ``motor_strength`` may name; any if empty.

    Returns
    -------
    PhysicsConfig
        The parameters.

    Raises
    ------
    ValueError
        An unknown field, a value of the wrong type or range, or a timestep or decision step
        that does not fit the control tick; the message names ``source`` and the field.
    """
    data = dict(data or {})
    for k in data:
        if k not in _FIELDS:
            raise ValueError(
                f"{source}: physics.{k}: unknown field (known: {', '.join(sorted(_FIELDS))})"
            )
    ms = data.pop("motor_strength", {})
    if not isinstance(ms, Mapping):
        raise ValueError(f"{source}: physics.motor_strength: expected a table of robots")
    strengths: dict[str, dict[str, float]] = {}
    for robot, wheels in ms.items():
        if robots and robot not in robots:
            raise ValueError(f"{source}: physics.motor_strength.{robot}: unknown robot")
        if not isinstance(wheels, Mapping):
            raise ValueError(f"{source}: physics.motor_strength.{robot}: expected a table")
        for w, v in wheels.items():
            if w not in WHEELS or not isinstance(v, int | float) or not 0 <= v <= 1:
                raise ValueError(
                    f"{source}: physics.motor_strength.{robot}.{w}: expected left_wheel or "
                    "right_wheel = a strength in [0, 1]"
                )
        strengths[robot] = {w: float(v) for w, v in wheels.items()}
    out: dict[str, Any] = {}
    for k, v in data.items():
        if k == "camera_pose":
            if v is not None and (not isinstance(v, list | tuple) or len(v) != 3):
                raise ValueError(f"{source}: physics.camera_pose: expected [x, y, yaw_deg]")
            out[k] = None if v is None else tuple(float(x) for x in v)
            continue
        if not isinstance(v, int | float) or isinstance(v, bool) or not 0 <= v < float("inf"):
            raise ValueError(f"{source}: physics.{k}: expected a non-negative number, got {v!r}")
        if k in _POSITIVE and v == 0:
            raise ValueError(f"{source}: physics.{k}: must be positive, got 0")
        out[k] = float(v)
    cfg = PhysicsConfig(**out, motor_strength=strengths)
    tick = 1.0 / cfg.control_hz
    if cfg.timestep > tick:
        raise ValueError(f"{source}: physics.timestep: {cfg.timestep:g} s is longer than a "
                         f"control tick (1 / control_hz = {tick:g} s)")  # fmt: skip
    if cfg.ticks_per_step < 1:
        raise ValueError(f"{source}: physics.step_seconds: {cfg.step_seconds:g} s is shorter "
                         f"than a control tick (1 / control_hz = {tick:g} s)")  # fmt: skip
    return cfg


# fields a zero makes meaningless (a division by it, or a robot or camera that cannot act)
_POSITIVE = frozenset(
    ("timestep", "control_hz", "step_seconds", "camera_fov_deg",
     "patroller_fov_deg", "max_speed", "max_accel", "turn_speed", "drift_per_gap",
     "drift_spread")
)  # fmt: skip


def with_motor_strength(scenario, robot: str, wheel: str, strength: float):
    """A copy of ``scenario`` whose ``[physics]`` table sets one wheel motor's strength.

    What ``--damage ROBOT:WHEEL=S`` means in the physics world.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    robot : str
        The robot's name.
    wheel : str
        ``left_wheel`` or ``right_wheel``.
    strength : float
        The strength, in [0, 1].

    Returns
    -------
    Scenario
        The copy.

    Raises
    ------
    ValueError
        An unknown robot or wheel, or a strength outside [0, 1].
    """
    scenario.robot_index(robot)  # unknown robot: ValueError naming the robots
    cfg = scenario_physics(scenario).with_strength(robot, wheel, strength)
    table = dict(scenario.section(SECTION))
    table["motor_strength"] = {r: dict(w) for r, w in cfg.motor_strength.items()}
    return scenario.with_section(SECTION, table)


def scenario_physics(scenario) -> PhysicsConfig:
    """The scenario's ``[physics]`` table as a validated :class:`PhysicsConfig`.

    Parameters
    ----------
    scenario : Scenario
        The scenario.

    Returns
    -------
    PhysicsConfig
        Its parameters (the defaults where the table is silent).

    Raises
    ------
    ValueError
        A bad table (see :func:`physics_config`).
    """
    return physics_config(scenario.section(SECTION), scenario.source, scenario.robot_names)
