#!/usr/bin/env python3
"""Fits the polynomials of src/wavefront/math.rs: sin(2πs) = s·P(s²) and cos(2πs) = Q(s²)
on s in [-1/4, 1/4], by iteratively reweighted least squares on Chebyshev nodes (close to
minimax), then checks them in f32 Horner form against f64 sin/cos.

    pip install numpy && python3 scripts/fit_sincos.py
"""
import numpy as np

N = 4000
s = 0.25 * np.cos(np.pi * (np.arange(N) + 0.5) / N)
s = s[s > 0]
z = s * s


def fit(f, degree):
    a = np.vstack([z**i for i in range(degree + 1)]).T
    w = np.ones_like(f)
    for _ in range(60):
        c, *_ = np.linalg.lstsq(a * w[:, None], f * w, rcond=None)
        err = a @ c - f
        w = w * (1 + 5 * np.abs(err) / np.abs(err).max())
        w /= w.mean()
    return [float(np.float32(x)) for x in c]


def horner(c, z):
    r = np.float32(c[-1])
    for x in reversed(c[:-1]):
        r = np.float32(r * z + np.float32(x))
    return r


sin_c = fit(np.sin(2 * np.pi * s) / s, 4)
cos_c = fit(np.cos(2 * np.pi * s), 5)
print("sin:", sin_c)
print("cos:", cos_c)
ss = np.linspace(-0.25, 0.25, 200001).astype(np.float32)
zz = (ss * ss).astype(np.float32)
exact = 2 * np.pi * ss.astype(np.float64)
print("f32 max abs error: sin", np.abs(ss * horner(sin_c, zz) - np.sin(exact)).max(),
      "cos", np.abs(horner(cos_c, zz) - np.cos(exact)).max())
