"""Figures drawn from results (a Dataset of ``gearsweep.run`` or ``gearsweep.open_result``).

Functions that take a result Dataset and read its units (the figure scripts use them too):

* ``plot.sweep.plot_response_vs_speed(ds, var="p_pp", ax=None, hue=None)``: any dynamic result
  over speed, one line per value of another swept dim, up and down sweeps, unsettled cases masked.
* ``plot.whine.plot_waterfall``, ``plot_campbell`` (with the result's own f_n),
  ``plot_order_lines``: a result with the ``spectrum`` output;
  ``plot.whine.plot_response_by_load(ax, ds, by=...)``: over speed per swept load (Fig. 6;
  named plot_response_vs_speed until 26 Nov 2026, as the one above).
* ``plot.stability.plot_stability_map(ds, var="unstable")``: a flag of a result over speed and
  damping with the ``floquet`` output (``unstable``, ``integrator_unstable``, a condition such as
  ``ds.floquet_multiplier > 1``; a variable that is no flag is refused).
* ``plot.rattle.plot_rattle_balance``, ``plot_rattle_contact``, ``plot_rattle_graphical``,
  ``plot_rattle_budget``: the results of the rattle analysis studies.
* ``plot.precision.plot_work_precision``, ``plot_method_stability``: the analysis results of the
  same names.
* ``plot.mesh``: a mesh study's result (STE, load sharing, stiffness over the mesh cycle and load).

The others take arrays in SI units; a result's variable or coordinate given as it is (an
xarray object with a ``units`` attribute, e.g. ``ds.ste`` in um) is read in its unit
(``plot.common.si_array``), its ``.values`` are taken as SI (``units.si_values`` converts them).
``plot.common.save(fig, path)`` writes a PNG.
"""
