"""A TurtleBot 2 (Kobuki) sized differential-drive robot as an MJCF body.

Two driven wheels (radius 0.035 m, 0.23 m apart) with velocity-controlled motors, two casters
(frictionless spheres front and back), a 2.2 kg base disc of radius 0.177 m (Kobuki's 354 mm
diameter): 2.4 kg in all. A wheel motor is a velocity servo ``torque = gain·(ω_cmd − ω)``
clipped to ``±torque_limit``; the gearbox has viscous damping and dry friction, so a motor's
*strength* s (scenario data, ``--damage ROBOT:left_wheel=0.6``) that scales both its gain and
its torque limit makes that wheel turn slower under the same command — physically, not by a
coded failure probability.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Kobuki", "KOBUKI", "robot_mjcf", "actuator_mjcf"]


@dataclass(frozen=True)
class Kobuki:
    """The robot's dimensions, masses and motors (module doc).

    Parameters
    ----------
    wheel_radius : float, default 0.035
        Metres.
    wheel_separation : float, default 0.23
        Metres between the wheels.
    base_radius : float, default 0.177
        Metres (Kobuki's 354 mm diameter).
    base_height : float, default 0.10
        Metres.
    base_mass : float, default 2.2
        Kilograms.
    wheel_mass : float, default 0.1
        Kilograms, each.
    caster_radius : float, default 0.012
        Metres.
    motor_gain : float, default 0.3
        A healthy motor's velocity servo gain at the wheel, N·m per rad/s.
    torque_limit : float, default 0.12
        A healthy motor's torque limit, N·m.
    gear_damping : float, default 0.004
        The gearbox's viscous damping, N·m per rad/s (the load a weak motor struggles against).
    gear_friction : float, default 0.03
        The gearbox's dry friction, N·m.
    max_wheel_speed : float, default 20.0
        The largest wheel speed commanded, rad/s (0.7 m/s, Kobuki's maximum).
    """

    wheel_radius: float = 0.035  # m
    wheel_separation: float = 0.23  # m
    base_radius: float = 0.177  # m (354 mm diameter)
    base_height: float = 0.10  # m
    base_mass: float = 2.2  # kg
    wheel_mass: float = 0.1  # kg
    caster_radius: float = 0.012  # m
    # motor (at the wheel, after the gearbox): velocity servo gain and torque limit of a healthy
    # motor; gearbox viscous damping and dry friction (the load a weak motor struggles against)
    motor_gain: float = 0.3  # N·m per rad/s
    torque_limit: float = 0.12  # N·m
    gear_damping: float = 0.004  # N·m per rad/s
    gear_friction: float = 0.03  # N·m
    max_wheel_speed: float = 20.0  # rad/s commanded (0.7 m/s, Kobuki's maximum)

    @property
    def mass(self) -> float:
        """Kilograms in all: the base and both wheels."""
        return self.base_mass + 2 * self.wheel_mass


KOBUKI = Kobuki()


def robot_mjcf(name: str, x: float, y: float, yaw_deg: float, rgba: str, k: Kobuki = KOBUKI) -> str:
    """The MJCF body of one robot (a free joint; wheels ``{name}_left``/``{name}_right``).

    Parameters
    ----------
    name : str
        The robot's name, prefixing its bodies, joints and geoms.
    x : float
        Its start x (m).
    y : float
        Its start y (m).
    yaw_deg : float
        Its start yaw, degrees.
    rgba : str
        Its base's colour, MJCF's "r g b a".
    k : Kobuki, default KOBUKI
        Its dimensions.

    Returns
    -------
    str
        The ``<body>`` element.
    """
    r, h = k.wheel_radius, k.base_height
    half = k.wheel_separation / 2
    cz = k.caster_radius
    fx, cpz = k.base_radius - 0.04, cz - r  # caster x offset and height in the body frame
    return f"""
    <body name="{name}" pos="{x:.4f} {y:.4f} {r:.4f}" euler="0 0 {yaw_deg:.3f}">
      <freejoint name="{name}_root"/>
      <geom name="{name}_base" type="cylinder" size="{k.base_radius} {h / 2:.4f}"
            pos="0 0 {h / 2 + 0.005:.4f}" mass="{k.base_mass}" rgba="{rgba}"
            friction="0.1 0.005 0.0001" contype="2" conaffinity="2"/>
      <geom name="{name}_caster_f" type="sphere" size="{cz}" pos="{fx} 0 {cpz:.4f}"
            mass="0.001" condim="1" priority="1" contype="1" conaffinity="1"/>
      <geom name="{name}_caster_b" type="sphere" size="{cz}" pos="{-fx} 0 {cpz:.4f}"
            mass="0.001" condim="1" priority="1" contype="1" conaffinity="1"/>\
{_wheel_mjcf(name, "lw", "left", half, k)}{_wheel_mjcf(name, "rw", "right", -half, k)}
    </body>"""


def _wheel_mjcf(name: str, body: str, side: str, y: float, k: Kobuki) -> str:
    """One driven wheel: body ``{name}_{body}`` at ``y`` in the robot's frame, on the hinge
    ``{name}_{side}`` its motor turns."""
    r = k.wheel_radius
    return f"""
      <body name="{name}_{body}" pos="0 {y} 0">
        <joint name="{name}_{side}" type="hinge" axis="0 1 0" damping="{k.gear_damping}"
               frictionloss="{k.gear_friction}"/>
        <geom type="sphere" size="{r}" mass="{k.wheel_mass}" friction="1.0 0.005 0.0001"
              contype="1" conaffinity="1" rgba="0.1 0.1 0.1 1"/>
      </body>"""


def actuator_mjcf(name: str, left: float = 1.0, right: float = 1.0, k: Kobuki = KOBUKI) -> str:
    """Velocity servos of one robot's wheels.

    Parameters
    ----------
    name : str
        The robot's name.
    left : float, default 1.0
        The left motor's strength (scales its gain and torque limit); 0 is a dead motor.
    right : float, default 1.0
        The right motor's.
    k : Kobuki, default KOBUKI
        The healthy motor's gain and torque limit.

    Returns
    -------
    str
        Two ``<velocity>`` elements.
    """
    out = []
    for side, s in (("left", left), ("right", right)):
        kv, tau = k.motor_gain * s, k.torque_limit * s
        # a dead motor (strength 0) has no gain and so no force; MuJoCo refuses the empty force
        # range [0, 0] that would say the same, so it is left unlimited
        limit = f'forcelimited="true" forcerange="{-tau:.6g} {tau:.6g}"' if s > 0 else ""
        out.append(
            f'<velocity name="{name}_{side}_motor" joint="{name}_{side}" kv="{kv:.6g}" {limit}/>'
        )
    return "\n    ".join(out)
