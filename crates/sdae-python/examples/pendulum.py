"""The planar pendulum from Python: a few simulated paths, the strong error of each scheme
against its run time, and E[cos phi_T] with its 95% interval, by hand from simulated paths and
by the expectation helper.

Run with `python examples/pendulum.py` after `pip install crates/sdae-python` (and
`pip install matplotlib` for the figures, written to pendulum-paths.png and
pendulum-error-vs-time.png).
"""

import time

import numpy as np

import sdae

scene = sdae.scene("pendulum")
print(scene, "-", scene.description)

# A few paths, every 8th of 1024 steps recorded.
few = sdae.simulate(scene, "half-explicit-practical", paths=4, steps=1024, seed=1, every=8)
print(few)

# E[cos phi_T] over 10 000 paths, with phi the angle from the downward vertical (r = (sin phi,
# -cos phi) for a unit pendulum), so cos phi = -y / |r|, and a 95% interval.
for scheme in ("half-explicit-practical", "projected-euler-maruyama"):
    start = time.perf_counter()
    many = sdae.simulate(scene, scheme, paths=10_000, steps=256, seed=2, every=256, threads=2)
    seconds = time.perf_counter() - start
    end = many.positions[:, -1, :]
    cos_phi = -end[:, 1] / np.linalg.norm(end, axis=1)
    mean = cos_phi.mean()
    half = 1.96 * cos_phi.std(ddof=1) / np.sqrt(cos_phi.size)
    print(f"{scheme}: E[cos phi_T] = {mean:.5f} +- {half:.5f} ({seconds:.2f} s)")

# The same expectation to root mean square accuracy 0.01, by the estimator a short pilot
# predicts cheapest: standard Monte Carlo, randomized QMC, MLMC or MLQMC.
found = sdae.expectation(scene, "cos_angle", eps=1e-2)
print(found)

# Strong errors against a reference 2^4 times finer than the finest level, with run time.
report = sdae.convergence(scene, quick=True)
print(report.markdown.splitlines()[0])

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: no figures")
else:
    fig, ax = plt.subplots(figsize=(5, 5))
    for p in range(few.positions.shape[0]):
        ax.plot(few.positions[p, :, 0], few.positions[p, :, 1], lw=0.8)
    ax.set_aspect("equal")
    ax.set_title(f"{scene.name}: {few.positions.shape[0]} paths, {few.scheme}")
    fig.savefig("pendulum-paths.png", dpi=120)
    print("wrote pendulum-paths.png")

    fig, ax = plt.subplots(figsize=(6, 4.5))
    for k, scheme in enumerate(sorted({row["scheme"] for row in report.rows})):
        rows = [r for r in report.rows if r["scheme"] == scheme and r["error_r"] is not None]
        seconds = [r["seconds_per_path"] for r in rows]
        errors = [r["error_r"] for r in rows]
        ax.loglog(seconds, errors, "o-", label=scheme, ms=3, color=plt.cm.tab20(k))
    ax.set_xlabel("run time per path (s)")
    ax.set_ylabel("strong error of r (L2 over paths)")
    ax.set_title(f"{scene.name}: error against run time")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig("pendulum-error-vs-time.png", dpi=120)
    print("wrote pendulum-error-vs-time.png")
