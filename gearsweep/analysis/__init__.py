"""Numerics on arrays beyond time stepping: spectra, harmonic balance, stability, references."""
