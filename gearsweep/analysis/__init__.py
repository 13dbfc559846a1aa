"""Numerics on arrays other than time stepping: no files, YAML, xarray, dask or plotting here."""
