"""Side by side: our C3BF safety filter against cbfpy on the paper's problem, N obstacles.

Problem (the same QP for every library): the paper's collision-cone CBF for an
acceleration-controlled unicycle (``UnicycleModel``: state ``x, y, theta, v, omega``, input
``a`` [m/s^2], ``alpha`` [rad/s^2]), body point 0.2 m ahead, ``gamma = 1`` (``alpha(h) = h``),
limits ``a in [-2, 2]``, ``alpha in [-4, 4]``, cost ``||u - u_ref||^2``, N static circular
obstacles in seeded feasible clutter: 1-3 of them ahead (the reference violates their
constraints), the rest hold with margin at the reference and at the answer. Ours runs with
``margin = 0`` and ``v_eps = 0`` (the paper's barrier exactly, as cbfpy's is written here).
Each call perturbs the state slightly (consecutive odometry samples: warm starts realistic).
Every library is called on the same state in turn (interleaved: machine noise hits all alike)
for ``--calls`` calls per case after a warm-up; the time is one whole call (barrier terms and
QP), as numpy out. Outside the timing, every 10th of our answers is compared with OSQP at
tolerances 1e-12 on the same rows ("ours vs tight OSQP").

Peers (when installed): cbfpy 0.1.0 with its default solver (qpax, relaxed QP, tolerance
1e-3) and with ElastiQP (``backend='elastiqp'``, tolerance 1e-5, the loosest its config does
not warn about), with the CPU settings the cbfpy README recommends (float64, one thread).
Install them with ``pip install -e '.[bench]'`` (cbfpy, elastiqp[jax]; pulls JAX). Without
them the script says so and times ours alone.

Run:  python benchmarks/peer_comparison.py [--calls 2000] [--sizes 1 10 50 250]
"""

from __future__ import annotations

import argparse
import os
import time

# cbfpy README: CPU, float64, single-threaded XLA and BLAS (set before JAX is imported).
os.environ.setdefault("JAX_PLATFORMS", "cpu")
os.environ.setdefault("JAX_ENABLE_X64", "True")
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from safe_legged_c3bf.c3bf import (  # noqa: E402
    FilterStatus,
    Obstacles,
    SafetyFilter,
    UnicycleModel,
    c3bf_lie_derivatives,
)

OFFSET = 0.2
GAMMA = 1.0
U_MIN = np.array([-2.0, -4.0])
U_MAX = np.array([2.0, 4.0])
X0 = np.array([0.0, 0.0, 0.0, 1.0, 0.0])
U_REF = np.array([1.0, 0.0])
NOISE = np.array([0.01, 0.01, 0.01, 0.02, 0.02])  # state perturbation per call
MODEL = UnicycleModel(offset=OFFSET)


def ours() -> SafetyFilter:
    """Our filter on the paper's barrier (no margin, no speed regularisation)."""
    return SafetyFilter(MODEL, gamma=GAMMA, u_min=U_MIN, u_max=U_MAX, margin=0.0, v_eps=0.0)


def _constraints(centers, radii, u):
    """``Lf h + Lg h u + gamma h`` of each obstacle at ``X0`` for inputs ``u`` ``(k, 2)``."""
    obs = Obstacles.vertical(centers, radii)
    t = c3bf_lie_derivatives(MODEL, X0, obs.center, obs.velocity, obs.radius, obs.plane, v_eps=0.0)
    return t.h, t.lf_h[:, None] + GAMMA * t.h[:, None] + t.lg_h @ np.atleast_2d(u).T


def clutter(n: int, seed: int) -> Obstacles:
    """1-3 obstacles ahead whose constraints the reference violates, plus n - k others that
    hold with margin (``> 0.5`` m^2/s^2, ``h > 0.05``) at the reference and at the answer for
    the ones ahead: a feasible clutter where the QP carries every row."""
    rng = np.random.default_rng(seed)
    k = min(n, int(rng.integers(1, 4)))
    while True:
        ahead = np.c_[rng.uniform(2.0, 4.5, k), rng.uniform(-0.8, 0.8, k)]
        r_ahead = rng.uniform(0.3, 0.5, k)
        _, con = _constraints(ahead, r_ahead, U_REF)
        if not (con[:, 0] < 0.0).all():
            continue
        res = ours().filter(X0, U_REF, Obstacles.vertical(ahead, r_ahead))
        if res.status is FilterStatus.ACTIVE:
            break
    probes = np.array([U_REF, res.u_safe, 0.5 * (U_REF + res.u_safe)])
    centers, radii = [ahead], [r_ahead]
    have = k
    while have < n:
        c = rng.uniform(-15.0, 15.0, (4 * n, 2))
        r = rng.uniform(0.2, 0.6, 4 * n)
        far = np.hypot(c[:, 0], c[:, 1]) > r + 1.0
        c, r = c[far], r[far]
        h, con = _constraints(c, r, probes)
        ok = (h > 0.05) & (con.min(axis=1) > 0.5)
        take = min(n - have, int(ok.sum()))
        centers.append(c[ok][:take])
        radii.append(r[ok][:take])
        have += take
    return Obstacles.vertical(np.concatenate(centers), np.concatenate(radii))


