"""ProMP rollout time: 7 demonstrations of 1,000 samples in 2-D, best of 300 calls per constraint set.

    python benchmarks/bench_promp_rollout.py
"""

import time

import numpy as np

from skillbank import Constraints
from skillbank.representations import ProMP


def main():
    rng = np.random.default_rng(0)
    s = np.linspace(0, 1, 1000)
    Ys = [np.column_stack([s + 0.01 * rng.standard_normal(), np.sin(np.pi * s) * (1 + 0.1 * k)])
          for k in range(7)]
    model = ProMP().fit(Ys)
    cases = (("none", Constraints()),
             ("start+goal", Constraints(start=[0.1, 0.0], goal=[1.1, 0.1])),
             ("start+goal+via", Constraints(start=[0.1, 0.0], goal=[1.1, 0.1], via=[(0.5, [0.5, 1.2])])))
    for name, c in cases:
        for _ in range(3):
            model.reproduce(c)
        times = []
        for _ in range(300):
            t0 = time.perf_counter()
            model.reproduce(c)
            times.append(time.perf_counter() - t0)
        print(f"{name}: best {min(times) * 1e3:.3f} ms, median {np.median(times) * 1e3:.3f} ms")


if __name__ == "__main__":
    main()
