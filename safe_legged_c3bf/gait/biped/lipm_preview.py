"""ZMP preview control on the linear inverted pendulum (cart-table model), after Kajita 2003.

The centre of mass at constant height ``z_c`` obeys, per horizontal axis, the cart-table model

    x_{k+1} = A x_k + B u_k,   p_k = C x_k,   x = (position, velocity, acceleration),

with the CoM jerk ``u`` as input and the ZMP ``p = x - z_c/g * x''`` as output. The servo
controller of Katayama et al. (as used by Kajita et al., ICRA 2003) minimises

    J = sum_k  Qe e_k^2 + dx_k^T Qx dx_k + R du_k^2,   e_k = p_k - p_ref_k,

with gains from the discrete algebraic Riccati equation of the system augmented by the
integral of the ZMP error (``scipy.linalg.solve_discrete_are``). The control law is

    u_k = -Gi sum_{i<=k} e_i - Gx x_k - sum_{j=1..N} Gp_j p_ref_{k+j}.

Both horizontal axes share the gains and are updated together: a tick is one (N,) x (N, 2)
dot product plus a few 3x3 operations, a few microseconds.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_discrete_are

GRAVITY = 9.81


def cart_table_matrices(dt: float, z_c: float, g: float = GRAVITY):
    """Discrete cart-table model (A (3, 3), B (3,), C (3,)) for sample time ``dt``."""
    A = np.array([[1.0, dt, dt * dt / 2.0], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    B = np.array([dt**3 / 6.0, dt * dt / 2.0, dt])
    C = np.array([1.0, 0.0, -z_c / g])
    return A, B, C


def preview_gains(
    dt: float,
    z_c: float,
    horizon: float,
    q_e: float = 1.0,
    q_x: float = 0.0,
    r: float = 1e-6,
    g: float = GRAVITY,
) -> tuple[float, np.ndarray, np.ndarray]:
    """Servo preview gains (Gi, Gx (3,), Gp (N,)) for an ``horizon`` s preview.

    Args:
        dt: control sample time (s).
        z_c: CoM height (m).
        horizon: preview time (s); N = round(horizon / dt) future samples.
        q_e: weight on the ZMP tracking error.
        q_x: weight on the state increments.
        r: weight on the jerk increments.
        g: gravity (m/s^2).

    """
    if dt <= 0 or z_c <= 0 or horizon < dt or q_e <= 0 or r <= 0 or q_x < 0:
        raise ValueError("invalid preview control parameters")
    A, B, C = cart_table_matrices(dt, z_c, g)
    n_prev = int(round(horizon / dt))
    # Augmented system on (e_k, dx_k): e_{k+1} = e_k + CA dx_k + CB du_k - dp_ref_{k+1}.
    At = np.zeros((4, 4))
    At[0, 0] = 1.0
    At[0, 1:] = C @ A
    At[1:, 1:] = A
    Bt = np.concatenate([[C @ B], B]).reshape(4, 1)
    Qt = np.diag([q_e, q_x, q_x, q_x])
    Rt = np.array([[r]])
    P = solve_discrete_are(At, Bt, Qt, Rt)
    S = float(r + (Bt.T @ P @ Bt).item())
    K = (Bt.T @ P @ At).ravel() / S
    gi, gx = float(K[0]), K[1:].copy()
    Ac = At - Bt @ K.reshape(1, 4)
    It = np.array([1.0, 0.0, 0.0, 0.0])
    gp = np.empty(n_prev)
    gp[0] = -gi
    X = -Ac.T @ P @ It
    for j in range(1, n_prev):
        gp[j] = (Bt.ravel() @ X) / S
        X = Ac.T @ X
    return gi, gx, gp


class ZmpPreviewController:
    """Two-axis (x, y) ZMP preview controller with its own cart-table state.

    Call :meth:`reset` with the CoM position, then :meth:`step` once per ``dt`` with the ZMP
    reference for the current sample and the next ``n_preview`` samples.
    """

    def __init__(
        self,
        dt: float,
        z_c: float,
        horizon: float = 1.6,
        q_e: float = 1.0,
        q_x: float = 0.0,
        r: float = 1e-6,
        g: float = GRAVITY,
    ) -> None:
        """Compute the gains (see :func:`preview_gains` for the arguments)."""
        self.dt = float(dt)
        self.z_c = float(z_c)
        self.g = float(g)
        self.omega = float(np.sqrt(g / z_c))
        self.A, self.B, self.C = cart_table_matrices(dt, z_c, g)
        self.gi, self.gx, self.gp = preview_gains(dt, z_c, horizon, q_e, q_x, r, g)
        self.n_preview = self.gp.size
        #: (3, 2) state: rows position, velocity, acceleration; columns x, y.
        self.state = np.zeros((3, 2))
        self.error_sum = np.zeros(2)

    def reset(
        self,
        position: np.ndarray,
        velocity: np.ndarray | None = None,
        acceleration: np.ndarray | None = None,
    ) -> None:
        """Set the CoM state (each (2,)) and clear the error integral."""
        self.state = np.zeros((3, 2))
        self.state[0] = position
        if velocity is not None:
            self.state[1] = velocity
        if acceleration is not None:
            self.state[2] = acceleration
        self.error_sum = np.zeros(2)

    @property
    def zmp(self) -> np.ndarray:
        """ZMP (2,) of the current model state."""
        return self.C @ self.state

    @property
    def dcm(self) -> np.ndarray:
        """Divergent component of motion x + x'/omega (2,) of the model state."""
        return self.state[0] + self.state[1] / self.omega

    def step(self, zmp_ref: np.ndarray) -> np.ndarray:
        """Advance one sample; return the new (3, 2) state.

        Args:
            zmp_ref: (n_preview + 1, 2) ZMP reference at the current sample and the next
                ``n_preview`` samples (a shorter array is padded with its last row).

        """
        ref = np.asarray(zmp_ref, dtype=float)
        n = self.n_preview + 1
        if ref.shape[0] < n:
            ref = np.vstack([ref, np.repeat(ref[-1:], n - ref.shape[0], axis=0)])
        self.error_sum += self.C @ self.state - ref[0]
        u = -self.gi * self.error_sum - self.gx @ self.state - self.gp @ ref[1:n]
        self.state = self.A @ self.state + np.outer(self.B, u)
        return self.state

    def shift(self, offset: np.ndarray) -> None:
        """Translate the model CoM by ``offset`` (2,) without changing its dynamics."""
        self.state[0] += offset