def states(calls: int, seed: int) -> np.ndarray:
    """``calls`` states near ``X0`` (consecutive odometry samples)."""
    return X0 + np.random.default_rng(seed).normal(size=(calls, 5)) * NOISE


# ---------------------------------------------------------------------------- peers (cbfpy)
def cbfpy_missing() -> str | None:
    """None when cbfpy (and ElastiQP) import, else what to install."""
    try:
        import cbfpy  # noqa: F401
        import elastiqp.jax  # noqa: F401
    except ImportError as exc:
        return (
            f"cbfpy peers not installed ({exc}); install them with "
            "`pip install -e '.[bench]'` (cbfpy==0.1.0, elastiqp[jax]; pulls JAX). "
            "Timing ours alone."
        )
    return None


def cbfpy_filter(obs: Obstacles, backend: str, tol: float):
    """cbfpy's CBF for this problem: ``(call(x, u_ref) -> u, compile time [s])``.

    The barrier is the paper's ``h = <p, v> + ||v|| sqrt(||p||^2 - r^2)`` with ``p`` the
    obstacle centre minus the body point and ``v`` minus the body point's velocity (static
    obstacles); cbfpy differentiates it. The obstacles are passed per call (arguments).
    """
    import jax.numpy as jnp
    from cbfpy import CBF, CBFConfig

    class C3BFConfig(CBFConfig):
        def __init__(self):
            super().__init__(
                n=5, m=2, u_min=U_MIN, u_max=U_MAX, solver_tol=tol, backend=backend,
                init_args=(obs.center, obs.radius),
            )

        def f(self, z, centers, radii):
            return jnp.array([z[3] * jnp.cos(z[2]), z[3] * jnp.sin(z[2]), z[4], 0.0, 0.0])

        def g(self, z, centers, radii):
            return jnp.array([[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])

        def h_1(self, z, centers, radii):
            c, s = jnp.cos(z[2]), jnp.sin(z[2])
            body = jnp.array([z[0] + OFFSET * c, z[1] + OFFSET * s])
            vel = jnp.array([z[3] * c - OFFSET * z[4] * s, z[3] * s + OFFSET * z[4] * c])
            p = centers - body
            v = -vel
            pv = p @ v
            return pv + jnp.linalg.norm(v) * jnp.sqrt(jnp.sum(p * p, axis=1) - radii**2)

        def alpha(self, h, centers, radii):
            return GAMMA * h

    import contextlib
    import io

    with contextlib.redirect_stdout(io.StringIO()):  # its tolerance notes
        cbf = CBF.from_config(C3BFConfig())
    centers, radii = obs.center, obs.radius
    t0 = time.perf_counter()
    np.asarray(cbf.safety_filter(X0, U_REF, centers, radii))  # jit compile
    compile_s = time.perf_counter() - t0

    def call(x, u_ref):
        return np.asarray(cbf.safety_filter(x, u_ref, centers, radii))

    return call, compile_s


PEERS = {"cbfpy (qpax)": ("qpax", 1e-3), "cbfpy (ElastiQP)": ("elastiqp", 1e-5)}


# ---------------------------------------------------------------------------- reference
def osqp_reference(obs: Obstacles, x, u_ref):
    """The same QP (the filter's rows at ``x``, unit norm) by OSQP at tolerances 1e-12,
    polished: ``u``, or None unless OSQP reports it solved."""
    import osqp
    import scipy.sparse as sp

    t = c3bf_lie_derivatives(MODEL, x, obs.center, obs.velocity, obs.radius, obs.plane,
                             v_eps=0.0)
    norms = np.linalg.norm(t.lg_h, axis=1)
    A, b = t.lg_h / norms[:, None], -(t.lf_h + GAMMA * t.h) / norms
    s = osqp.OSQP()
    s.setup(sp.csc_matrix(np.eye(2)), -u_ref, sp.csc_matrix(np.vstack([A, np.eye(2)])),
            np.r_[b, U_MIN], np.r_[np.full(len(b), np.inf), U_MAX], verbose=False,
            eps_abs=1e-12, eps_rel=1e-12, eps_prim_inf=1e-14, max_iter=400000,
            polishing=True, polish_refine_iter=20)
    res = s.solve(raise_error=False)
    return res.x if res.info.status == "solved" else None


# ---------------------------------------------------------------------------- timing
def run_case(n: int, calls: int, with_peers: bool, warmup: int = 50) -> dict:
    """Interleaved timing of every library on one clutter of ``n`` obstacles."""
    obs = clutter(n, seed=n)
    flt = ours()
    libs = {"ours": lambda x, u: flt.filter(x, u, obs).u_safe}
    compile_s = {}
    if with_peers:
        for name, (backend, tol) in PEERS.items():
            libs[name], compile_s[name] = cbfpy_filter(obs, backend, tol)
    xs = states(warmup + calls, seed=1000 + n)
    times = {name: np.empty(calls) for name in libs}
    answers = {name: np.empty((calls, 2)) for name in libs}
    paths: dict[str, int] = {}
    perf = time.perf_counter
    for i, x in enumerate(xs):
        for name, fn in libs.items():
            t0 = perf()
            u = fn(x, U_REF)
            dt = perf() - t0
            if i >= warmup:
                times[name][i - warmup] = dt
                answers[name][i - warmup] = u
        if i >= warmup:
            res = flt.filter(x, U_REF, obs)  # outside the timing: which path answered
            key = f"{res.status.value}/{res.solver}"
            paths[key] = paths.get(key, 0) + 1
    violated = int((_constraints(obs.center, obs.radius, U_REF)[1] < 0).sum())
    # Outside the timing: our answers against a tight OSQP of the same rows (every 10th call).
    du_osqp = 0.0
    for x, u in zip(xs[warmup::10], answers["ours"][::10], strict=True):
        ref = osqp_reference(obs, x, U_REF)
        if ref is not None:
            du_osqp = max(du_osqp, float(np.abs(u - ref).max()))
    return {"n": n, "times": times, "answers": answers, "compile": compile_s,
            "paths": paths, "violated": violated, "du_osqp": du_osqp}


def report(case: dict) -> list[str]:
    """Table rows of one case: median, p99, ratio to ours, max |u - u_ours|."""
    t, u = case["times"], case["answers"]
    ours_med = np.median(t["ours"])
    out = []
    for name in t:
        med, p99 = np.median(t[name]) * 1e6, np.percentile(t[name], 99) * 1e6
        ratio = np.median(t[name]) / ours_med
        diff = float(np.abs(u[name] - u["ours"]).max())
        comp = case["compile"].get(name)
        comp_s = f"{comp:8.2f}" if comp is not None else f"{'-':>8}"
        out.append(
            f"{case['n']:>5} {name:<18} {med:>10.1f} {p99:>10.1f} {ratio:>8.2f} "
            f"{diff:>11.2e} {comp_s}"
        )
    fastest = min((np.median(t[k]) for k in t if k != "ours"), default=None)
    mix = ", ".join(f"{k} {v}" for k, v in sorted(case["paths"].items()))
    line = (f"      rows violated by u_ref: {case['violated']}; our paths: {mix}; "
            f"ours vs tight OSQP: max |du| {case['du_osqp']:.1e}")
    if fastest is not None:
        line += f"; ours / fastest peer = {ours_med / fastest:.2f}"
    out.append(line)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=2000, help="timed calls per case")
    ap.add_argument("--sizes", type=int, nargs="+", default=[1, 10, 50, 250])
    ap.add_argument("--ours-only", action="store_true", help="skip the peers")
    args = ap.parse_args()
    missing = None if args.ours_only else cbfpy_missing()
    if missing:
        print(missing)
    with_peers = not args.ours_only and missing is None
    print(f"{'N':>5} {'library':<18} {'median us':>10} {'p99 us':>10} {'x ours':>8} "
          f"{'max|du|':>11} {'compile s':>8}")
    for n in args.sizes:
        for line in report(run_case(n, args.calls, with_peers)):
            print(line, flush=True)


if __name__ == "__main__":
    main()
