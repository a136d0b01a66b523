"""The paper's pendulum task: state (theta, omega), torque limited to [-5, 5], 150 steps.

Dynamics (a rigid pendulum, ``theta = 0`` upright, counter-clockwise positive):

.. math::  m l^2 \\ddot\\theta = m g l \\sin\\theta - b \\dot\\theta + u,
           \\qquad u \\in [-u_{max}, u_{max}]

integrated with classical Runge–Kutta (RK4), ``n_substeps`` steps of ``dt / n_substeps`` per
control step with the torque held constant (zero-order hold); ``theta`` is then wrapped to
``[-pi, pi)``. With ``b = 0`` and ``u = 0`` the energy
``E = m l^2 omega^2 / 2 + m g l cos(theta)`` is conserved up to the RK4 error (O(dt^4)).

The maximal torque (5 N m) is about half of ``m g l`` (9.81 N m): the pendulum cannot be
lifted directly and must be swung up; near the top a balancing controller catches it only
inside a bounded region of attraction. Whether a state is caught on this swing or needs one
more revolution changes the return abruptly, which gives the fixed policy's value function
the sharp discontinuities the paper is about.

Reward ``r = cos(theta)`` (``+1`` upright, ``-1`` hanging): smooth in the state, so every
discontinuity of the value comes from the policy and the dynamics, none from the reward.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numpy.typing import ArrayLike


@dataclass(frozen=True)
class PendulumParams:
    """Every physical and task constant of :class:`PaperPendulum`.

    Attributes
    ----------
    mass : float
        Point mass at the tip, kg.
    length : float
        Rod length, m (massless rod).
    gravity : float
        m s^-2.
    friction : float
        Viscous friction coefficient ``b``, N m s.
    max_torque : float
        Torque limit ``u_max``, N m (the paper's [-5, 5]).
    dt : float
        Control interval, s.
    n_substeps : int
        RK4 steps per control interval.
    max_speed : float
        ``|omega|`` is clipped to this after each step (rad/s); a safety bound of the
        observation space that the fixed policy never reaches.
    episode_length : int
        Steps per episode (the paper's 150, i.e. 7.5 s).
    """

    mass: float = 1.0
    length: float = 1.0
    gravity: float = 9.81
    friction: float = 0.05
    max_torque: float = 5.0
    dt: float = 0.05
    n_substeps: int = 4
    max_speed: float = 12.0
    episode_length: int = 150

    @property
    def inertia(self) -> float:
        """``m l^2``, kg m^2."""
        return self.mass * self.length**2

    @property
    def mgl(self) -> float:
        """Gravity torque at horizontal, ``m g l``, N m."""
        return self.mass * self.gravity * self.length


def wrap_angle(theta: ArrayLike) -> np.ndarray:
    """Angles wrapped to ``[-pi, pi)``; any shape."""
    return (np.asarray(theta) + math.pi) % (2 * math.pi) - math.pi


def energy(theta: np.ndarray, omega: np.ndarray, params: PendulumParams) -> np.ndarray:
    """Mechanical energy ``m l^2 omega^2 / 2 + m g l cos(theta)``, J; broadcasts."""
    return 0.5 * params.inertia * np.asarray(omega) ** 2 + params.mgl * np.cos(theta)


def dynamics_step(
    theta: np.ndarray, omega: np.ndarray, torque: np.ndarray, params: PendulumParams
) -> tuple[np.ndarray, np.ndarray]:
    """One control step for a batch of pendulums (torque clipped to the limit first).

    Parameters
    ----------
    theta, omega : ndarray, shape (n,) (or any common shape)
        Angle (rad, 0 upright) and angular velocity (rad/s).
    torque : ndarray, broadcastable to ``theta``
        Requested torque, N m; clipped to ``[-max_torque, max_torque]``.
    params : PendulumParams

    Returns
    -------
    theta, omega : ndarray, same shape
        Next state, ``theta`` wrapped to ``[-pi, pi)``, ``omega`` clipped to ``max_speed``.
    """
    u = np.clip(torque, -params.max_torque, params.max_torque)
    a_grav = params.gravity / params.length
    inv_i = 1.0 / params.inertia
    b = params.friction
    h = params.dt / params.n_substeps

    def accel(th: np.ndarray, om: np.ndarray) -> np.ndarray:
        return a_grav * np.sin(th) + inv_i * (u - b * om)

    th = np.asarray(theta, dtype=np.float64)
    om = np.asarray(omega, dtype=np.float64)
    for _ in range(params.n_substeps):
        k1t, k1o = om, accel(th, om)
        k2t, k2o = om + 0.5 * h * k1o, accel(th + 0.5 * h * k1t, om + 0.5 * h * k1o)
        k3t, k3o = om + 0.5 * h * k2o, accel(th + 0.5 * h * k2t, om + 0.5 * h * k2o)
        k4t, k4o = om + h * k3o, accel(th + h * k3t, om + h * k3o)
        th = th + h / 6.0 * (k1t + 2 * k2t + 2 * k3t + k4t)
        om = om + h / 6.0 * (k1o + 2 * k2o + 2 * k3o + k4o)
    return wrap_angle(th), np.clip(om, -params.max_speed, params.max_speed)


def reward(theta: ArrayLike) -> np.ndarray:
    """Reward ``cos(theta)`` of being at angle ``theta`` (before the step); broadcasts."""
    return np.cos(np.asarray(theta, dtype=np.float64))


#: Side of :meth:`PaperPendulum.render`'s image, pixels.
RENDER_SIZE = 128
#: The rod's length in that image, pixels.
ROD_PIXELS = 48


class PaperPendulum(gym.Env[np.ndarray, np.ndarray]):
    """The paper's pendulum task as a gymnasium environment.

    Observation ``(theta, omega)``, float32, ``theta`` in ``[-pi, pi)`` (0 = upright),
    ``omega`` in ``[-max_speed, max_speed]``; action: torque, shape (1,), in
    ``[-max_torque, max_torque]`` (out-of-range actions are clipped); reward ``cos(theta)``
    of the state the step starts from. Episodes never terminate; the registered id
    ``sb3_geogp/PaperPendulum-v0`` truncates them after ``episode_length`` (150) steps.

    Parameters
    ----------
    params : PendulumParams, optional
        Physical and task constants (defaults: the documented paper set-up).
    start_speed : float
        Reset draws ``theta ~ U[-pi, pi)`` and ``omega ~ U[-start_speed, start_speed]``
        (rad/s), i.e. uniformly over the ground-truth grid's box.
    render_mode : {None, "rgb_array"}
        ``"rgb_array"``: :meth:`render` returns the pendulum seen from the front, uint8,
        shape (:data:`RENDER_SIZE`, :data:`RENDER_SIZE`, 3): rod black, bob red, the pivot at
        the centre, upright ``theta = 0`` pointing up. SB3's ``make_vec_env`` asks for it.

    Notes
    -----
    ``reset(options={"state": (theta, omega)})`` starts from a given state instead.
    The state is kept in float64; observations are float32 copies.
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array"], "render_fps": 20}  # noqa: RUF012

    def __init__(
        self,
        params: PendulumParams | None = None,
        start_speed: float = 8.0,
        render_mode: str | None = None,
    ) -> None:
        super().__init__()
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.params = params or PendulumParams()
        if not 0 <= start_speed <= self.params.max_speed:
            raise ValueError(f"start_speed must be in [0, max_speed], got {start_speed}")
        self.start_speed = float(start_speed)
        self.render_mode = render_mode
        high = np.array([math.pi, self.params.max_speed], dtype=np.float32)
        self._high = high
        self.observation_space = spaces.Box(-high, high, dtype=np.float32)
        u = self.params.max_torque
        self.action_space = spaces.Box(-u, u, shape=(1,), dtype=np.float32)
        self.state = np.zeros(2, dtype=np.float64)

    def _obs(self) -> np.ndarray:
        obs = self.state.astype(np.float32)
        # float32 rounding can lift pi - eps to pi: keep the observation inside the box.
        return np.clip(obs, -self._high, self._high)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start a new episode; returns ``(obs, info)``, ``obs`` of shape (2,)."""
        super().reset(seed=seed)
        if options is not None and "state" in options:
            theta, omega = (float(v) for v in options["state"])
            self.state = np.array([wrap_angle(theta), omega], dtype=np.float64)
        else:
            self.state = np.array(
                [
                    self.np_random.uniform(-math.pi, math.pi),
                    self.np_random.uniform(-self.start_speed, self.start_speed),
                ]
            )
        return self._obs(), {}

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Apply torque ``action`` (shape (1,)) for ``dt``; returns the gymnasium 5-tuple."""
        torque = float(np.asarray(action, dtype=np.float64).reshape(-1)[0])
        theta, omega = self.state
        r = float(reward(theta))
        th, om = dynamics_step(
            np.array([theta]), np.array([omega]), np.array([torque]), self.params
        )
        self.state = np.array([th[0], om[0]])
        return self._obs(), r, False, False, {"energy": float(energy(th[0], om[0], self.params))}

    def render(self) -> np.ndarray | None:
        """Front view as an RGB image (``render_mode="rgb_array"``), else ``None``."""
        if self.render_mode != "rgb_array":
            return None
        n, theta = RENDER_SIZE, float(self.state[0])
        centre = (n - 1) / 2
        # Counter-clockwise from upright, image rows growing downwards.
        tip_row = centre - ROD_PIXELS * math.cos(theta)
        tip_col = centre - ROD_PIXELS * math.sin(theta)
        img = np.full((n, n, 3), 255, dtype=np.uint8)
        t = np.linspace(0.0, 1.0, 2 * ROD_PIXELS)
        rows = np.rint(centre + t * (tip_row - centre)).astype(int)
        cols = np.rint(centre + t * (tip_col - centre)).astype(int)
        img[rows, cols] = 0
        r, c = np.mgrid[0:n, 0:n]
        img[np.hypot(r - tip_row, c - tip_col) <= n / 25] = (220, 0, 0)
        img[np.hypot(r - centre, c - centre) <= n / 64] = (120, 120, 120)
        return img
