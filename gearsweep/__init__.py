"""gearsweep: batch parameter studies of nonlinear spur gear dynamics.

Layout (one job per folder):

* ``gearsweep.kernels`` -- Numba kernels on floats and arrays in SI units (no I/O, no xarray).
* ``gearsweep.gear``    -- physics of the gear pair: geometry, tooth compliance, STE, stiffness.
* ``gearsweep.model``   -- Eq. (6)-(7) of the paper: from physical inputs to kernel coefficients.
* ``gearsweep.study``   -- YAML -> validated study -> cases -> kernel calls -> xarray -> netCDF.
* ``gearsweep.plot``    -- plotting functions that take a Dataset (and an ``ax``).
* ``gearsweep.cli``     -- the thin command-line interface.
"""

__version__ = "0.1.0"
