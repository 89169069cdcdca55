"""Patrollers (and L) driving in MuJoCo: decisions on the grid, motion in physics.

Every decision step (``step_seconds``, default 2 s) each patroller discretises its *estimated*
pose (true pose + a temporally correlated, AMCL-like error), takes its true grid policy's action
there (``scenario.true_policy``), with the scenario's played equilibrium where two patrollers'
intended moves meet (:func:`mirl.world.game.meeting`), and the
:class:`~mirl.physics.control.Controller` drives towards the intended cell and heading. A step
that does not get there in time is simply where the robot is at the next decision. L's camera
records the patrollers it sees once per decision step (true pose + measurement noise): that
pose track is all the learner gets. While L is out of its room the patrollers' cameras look for
it at every control tick (10 Hz). Contacts between robots (and with walls) are counted as
events (a pair touching after not touching).

Every random number comes from ``seed`` through independent streams (localisation, camera
measurement, game draws, start draws), so a run is a function of its arguments.
"""

from __future__ import annotations

import mujoco
import numpy as np

from mirl.observations.discretise import discretise
from mirl.observations.poses import PoseTracks
from mirl.observations.trajectories import Trajectories
from mirl.physics.camera import (
    Cone,
    ObserverCamera,
    PatrollerCameras,
    Sighting,
    observer_camera,
)
from mirl.physics.config import PhysicsConfig, scenario_physics
from mirl.physics.contacts import ContactLog
from mirl.physics.control import DRIVE, HOLD, PIVOT, Controller, crowded, in_company, wrap
from mirl.physics.records import OBSERVER, Records
from mirl.physics.robot import KOBUKI
from mirl.physics.world import world_mjcf
from mirl.world.domain import FORWARD, N_HEADINGS, TURN_LEFT, TURN_RIGHT
from mirl.world.game import meeting, meeting_actions
from mirl.world.maps import HEADING_DELTAS, HEADING_YAWS

__all__ = [
    "PhysicalWorld",
    "Sighting",
    "scenario_physics",
    "observer_camera",
    "OBSERVER",
]

Pose = tuple[float, float, float]  # x, y (m), yaw (rad)


def _heading(yaw):
    """The grid heading nearest a yaw (radians; arrays elementwise)."""
    return np.rint(wrap(yaw) / (np.pi / 2)).astype(int) % N_HEADINGS


