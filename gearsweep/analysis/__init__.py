"""Numerics on arrays beyond the time-stepping kernels (spectra, references, stability, advice)."""
