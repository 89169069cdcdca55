"""Contact events between robots, and between robots and walls, in a MuJoCo world built by
:func:`~mirl.physics.world.world_mjcf`: a pair counts once, when it starts touching."""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["ContactLog"]


class ContactLog:
    """Contact events of the robots ``names`` (their ``{name}_base`` geoms) with each other and
    with the walls (geoms named ``wall…``).

    Parameters
    ----------
    model : mujoco.MjModel
        The world's model.
    names : sequence of str
        The robots, in the order their indices in :attr:`pairs` refer to.
    """

    def __init__(self, model: mujoco.MjModel, names) -> None:
        self._geom_robot = np.full(model.ngeom, -1)  # robot index of each geom, -1: no robot
        self._geom_robot[[model.geom(f"{nm}_base").id for nm in names]] = np.arange(len(names))
        self._is_wall = np.array(
            [model.geom(g).name.startswith("wall") for g in range(model.ngeom)]
        )
        self.contacts = 0  # robot-robot contact events
        self.wall_contacts = 0
        self.pairs: list[tuple[int, int, int]] = []  # (step, i, j) of each robot-robot event
        self._touching: set[tuple[int, int]] = set()  # (i, j), or (i, -1) for a wall

    def update(self, data: mujoco.MjData, step: int) -> None:
        """Count the pairs touching in ``data`` now that were not at the last update.

        Parameters
        ----------
        data : mujoco.MjData
            The world's state after a MuJoCo step.
        step : int
            The decision step, recorded with each robot–robot event.
        """
        if data.ncon == 0:
            self._touching = set()
            return
        g = data.contact.geom[: data.ncon]
        ra, rb = self._geom_robot[g[:, 0]], self._geom_robot[g[:, 1]]
        if not self._touching and (ra < 0).all() and (rb < 0).all():
            return  # the usual case: wheels and casters on the floor only
        now = set()
        both = (ra >= 0) & (rb >= 0)
        for i, j in zip(ra[both], rb[both], strict=True):
            now.add((int(min(i, j)), int(max(i, j))))
        wall = ((ra >= 0) & self._is_wall[g[:, 1]]) | ((rb >= 0) & self._is_wall[g[:, 0]])
        for i in np.where(ra >= 0, ra, rb)[wall]:
            now.add((int(i), -1))
        for pair in now - self._touching:
            if pair[1] >= 0:
                self.contacts += 1
                self.pairs.append((step, *pair))
            else:
                self.wall_contacts += 1
        self._touching = now