class PhysicalWorld:
    """N patrollers (and L, unless ``observer=False``) in one MuJoCo model.

    What happens is kept by composed objects: :attr:`records` (states, actions, poses, L's
    camera measurements), :attr:`contact_log` (contact events), :attr:`camera` (L's view) and
    :attr:`patroller_cameras` (the patrollers' sightings of L); the attributes and methods
    below that read them are views of those objects.

    Parameters
    ----------
    scenario : Scenario
        The scenario: map, patrollers, game, L's start.
    config : PhysicsConfig, optional
        The physical parameters; the scenario's ``[physics]`` table by default.
    observability : float, optional
        The fraction of the hallway L sees; the scenario's by default.
    seed : int, default 0
        Seeds the localisation noise, L's measurement noise, the game draws and random starts
        (four streams spawned from it).
    starts : list of (int, int, int), optional
        The patrollers' start states (row, col, heading); the scenario's by default.
    random_starts : bool, default False
        Start each patroller at a uniformly drawn state of its patrol cycle instead.
    observer : bool, default True
        Whether L (and its camera) is in the world.
    policies : ndarray of int, shape (N, S), optional
        The patrollers' policies; their true policies by default.
    record_ticks : bool, default True
        Whether the true poses of every control tick are kept (:meth:`tick_poses`).
    observer_heading : int, optional
        L's start heading; facing its camera's view by default.
    """

    # set while the model is built (in ``__init__``), declared here so the class names them
    contact_log: ContactLog
    """Contact events, robot–robot and robot–wall."""
    patroller_cameras: PatrollerCameras
    """The patrollers' view cones and their sightings of L."""

    def __init__(
        self,
        scenario,
        *,
        config: PhysicsConfig | None = None,
        observability: float | None = None,
        seed: int = 0,
        starts: list[tuple[int, int, int]] | None = None,
        random_starts: bool = False,
        observer: bool = True,
        policies: np.ndarray | None = None,
        record_ticks: bool = True,
        observer_heading: int | None = None,
    ) -> None:
        self.scenario = scenario
        self.cfg = cfg = config or scenario_physics(scenario)
        self.domain = dom = scenario.domain
        self.map = scenario.map
        self.frame = scenario.map.frame
        self.n = len(scenario.robots)
        self.names = scenario.robot_names
        self.degree = scenario.observability if observability is None else float(observability)
        self.visible = dom.visible_states(self.degree)
        self.policies = (
            np.stack([scenario.true_policy(i) for i in range(self.n)])
            if policies is None
            else np.asarray(policies)
        )
        # each pair's own equilibrium ([[game.pairs]]), else the scenario's, as on the grid
        self._eq = {}
        for i, j in scenario.pairs:
            eq = scenario.pair_equilibrium(i, j)
            self._eq[i, j] = (np.asarray(eq.row, float), np.asarray(eq.col, float))
        loc, meas, game, start = np.random.SeedSequence(int(seed)).spawn(4)
        self._loc_rng = np.random.default_rng(loc)
        self._meas_rng = np.random.default_rng(meas)
        self._game_rng = np.random.default_rng(game)
        if starts is None:
            starts = [tuple(r.start) for r in scenario.robots]
            if random_starts:
                start_rng = np.random.default_rng(start)
                starts = [
                    tuple(dom.states[c[start_rng.integers(len(c))]])
                    for c in (self._cycle(i, dom.state_index(*starts[i])) for i in range(self.n))
                ]
        self.has_observer = observer
        self.m = self.n + int(observer)
        self._lane = cfg.lane_offset * self.frame.cell_size
        self._build(self._start_poses(starts, observer_heading))
        self._init_noise_and_control()
        self._nearest = self._nearest_cells()
        self._visible_cells = self.map.visible_mask(self.degree)
        self.t = 0  # decision steps so far
        self.observer_moved = False  # L has been driven: the patrollers' cameras look for it
        self.records = Records(dom, self.names, observer, record_ticks)
        self._record_decision_time()

    def _start_poses(self, starts, observer_heading: int | None) -> list[Pose]:
        """Patrollers and L at their start cells' centres."""
        poses = []
        for r, c, h in starts:
            x, y = self.frame.cell_centre(r, c)
            poses.append((float(x), float(y), float(HEADING_YAWS[h])))
        if self.has_observer:
            x, y = self.frame.cell_centre(*self.scenario.observer_start)
            self.camera = observer_camera(self.scenario, self.cfg, self.frame, self.degree)
            oyaw = self.camera.pose[2] if self.camera.pose else 0.0
            if observer_heading is not None:
                oyaw = float(HEADING_YAWS[observer_heading])
            poses.append((float(x), float(y), float(oyaw)))
        else:
            self.camera = ObserverCamera(None, None, np.zeros(self.map.shape, bool))
        return poses

    def _build(self, poses) -> None:
        """The MuJoCo model and the index arrays every control tick uses."""
        cfg = self.cfg
        names = list(self.names) + ([OBSERVER] if self.has_observer else [])
        specs = [
            (nm, *poses[i], cfg.strength(nm, "left_wheel"), cfg.strength(nm, "right_wheel"))
            for i, nm in enumerate(names)
        ]
        xml = world_mjcf(self.map.free, self.frame, specs, timestep=cfg.timestep)
        self.model = model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(model)
        mujoco.mj_forward(model, self.data)
        roots = [model.joint(f"{nm}_root").id for nm in names]
        self._qadr = np.array([model.jnt_qposadr[j] for j in roots])
        self._pose_idx = self._qadr[:, None] + np.array([0, 1, 3, 4, 5, 6])
        self._dadr = np.array([model.jnt_dofadr[j] for j in roots])
        self.contact_log = ContactLog(model, names)

    def _init_noise_and_control(self) -> None:
        cfg, cs = self.cfg, self.frame.cell_size
        self.ctrl = Controller(
            self.m,
            KOBUKI,
            max_speed=cfg.max_speed * cs,
            max_accel=cfg.max_accel,
            turn_speed=cfg.turn_speed,
            pass_speed=cfg.pass_speed * cs,
            dt=1.0 / cfg.control_hz,
        )
        sd_xy = cfg.localisation_sigma * cs
        self._noise_sd = np.array([sd_xy, sd_xy, np.radians(cfg.localisation_sigma_deg)])
        self._noise_a = float(np.exp(-1.0 / (cfg.control_hz * max(cfg.localisation_tau, 1e-9))))
        self._noise = self._loc_rng.normal(size=(self.m, 3)) * self._noise_sd
        rng = cfg.patroller_range
        cone = Cone(
            cfg.patroller_fov_deg, rng if rng is not None else self.scenario.detect_distance * cs
        )
        self.patroller_cameras = PatrollerCameras(cone, self.map, self.n)

    # ---- views of the composed records -------------------------------------------------
    @property
    def true(self) -> list[np.ndarray]:
        """Per decision time: (N,) true state indices."""
        return self.records.true

    @property
    def seen(self) -> list[np.ndarray]:
        """Per decision time: (N,) L's discretised observations (-1 unseen)."""
        return self.records.seen

    def true_states(self) -> np.ndarray:
        """The patrollers' true states at every decision time so far.

        Returns
        -------
        ndarray of int, shape (t+1, N)
            State indices (poses discretised, snapped onto the hallway).
        """
        return self.records.true_states()

    def observations(self, until: int | None = None) -> Trajectories:
        """What L's camera saw, discretised, as grid observations.

        Parameters
        ----------
        until : int, optional
            The last decision time included; all so far by default.

        Returns
        -------
        Trajectories
            The observed states, with their lateral offsets.
        """
        return self.records.observations(until)

    def truth(self) -> Trajectories:
        """The patrollers' true states as grid trajectories.

        Returns
        -------
        Trajectories
            Every patroller at every decision time so far.
        """
        return self.records.truth()

    def tick_poses(self) -> tuple[np.ndarray, np.ndarray]:
        """The true poses at every control tick.

        Returns
        -------
        times : ndarray of shape (k,)
            Seconds.
        poses : ndarray of shape (k, m, 3)
            x, y, yaw of every robot (patrollers first, L last).
        """
        return self.records.tick_poses()

    def observed_rows(self) -> np.ndarray:
        """L's camera measurements.

        Returns
        -------
        ndarray of shape (k, 5)
            Rows t (s), robot, x, y, yaw.
        """
        return self.records.observed_rows()

    def observed_tracks(self) -> PoseTracks:
        """What L's camera measured: one noisy pose per seen patroller per decision step.

        Returns
        -------
        PoseTracks
            The measurements.
        """
        return self.records.observed_tracks()

    def true_tracks(self) -> PoseTracks:
        """Every robot's true pose at every control tick (L, if present, is robot ``L``).

        Returns
        -------
        PoseTracks
            The poses.
        """
        return self.records.true_tracks()

    @property
    def contacts(self) -> int:
        """Robot-robot contact events so far."""
        return self.contact_log.contacts

    @property
    def wall_contacts(self) -> int:
        """Robot-wall contact events so far."""
        return self.contact_log.wall_contacts

    @property
    def contact_pairs(self) -> list[tuple[int, int, int]]:
        """(step, i, j) of every robot-robot contact event."""
        return self.contact_log.pairs

    @property
    def sightings(self) -> list[Sighting]:
        """Every time a patroller's camera saw L."""
        return self.patroller_cameras.sightings

    @property
    def observer_out(self) -> bool:
        """Whether L was outside its room when the patrollers' cameras last looked."""
        return self.patroller_cameras.observer_out

    # ---- geometry helpers ---------------------------------------------------------------
    def _cycle(self, i: int, s: int) -> np.ndarray:
        pol, psi = self.policies[i], self.domain.intended
        for _ in range(2 * self.domain.n_states):
            s = psi[s, pol[s]]
        cyc = [int(s)]
        s = psi[s, pol[s]]
        while s != cyc[0]:
            cyc.append(int(s))
            s = psi[s, pol[s]]
        return np.asarray(cyc)

    def _nearest_cells(self) -> np.ndarray:
        """(rows, cols) index of the nearest patroller cell of every map cell."""
        rows, cols = self.map.shape
        rr, cc = np.mgrid[0:rows, 0:cols]
        cells = self.domain.cells
        d = (rr.ravel()[:, None] - cells[None, :, 0]) ** 2 + (
            cc.ravel()[:, None] - cells[None, :, 1]
        ) ** 2
        return np.argmin(d, axis=1).reshape(rows, cols)

    def poses(self) -> np.ndarray:
        """The true pose of every robot now.

        Returns
        -------
        ndarray of shape (m, 3)
            x, y (m), yaw (rad) of every robot, patrollers first, L last.
        """
        q = self.data.qpos[self._pose_idx]  # (m, 6): x, y, qw, qx, qy, qz
        w, x, y, z = q[:, 2], q[:, 3], q[:, 4], q[:, 5]
        out = q[:, :3].copy()
        out[:, 2] = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        return out

    def estimated_poses(self) -> np.ndarray:
        """The poses the robots believe they have: the true ones with the localisation error.

        Returns
        -------
        ndarray of shape (m, 3)
            x, y (m), yaw (rad), patrollers first, L last.
        """
        p = self.poses()
        p[:, :2] += self._noise[:, :2]
        p[:, 2] = wrap(p[:, 2] + self._noise[:, 2])
        return p

    def discretise(self, poses: np.ndarray, *, snap: bool = True) -> np.ndarray:
        """Patroller states of poses: nearest cell and nearest heading.

        Parameters
        ----------
        poses : ndarray of shape (k, 3)
            The poses' x, y (m) and yaw (rad).
        snap : bool, default True
            Off the hallway, take the nearest hallway cell; else -1.

        Returns
        -------
        ndarray of int, shape (k,)
            State indices.
        """
        rows, cols = self.map.shape
        r, c = self.frame.cell_of(poses[:, 0], poses[:, 1])
        h = _heading(poses[:, 2])
        inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        rc, cc = np.clip(r, 0, rows - 1), np.clip(c, 0, cols - 1)
        s = self.domain.state_index(np.where(inside, r, -1), np.where(inside, c, -1), h)
        if snap:
            cell = self._nearest[rc, cc]
            s = np.where(s >= 0, s, cell * N_HEADINGS + h)
        return s

    def observer_cell_heading(self, estimated: bool = True) -> tuple[int, int, int]:
        """L's cell and nearest heading.

        Parameters
        ----------
        estimated : bool, default True
            From L's estimated pose (what L knows), else its true one.

        Returns
        -------
        (int, int, int)
            Row, column and heading.
        """
        p = (self.estimated_poses() if estimated else self.poses())[self.n]
        r, c = self.frame.cell_of(p[0], p[1])
        h = int(_heading(p[2]))
        return int(r), int(c), h

    # ---- one decision step --------------------------------------------------------------
    def _record_decision_time(self) -> None:
        p = self.poses()
        self.records.true.append(self.discretise(p[: self.n]))
        seen, lateral = self._observe(p)
        self.records.seen.append(seen)
        self.records.seen_lateral.append(lateral)

    def _observe(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """L's camera now: a noisy pose for every patroller it sees, discretised: (N,) states
        (-1 unseen) and lateral offsets (NaN unseen)."""
        out = np.full(self.n, -1, dtype=int)
        lateral = np.full(self.n, np.nan)
        if not self.has_observer:
            return out, lateral
        px, py = p[: self.n, 0], p[: self.n, 1]
        seen = self.camera.sees(self.model, self.data, self.frame, px, py)
        idx = np.flatnonzero(seen)
        if len(idx) == 0:
            return out, lateral
        cs = self.frame.cell_size
        z = self._meas_rng.normal(size=(len(idx), 3))
        meas = p[idx].copy()
        meas[:, :2] += z[:, :2] * self.cfg.measurement_sigma * cs
        meas[:, 2] = wrap(meas[:, 2] + z[:, 2] * np.radians(self.cfg.measurement_sigma_deg))
        tsec = self.t * self.cfg.step_seconds
        measured = [
            (tsec, int(i), float(x), float(y), float(yaw))
            for i, (x, y, yaw) in zip(idx, meas, strict=True)
        ]
        self.records.measured(measured)
        # the robot-data discretisation (mirl.observations.discretise), one step at a time:
        # nearest cell (snapped onto the hallway within its tolerance) and nearest heading
        a = np.asarray(measured)
        step = PoseTracks(self.names, a[:, 0], a[:, 1].astype(int), a[:, 2], a[:, 3], a[:, 4],
                          source="L's camera")  # fmt: skip
        d = discretise(
            step, self.scenario, step_seconds=self.cfg.step_seconds, start_time=tsec, n_steps=1,
            drop_off_map=True, visible=self._visible_cells,
        ).trajectories  # fmt: skip
        out[d.robot] = self.domain.state_index(d.row, d.col, d.heading)
        if d.lateral is not None:
            lateral[d.robot] = d.lateral
        return out, lateral

    def decide(self) -> tuple[np.ndarray, np.ndarray]:
        """The patrollers' believed states and actions now (equilibrium at meetings).

        Returns
        -------
        states : ndarray of int, shape (N,)
            The states the patrollers believe they are in (from their estimated poses).
        actions : ndarray of int, shape (N,)
            Their policies' actions, replaced by game moves where two meet.
        """
        est = self.estimated_poses()
        s = self.discretise(est[: self.n])
        own = self.policies[np.arange(self.n), s]
        pairs = [
            (i, j)
            for i in range(self.n)
            for j in range(i + 1, self.n)
            if meeting(self.domain, s[i], s[j], own[i], own[j])
        ]

        def draw(k: int) -> tuple[int, int]:
            i, j = pairs[k]
            return self._draw(self._eq[i, j][0]), self._draw(self._eq[i, j][1])

        return s, meeting_actions(own, pairs, draw)

    def _draw(self, probs: np.ndarray) -> int:
        """A game action drawn from a (possibly mixed) equilibrium strategy."""
        k = int(np.searchsorted(np.cumsum(probs), self._game_rng.random(), "right"))
        return min(k, 2)

    def _set_targets(self, idx, states_rch, acts, lane) -> None:
        """Targets for robots ``idx`` from their intended (row, col, heading) and actions; in
        company they keep ``lane`` (m) to the right of the centre line."""
        r, c, h = states_rch.T
        x, y = self.frame.cell_centre(r, c)
        yaw = HEADING_YAWS[h]
        mode = np.select(
            [acts == FORWARD, (acts == TURN_LEFT) | (acts == TURN_RIGHT)], [DRIVE, PIVOT], HOLD
        )
        self.ctrl.set_targets(idx, mode, x, y, yaw, lane)

    def _observer_intended(self, action: int) -> tuple[np.ndarray, int]:
        r, c, h = self.observer_cell_heading()
        if action == FORWARD:
            dr, dc = HEADING_DELTAS[h]
            rr, cc = r + dr, c + dc
            rows, cols = self.map.shape
            if 0 <= rr < rows and 0 <= cc < cols and self.map.free[rr, cc]:
                r, c = rr, cc
        elif action == TURN_LEFT:
            h = (h + 1) % N_HEADINGS
        elif action == TURN_RIGHT:
            h = (h + 3) % N_HEADINGS
        return np.array([[r, c, h]]), action

    def step(self, observer_action: int | None = None) -> np.ndarray:
        """Advance one decision step.

        Parameters
        ----------
        observer_action : int, optional
            An index into :data:`~mirl.world.actions.ACTIONS` that drives L; None leaves it
            standing.

        Returns
        -------
        ndarray of int, shape (N,)
            The patrollers' true states at the new time.
        """
        s, acts = self.decide()
        self.records.believed.append(s)
        self.records.actions.append(acts)
        nxt = self.domain.intended[s, acts]
        self._set_targets(np.arange(self.n), self.domain.states[nxt], acts, self._lane)
        if self.has_observer and observer_action is not None:
            rch, a = self._observer_intended(int(observer_action))
            self._set_targets(np.array([self.n]), rch, np.array([a]), 0.0)
            self.observer_moved = True
        self._run_ticks(self.cfg.ticks_per_step)
        self.t += 1
        self._record_decision_time()
        return self.records.true[-1]

    def _run_ticks(self, k: int) -> None:
        m, d, cfg = self.model, self.data, self.cfg
        a = self._noise_a
        b = np.sqrt(1 - a * a) * self._noise_sd
        p = self.poses()
        for _ in range(k):
            self._noise = a * self._noise + b * self._loc_rng.normal(size=(self.m, 3))
            est = p + self._noise
            slow = crowded(p, self.frame.cell_size, cfg.pass_distance)
            # company among the patrollers only: L, hidden, must not change how they drive
            company = np.zeros(self.m, dtype=bool)
            company[: self.n] = in_company(p[: self.n], self.frame.cell_size,
                                           cfg.keep_right_within)  # fmt: skip
            d.ctrl[:] = self.ctrl.wheel_speeds(
                est[:, 0], est[:, 1], est[:, 2], slow, company
            ).ravel()
            mujoco.mj_step(m, d, nstep=cfg.substeps)
            p = self.poses()
            self.contact_log.update(d, self.t)
            self.records.tick(d.time, p)
            if self.has_observer and self.observer_moved:
                self.patroller_cameras.look(m, d, p, self.t)
