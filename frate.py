import time, numpy as np, glmls
rng = np.random.default_rng(0)
p = rng.uniform(0, 255, (64, 3)); q = p + rng.normal(0, 4, (64, 3))
pts = rng.uniform(0, 255, (1_000_000, 3))
for t in ("rigid", "similarity", "affine"):
    m = glmls.MLS(p, q, transform=t)
    m(pts[:1000])
    ts = []
    for _ in range(3):
        t0 = time.perf_counter(); m(pts); ts.append(time.perf_counter() - t0)
    print(t, "1M pts", round(min(ts), 3), "s")
