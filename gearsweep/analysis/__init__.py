"""Numerics on arrays outside the time-stepping kernels: harmonic balance, jump detection, ..."""
