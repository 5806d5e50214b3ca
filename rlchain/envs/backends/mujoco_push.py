"""MuJoCoPushCube-v0: push a cube to a goal on a table, simulated by MuJoCo (the ``mujoco`` package), many
envs in one process, written to EmbodiChain's env contract (:mod:`rlchain.envs.backends.embodichain_env`).

The scene: a table (a plane with friction), a 0.1 m cube of 0.5 kg on a free joint (it slides, tips and
turns as MuJoCo's contact solver says), and a pusher: a vertical cylinder (radius 0.02 m) at the cube's
height on two slide joints, driven by velocity actuators. An action a in [-1, 1]^2 is the pusher's target
planar velocity, ``a * max_speed`` (0.5 m/s); each decision holds it for ``substeps`` physics steps of
0.01 s (5: 20 decisions a second). All envs step in one ``mujoco.rollout`` call from their stacked states.

Starts and success test as EmbodiChain's push_cube (``embodichain_tasks/configs/agents/rl/push_cube``):
the cube within 0.2 m of its spot (the table's centre here), the goal anywhere within 0.3 m of the
centre (a goal nearer the cube than ``min_start_distance`` is drawn again), the pusher near (0, -0.4);
success when the cube's planar distance to the goal is under
``success_threshold`` (0.1 m), which ends the episode (as EmbodiChain's ``terminated = success | fail``);
100-decision episodes (their gym_config's ``max_episode_steps``).

``info['rewards']`` holds every term unweighted, EmbodiChain's four under their names and two progress
terms (the change of a distance in one decision, as their ``incremental_distance_to_target``):

- ``reaching_reward``: 1 - tanh(8 d), d the pusher's distance to the pushing point behind the cube (the
  point where the pusher touches the cube's far side from the goal);
- ``goal_distance_reward``: exp(-d^2 / (2 * 0.12^2)), d the cube's planar distance to the goal;
- ``action_penalty``: -|a - a_prev|^2;
- ``success_bonus``: 1 on success;
- ``reach_progress``: how much nearer (m) the pusher came to the pushing point along the way around the
  cube (see ``_distances``);
- ``goal_progress``: how much nearer (m) the cube came to the goal.

The reward is their sum weighted by ``reward_weights`` (:data:`DEFAULT_WEIGHTS`; missing terms weigh 0).
Observation (a nested dict, flattened in sorted-key order, 18 numbers): pusher position and velocity;
cube position, velocity and yaw (sin, cos of 4 x yaw: a square looks the same every quarter turn);
goal position; the cube-to-goal, pusher-to-cube and pusher-to-pushing-point vectors. Positions and
velocities are multiplied by ``obs_scale`` so that the workspace spans about [-2, 2].
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import torch

from rlchain.envs.backends.embodichain_env import contract_builder

DEFAULT_WEIGHTS = {"reaching_reward": 0.03, "goal_distance_reward": 0.0, "action_penalty": 0.01,
                   "success_bonus": 10.0, "reach_progress": 5.0, "goal_progress": 20.0}
"""Weights that learn here (docs/robot_learning.md says why EmbodiChain's own weights do not)."""

EMBODICHAIN_WEIGHTS = {"reaching_reward": 0.03, "goal_distance_reward": 0.8, "action_penalty": 0.01,
                       "success_bonus": 10.0}
"""EmbodiChain push_cube's gym_config weights (its action penalty is already negative, hence +0.01)."""

HALF = 0.05  # cube half size (m)
RADIUS = 0.02  # pusher radius (m)
LIMIT = 0.6  # pusher joint range and table half width (m)
AROUND = 0.1  # clearance of a pusher going around the cube, from the cube's centre (its corner is at 0.071)

SCENE = f"""
<mujoco model="push_cube">
  <option timestep="0.01" integrator="implicitfast"/>
  <default><geom friction="0.6 0.005 0.0001"/></default>
  <worldbody>
    <geom name="table" type="plane" size="1 1 0.05" contype="1" conaffinity="1"/>
    <body name="pusher" pos="0 0 {HALF}">
      <joint name="px" type="slide" axis="1 0 0" range="{-LIMIT} {LIMIT}" limited="true"/>
      <joint name="py" type="slide" axis="0 1 0" range="{-LIMIT} {LIMIT}" limited="true"/>
      <geom name="pusher" type="cylinder" size="{RADIUS} 0.04" mass="1" contype="2" conaffinity="2"/>
    </body>
    <body name="cube" pos="0 0 {HALF}">
      <freejoint name="cube"/>
      <geom name="cube" type="box" size="{HALF} {HALF} {HALF}" mass="0.5" contype="3" conaffinity="3"/>
    </body>
  </worldbody>
  <actuator>
    <velocity joint="px" kv="100" ctrlrange="-1 1" forcerange="-60 60"/>
    <velocity joint="py" kv="100" ctrlrange="-1 1" forcerange="-60 60"/>
  </actuator>
</mujoco>
"""


class MuJoCoPushCube:
    """``num_envs`` push-cube tasks in MuJoCo, EmbodiChain's env contract (see the module docstring)."""

    def __init__(self, num_envs: int, device: Any = "cpu", max_episode_steps: int = 100,
                 success_threshold: float = 0.1, substeps: int = 5, max_speed: float = 0.5,
                 obs_scale: float = 5.0, reward_weights: dict[str, float] | None = None,
                 cube_range: float = 0.2, goal_range: float = 0.3, min_start_distance: float = 0.0,
                 seed: int | None = None) -> None:
        import mujoco  # the `mujoco` extra; imported when the env is built
        from mujoco import rollout

        self._mujoco, self._rollout = mujoco, rollout
        self.num_envs, self.device = int(num_envs), torch.device(device)
        self.max_episode_steps, self.success_threshold = int(max_episode_steps), float(success_threshold)
        self.substeps, self.max_speed, self.obs_scale = int(substeps), float(max_speed), float(obs_scale)
        self.cube_range, self.goal_range = float(cube_range), float(goal_range)
        self.min_start_distance = float(min_start_distance)
        weights = DEFAULT_WEIGHTS if reward_weights is None else reward_weights
        unknown = set(weights) - set(DEFAULT_WEIGHTS)
        if unknown:
            raise ValueError(f"reward_weights: unknown term(s) {sorted(unknown)} (terms: {sorted(DEFAULT_WEIGHTS)})")
        self.weights = {k: float(v) for k, v in weights.items()}
        self.model = mujoco.MjModel.from_xml_string(SCENE)
        self.data = mujoco.MjData(self.model)
        self.spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.nstate = mujoco.mj_stateSize(self.model, self.spec)
        self.q0 = 1  # the state vector starts with time, then qpos (pusher x, y; cube xyz + quat), qvel
        self.v0 = 1 + self.model.nq
        self.state_row = np.zeros(self.nstate)
        mujoco.mj_getState(self.model, self.data, self.state_row, self.spec)
        n = self.num_envs
        self.state = np.tile(self.state_row, (n, 1))
        self.goal = np.zeros((n, 2))
        self.last_action = np.zeros((n, 2))
        self.elapsed = np.zeros(n, dtype=np.int64)
        self._out = np.zeros((n, self.substeps, self.nstate))
        self.rng = np.random.default_rng(seed)
        self.single_action_space = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)

    # -- state --------------------------------------------------------------------------------------
    def _parts(self) -> tuple[np.ndarray, ...]:
        s, q, v = self.state, self.q0, self.v0
        return s[:, q:q + 2], s[:, v:v + 2], s[:, q + 2:q + 4], s[:, v + 2:v + 4], s[:, q + 5:q + 9]

    def _reset_rows(self, rows: np.ndarray) -> None:
        k = rows.size
        if k == 0:
            return
        s = np.tile(self.state_row, (k, 1))
        q = self.q0
        s[:, q] = self.rng.uniform(-0.05, 0.05, k)
        s[:, q + 1] = self.rng.uniform(-0.45, -0.35, k)
        s[:, q + 2:q + 4] = self.rng.uniform(-self.cube_range, self.cube_range, (k, 2))
        s[:, q + 4] = HALF
        s[:, q + 5:q + 9] = (1.0, 0.0, 0.0, 0.0)
        self.state[rows] = s
        goal = self.rng.uniform(-self.goal_range, self.goal_range, (k, 2))
        near = np.linalg.norm(goal - s[:, q + 2:q + 4], axis=1) < self.min_start_distance
        while near.any():  # redraw goals that start too near the cube
            goal[near] = self.rng.uniform(-self.goal_range, self.goal_range, (int(near.sum()), 2))
            near = np.linalg.norm(goal - s[:, q + 2:q + 4], axis=1) < self.min_start_distance
        self.goal[rows] = goal
        self.last_action[rows] = 0.0
        self.elapsed[rows] = 0

    def _obs(self) -> dict:
        ee, ee_vel, cube, cube_vel, quat = self._parts()
        to_goal = self.goal - cube
        push_point = cube - to_goal / np.maximum(np.linalg.norm(to_goal, axis=1), 1e-6)[:, None] * (HALF + RADIUS)
        w, z = quat[:, 0], quat[:, 3]
        yaw = 2.0 * np.arctan2(z, w)
        k = self.obs_scale
        t = lambda x: torch.as_tensor(np.asarray(x, dtype=np.float32), device=self.device)
        return {"robot": {"ee_pos": t(k * ee), "ee_vel": t(k * ee_vel)},
                "object": {"cube_pos": t(k * cube), "cube_vel": t(k * cube_vel),
                           "cube_yaw": t(np.stack((np.sin(4 * yaw), np.cos(4 * yaw)), 1)),
                           "goal_pos": t(k * self.goal), "cube_to_goal": t(k * (self.goal - cube)),
                           "ee_to_cube": t(k * (cube - ee)), "ee_to_push_point": t(k * (push_point - ee))}}

    def _distances(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(pusher to the pushing point straight, the same around the cube, cube to goal), planar, in metres.

        Around the cube: a pusher not yet behind the cube goes by the cube's side (``AROUND`` from its
        centre, on the pusher's side) and its back corner on that side, then to the pushing point; the path
        a pusher must take without shoving the cube away from the goal."""
        ee, _, cube, _, _ = self._parts()
        to_goal = self.goal - cube
        d_goal = np.linalg.norm(to_goal, axis=1)
        u = to_goal / np.maximum(d_goal, 1e-6)[:, None]
        push = cube - u * (HALF + RADIUS)
        straight = np.linalg.norm(ee - push, axis=1)
        rel = ee - cube
        along = (rel * u).sum(1)
        side = rel - along[:, None] * u
        norm = np.linalg.norm(side, axis=1)
        side = np.where(norm[:, None] > 1e-6, side / np.maximum(norm, 1e-6)[:, None], np.stack((-u[:, 1], u[:, 0]), 1))
        beside, corner = cube + AROUND * side, cube + AROUND * (side - u)
        to_push = np.linalg.norm(corner - push, axis=1)
        around = np.where(along > 0.0, np.linalg.norm(ee - beside, axis=1) + AROUND + to_push,
                          np.where(along > -AROUND, np.linalg.norm(ee - corner, axis=1) + to_push, straight))
        return straight, around, d_goal

    # -- the contract ------------------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: Any = None) -> tuple[dict, dict]:
        if seed is not None:
            self.rng = np.random.default_rng(seed)
        self._reset_rows(np.arange(self.num_envs))
        return self._obs(), {}

    def step(self, action: torch.Tensor) -> tuple[dict, torch.Tensor, torch.Tensor, torch.Tensor, dict]:
        a = np.clip(action.detach().cpu().numpy().astype(np.float64).reshape(self.num_envs, 2), -1.0, 1.0)
        _, around0, d_goal0 = self._distances()
        control = (a * self.max_speed)[:, None, :]
        self._rollout.rollout(self.model, self.data, self.state, control, nstep=self.substeps,
                              state=self._out)
        self.state = self._out[:, -1].copy()
        self.elapsed += 1
        d_reach, around, d_goal = self._distances()
        success = d_goal < self.success_threshold
        terms = {"reaching_reward": 1.0 - np.tanh(8.0 * d_reach),
                 "goal_distance_reward": np.exp(-d_goal ** 2 / (2 * 0.12 ** 2)),
                 "action_penalty": -np.square(a - self.last_action).sum(1),
                 "success_bonus": success.astype(np.float64),
                 "reach_progress": around0 - around, "goal_progress": d_goal0 - d_goal}
        reward = sum(self.weights.get(k, 0.0) * v for k, v in terms.items())
        self.last_action = a
        truncated = self.elapsed >= self.max_episode_steps
        t = lambda x, dt=torch.float32: torch.as_tensor(np.asarray(x), device=self.device).to(dt)
        info = {"success": t(success, torch.bool), "fail": torch.zeros(self.num_envs, dtype=torch.bool),
                "elapsed_steps": t(self.elapsed.copy(), torch.int64),
                "rewards": {k: t(v) for k, v in terms.items()}, "metrics": {"distance_to_goal": t(d_goal)}}
        done = success | truncated
        self._reset_rows(np.flatnonzero(done))  # same-step auto-reset, no final observation (the contract)
        return self._obs(), t(reward), t(success, torch.bool), t(truncated & ~success, torch.bool), info

    def get_state(self) -> dict:
        return {"state": self.state.copy(), "goal": self.goal.copy(), "last_action": self.last_action.copy(),
                "elapsed": self.elapsed.copy()}

    def set_state(self, state: dict) -> None:
        for key in ("state", "goal", "last_action", "elapsed"):
            setattr(self, key, np.array(state[key], copy=True))

    def close(self) -> None:
        pass


ENV_BUILDERS = {"MuJoCoPushCube-v0": contract_builder("MuJoCoPushCube-v0", MuJoCoPushCube)}
"""``env_name`` -> builder, for :data:`rlchain.registry.ENVS` (rlchain.builtins registers it)."""
