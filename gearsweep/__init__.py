"""gearsweep: batch parameter studies of nonlinear spur gear dynamics.

    import gearsweep
    ds = gearsweep.run("studies/whine_speed_sweep.yaml")   # validate, run in-process -> Dataset
    ds = gearsweep.open_result("results/fig08_rattle.nc")
    print(gearsweep.advise("studies/fig08_rattle.yaml", target=1e-4))  # steps for an accuracy

Layers, each importing only from those below it (``docs/architecture.md``; import-linter checks):

* ``gearsweep.cli``      -- the command line over ``api``.
* ``gearsweep.api``      -- ``run``, ``estimate``, ``advise``, ``open_result``,
  ``result_model``, ``result_study``.
* ``gearsweep.study``    -- YAML -> schema -> plan -> chunks -> kernel -> Dataset -> netCDF.
  ``gearsweep.plot``     -- plot functions that draw Datasets (never import ``study``).
* ``gearsweep.analysis`` -- harmonic balance, Floquet, spectra, references, the step advisor.
* ``gearsweep.gear``     -- tooth and mesh physics: geometry, compliance, STE, k(t) per load.
* ``gearsweep.model``    -- the one case model of Eq. (6)-(7)/(11) and its kernel arguments.
* ``gearsweep.kernels``  -- Numba kernels and method facts on floats and arrays in SI units.
* ``gearsweep.units``, ``errors``, ``jit`` -- units, exceptions, JIT options.
"""

from gearsweep._version import __version__

_API = ("run", "estimate", "advise", "open_result", "result_model", "result_study")
_MODULES = ("analysis", "api", "errors", "gear", "kernels", "model", "plot", "study", "units")
"""Subpackages and modules reachable as attributes after ``import gearsweep`` alone
(``gearsweep.units.si_values(da)``, as the README writes it, raised AttributeError until some
API call had imported them; an outside tester's finding)."""


def __getattr__(name: str):
    # The API and the modules are imported on first use: ``import gearsweep`` stays as cheap as
    # its version, and the CLI loads only what a command needs.
    if name in _API:
        from gearsweep import api

        return getattr(api, name)
    if name in _MODULES:
        import importlib

        return importlib.import_module(f"gearsweep.{name}")
    raise AttributeError(f"module 'gearsweep' has no attribute {name!r}")


def __dir__() -> list[str]:
    # what a notebook's completion lists (``gearsweep.<TAB>``): the API too, without loading it
    return sorted({*globals(), *_API, *_MODULES})


__all__ = ["__version__", *_API]
