"""The physical world: differential-drive robots in MuJoCo, seen through cameras.

What it holds:

- :mod:`~mirl.physics.robot` — a TurtleBot 2 (Kobuki) sized robot as MJCF; damaged wheels are
  weaker motors (gain and torque limit), never a coded failure probability;
- :mod:`~mirl.physics.world` — the MJCF of any grid map (walls as merged boxes), placed by the
  map's :class:`~mirl.world.maps.MapFrame`;
- :mod:`~mirl.physics.control` — the ``move_base`` analogue (pursuit + heading feedback, pivots,
  slowing down near another robot);
- :mod:`~mirl.physics.camera` — view cones with ``mujoco.mj_ray`` lines of sight: L's camera and
  the patrollers' cameras with their sightings of L;
- :mod:`~mirl.physics.contacts` — contact events, robot–robot and robot–wall;
- :mod:`~mirl.physics.records` — what a run recorded: grid states, actions, tick poses, L's
  camera measurements;
- :mod:`~mirl.physics.patrol` — :class:`~mirl.physics.patrol.PhysicalWorld`: patrollers
  deciding on the grid from a noisy pose estimate and driving in physics, composed of the
  objects above;
- :mod:`~mirl.physics.config` — the ``[physics]`` scenario table and its defaults;
- :mod:`~mirl.physics.calibration` — effective per-action success rates of the physics.

Layer rule: this package may import only :mod:`mirl.world`, :mod:`mirl.observations` and
:mod:`mirl.mdp` — never learning, planning, experiments
or the grid simulator. The learner gets only the discretised observations L's camera makes.

MuJoCo is optional: ``pip install "mirl[physics]"``. :func:`require_mujoco` gives the one-line
message the command line prints when it is missing.
"""

from __future__ import annotations

__all__ = ["MISSING_MESSAGE", "require_mujoco", "mujoco_version"]

MISSING_MESSAGE = 'the physics world needs MuJoCo: pip install "mirl[physics]"'


# releases that simulate these robots wrongly, and why (docs/results.md, "MuJoCo versions")
BROKEN_MUJOCO = {
    "4.0.0": "its sparse-Cholesky bug (fixed in 4.0.1) slows a healthy robot to 0.30-0.38 m/s",
}


def require_mujoco() -> None:
    """Raise ImportError with :data:`MISSING_MESSAGE` when ``mujoco`` cannot be imported, and
    with the reason when it is a release in :data:`BROKEN_MUJOCO` (installed by hand: the
    ``physics`` extra excludes them)."""
    try:
        import mujoco
    except ImportError:
        raise ImportError(MISSING_MESSAGE) from None
    version = str(getattr(mujoco, "__version__", ""))
    if version in BROKEN_MUJOCO:
        raise ImportError(
            f"MuJoCo {version} breaks the physics world ({BROKEN_MUJOCO[version]}): "
            'pip install "mujoco!=4.0.0"'
        )


def mujoco_version() -> str:
    """The installed MuJoCo's version.

    Physics results depend on it — the same seed gives other trajectories under another MuJoCo
    (3.17.0 against 4.0.0: 30 against 7 robot–robot contacts in the same 25 minutes) — so runs
    record it beside mirl's own fingerprint.

    Returns
    -------
    str
        ``mujoco.__version__``.
    """
    import mujoco

    return str(mujoco.__version__)
