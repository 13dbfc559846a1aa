"""The ``jump`` summary of a continued (up and down) rattle study, from its result Dataset.

``jump_summary(ds)`` applies ``gearsweep.analysis.jumps.find_jumps`` (the criterion is stated in
its module docstring) to the amplitude ``p_pp / 2`` of the ``up`` and ``down`` sweeps of every
case and returns the speeds where each sweep jumps and the hysteresis band between them, on the
study's other dims.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from gearsweep.analysis.jumps import find_jumps

JUMP_VARIABLES = {
    "jump_up_speed": ("rpm", "speed at which the run-up jumps (NaN: no jump)"),
    "jump_up_size": ("1", "relative amplitude change of the run-up jump (negative: drop)"),
    "jump_down_speed": ("rpm", "speed at which the run-down jumps (NaN: no jump)"),
    "jump_down_size": ("1", "relative amplitude change of the run-down jump, towards lower speed"),
    "hysteresis_low": ("rpm", "lower end of the jump hysteresis band"),
    "hysteresis_high": ("rpm", "upper end of the jump hysteresis band"),
    "hysteresis_width": ("rpm", "width of the jump hysteresis band (0: none)"),
}


def jump_summary(ds: xr.Dataset, threshold: float = 0.25) -> xr.Dataset:
    """Jump speeds and hysteresis band of every up/down sweep of a continued study.

    Parameters
    ----------
    ds : xarray.Dataset
        Result of a study with ``continuation: [up, down]`` (dims ``direction`` and ``speed``).
    threshold : float
        Relative amplitude change that marks a jump [1] (see ``analysis.jumps``).

    Returns
    -------
    xarray.Dataset
        ``JUMP_VARIABLES`` on the study's dims other than ``direction`` and ``speed``.
    """
    if "direction" not in ds.dims or not {"up", "down"} <= set(ds["direction"].values.tolist()):
        raise ValueError("a jump summary needs a study continued both up and down")
    amp = 0.5 * ds["p_pp"]
    up = amp.sel(direction="up")
    down = amp.sel(direction="down")
    other = [d for d in up.dims if d != "speed"]
    up = up.transpose(*other, "speed")
    down = down.transpose(*other, "speed")
    js = find_jumps(ds["speed"].values, up.values, down.values, threshold)
    coords = {d: ds[d] for d in other}
    out = {}
    values = {"jump_up_speed": js.up_speed, "jump_up_size": js.up_size,
              "jump_down_speed": js.down_speed, "jump_down_size": js.down_size,
              "hysteresis_low": js.band_low, "hysteresis_high": js.band_high,
              "hysteresis_width": js.width}
    for name, (units, long_name) in JUMP_VARIABLES.items():
        out[name] = xr.DataArray(np.asarray(values[name]), dims=other, coords=coords,
                                 attrs={"units": units, "long_name": long_name})
    res = xr.Dataset(out)
    res.attrs["jump_threshold"] = threshold
    return res
