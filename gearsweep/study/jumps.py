"""The ``jump`` summary of a continued (up and down) rattle study, from its result Dataset.

``jump_summary(ds)`` applies ``gearsweep.analysis.jumps.find_jumps`` (the criterion is stated in
its module docstring) to the amplitude ``p_pp / 2`` of the ``up`` and ``down`` sweeps of every
case and returns the speeds where each sweep jumps, the two grid speeds between which each jump
lies, and the hysteresis band between them, on the study's other dims; ``jump_unsupported``
marks the sweeps whose jumps cannot be judged. A case-speed's amplitude is known (supports a
jump) where its error, the larger of its ``settle_error`` and its ``transient_left`` (the share
of the start's free vibration the transient left, recorded since 27 Nov 2026: a result without
it is judged by ``settle_error`` alone), is at most half the jump threshold, whatever its
``status`` (the settle tolerance, 1e-2, is for the recorded statistics; a diverged or skipped
one, status 1 or 3, is unknown). A case whose transient cannot have decayed is status 2 with
record halves that may agree closely (a beat slower than the record): its ``transient_left``,
not its ``settle_error``, says how far its amplitude may be from the steady one. The search
across the speeds that did not settle and the verdict "no jump" go by ``status``
(``find_jumps``'s ``settled_up`` / ``settled_down``).
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from gearsweep.analysis.jumps import find_jumps

UNSUPPORTED_WHY = ("steps that meet the jump criterion but none with points of both branches"
                   " beside it whose amplitude is known (settle_error and transient_left at"
                   " most half the threshold), or no jump while most of its case-speeds did not"
                   " settle")
"""Why a sweep's jump cannot be judged (``find_jumps``'s unsupported): the one wording of the
``jump_unsupported`` variable and of the analyses' notes."""

JUMP_VARIABLES = {
    "jump_up_speed": ("rpm", ("speed at which the run-up jumps: midpoint of jump_up_low"
                                  " and jump_up_high (NaN: no jump)")),
    "jump_up_size": ("1", "relative amplitude change of the run-up jump (negative: drop)"),
    "jump_down_speed": ("rpm", ("speed at which the run-down jumps: midpoint of"
                                    " jump_down_low and jump_down_high (NaN: no jump)")),
    "jump_down_size": ("1", "relative amplitude change of the run-down jump, towards lower speed"),
    "jump_up_low": ("rpm", ("speed below the run-up jump: the jump lies between jump_up_low and"
                            " jump_up_high, the speeds of the step that locates it")),
    "jump_up_high": ("rpm", "speed above the run-up jump"),
    "jump_down_low": ("rpm", ("speed below the run-down jump: the jump lies between"
                              " jump_down_low and jump_down_high")),
    "jump_down_high": ("rpm", "speed above the run-down jump"),
    "hysteresis_low": ("rpm", "lower end of the jump hysteresis band"),
    "hysteresis_high": ("rpm", "upper end of the jump hysteresis band"),
    "hysteresis_width": ("rpm", ("width of the jump hysteresis band (0: none; NaN: cannot be"
                              " judged, see jump_unsupported)")),
    "hysteresis_open": ("1", ("the hysteresis band reaches an end of the swept speeds still"
                              " two-valued, its width a lower bound (0: no, 1: the lowest speed,"
                              " 2: the highest, 3: both)")),
    "jump_unsupported": ("1", (f"a sweep has {UNSUPPORTED_WHY}: whether it jumps, and the"
                               " hysteresis band, cannot be judged (0: judged, 1: the run-up,"
                               " 2: the run-down, 3: both)")),
}


def _amplitude_error(ds: xr.Dataset, settled: xr.DataArray) -> xr.DataArray:
    """Relative uncertainty of each case-speed's amplitude: the larger of its ``settle_error``
    and its ``transient_left`` (where the result has it: module docstring), NaN (unknown) where
    it diverged or was skipped (status 1, 3), 0 where the study took it as settled above its
    settle tolerance (only a response that has died away is: its settle_error is round-off over
    round-off; ``STATUS_CODES`` 2)."""
    err = ds["settle_error"]
    if "transient_left" in ds:  # (a NaN of either is unknown)
        err = xr.where(err >= ds["transient_left"], err, ds["transient_left"])
        err = err.where(ds["settle_error"].notnull())
    tol = float(ds.attrs.get("settle_tolerance", np.inf))
    quiet = settled & (err > tol)
    status = ds["status"] if "status" in ds else xr.zeros_like(err, dtype=np.int8)
    return xr.where(quiet, 0.0, err.where(status.isin([0, 2])))


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
    settled = (ds["status"] == 0).broadcast_like(amp) if "status" in ds else xr.ones_like(
        amp, dtype=bool)  # every result has a status
    other = [d for d in amp.dims if d not in ("direction", "speed")]

    def sweep(da, direction):
        return da.sel(direction=direction).transpose(*other, "speed").values

    error = {"up": None, "down": None}
    if "settle_error" in ds:
        e = _amplitude_error(ds, settled).broadcast_like(amp)
        # (float32: compared with a fraction of the threshold, and held through find_jumps)
        error = {d: sweep(e, d).astype(np.float32) for d in error}
        del e
    js = find_jumps(ds["speed"].values, sweep(amp, "up"), sweep(amp, "down"), threshold,
                    settled_up=sweep(settled, "up"), settled_down=sweep(settled, "down"),
                    error_up=error["up"], error_down=error["down"])
    coords = {d: ds[d] for d in other}
    out = {}
    values = {"jump_up_speed": js.up_speed, "jump_up_size": js.up_size,
              "jump_down_speed": js.down_speed, "jump_down_size": js.down_size,
              "jump_up_low": js.up_low, "jump_up_high": js.up_high,
              "jump_down_low": js.down_low, "jump_down_high": js.down_high,
              "hysteresis_low": js.band_low, "hysteresis_high": js.band_high,
              "hysteresis_width": js.width,
              "hysteresis_open": (np.asarray(js.open_low, np.int8)
                                  + 2 * np.asarray(js.open_high, np.int8)),
              "jump_unsupported": (np.asarray(js.up_unsupported, np.int8)
                                   + 2 * np.asarray(js.down_unsupported, np.int8))}
    for name, (units, long_name) in JUMP_VARIABLES.items():
        out[name] = xr.DataArray(np.asarray(values[name]), dims=other, coords=coords,
                                 attrs={"units": units, "long_name": long_name})
    res = xr.Dataset(out)
    res.attrs["jump_threshold"] = threshold
    return res
