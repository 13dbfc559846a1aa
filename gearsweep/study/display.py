"""Results in the units of the study: the display unit of each quantity (``gearsweep.units``).

``display_coordinates`` rewrites the swept coordinates of a result Dataset from the SI numbers
the kernel ran with into the display unit of their kind (backlash in mm, damping in N s/mm,
stiffness in kN/mm, speed in rpm, torque in N m, ...) with that unit in their ``units`` attribute,
so that a study sweeping ``backlash: [0.1 mm, 0.2 mm]`` (or ``[100 um, 200 um]``) gives
``ds.sel(backlash=0.1)``: the values are rounded to 14 significant digits
(``units.decimal_coordinates``), which removes the float noise of the way through SI.
Dimensionless quantities carry CF's ``units: "1"``; string coordinates carry no unit.
"""

from __future__ import annotations

import xarray as xr

from gearsweep.model import SWEEPABLE
from gearsweep.units import KINDS, decimal_coordinates, to_display

P_MEANING = ("p: the dynamic transmission error, the relative displacement of the two gears along"
             " the line of action, Eq. (5) of Choi, Lee & Shin (1997); dimensionless in the"
             " Mathieu scene")
"""What ``p`` in the long names of the result variables means (their ``comment``)."""


def display_coordinates(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with every swept coordinate in its display unit (values and ``units``)."""
    for name in list(ds.coords):
        var = ds[name]
        if var.dtype.kind in "OSU":
            ds[name].attrs.pop("units", None)
            continue
        if var.attrs.get("units") == "-":
            ds[name].attrs["units"] = "1"
        kind = SWEEPABLE.get(name)
        if kind is None or kind == "dimensionless":
            continue
        attrs = dict(var.attrs, units=KINDS[kind].cf)
        values = decimal_coordinates(to_display(var.values, kind))  # 100 um -> 0.1 (mm), exactly
        ds = ds.assign_coords({name: (var.dims, values, attrs)})
    for name in ds.data_vars:
        if ds[name].attrs.get("units") == "-":
            ds[name].attrs["units"] = "1"
        if " p " in f" {ds[name].attrs.get('long_name', '')} ".replace(",", " "):
            ds[name].attrs.setdefault("comment", P_MEANING)
    return ds
