"""Static mesh figures for Table 1 (consistent interpretation) at 50 N m.

Writes figures/fig01_ste.png, fig02_load_sharing.png, fig03_backlash_stiffness.png,
mesh_ste_vs_load.png and mesh_tip_relief.png. Run from the repository root:

    python scripts/fig_mesh.py [--out figures]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from gearsweep.gear.geometry import GearPair, table1_consistent  # noqa: E402
from gearsweep.gear.mesh import TipRelief, fourier, mesh_cycle, mesh_cycles  # noqa: E402
from gearsweep.plot.mesh import (  # noqa: E402
    plot_backlash_stiffness,
    plot_load_sharing,
    plot_ste,
    plot_ste_vs_load,
    plot_tip_relief,
)

TORQUE = 50.0  # [N m] Table 1 input torque 50000 N mm
RELIEF = 6e-6  # [m] linear tip relief designed for 50 N m


def design_relief(pair: GearPair, amount: float) -> tuple[TipRelief, TipRelief]:
    """Linear tip relief of both gears from the bounds of single-tooth contact to the tips."""
    xi1 = (pair.s_start + pair.base_pitch) / pair.base_radius1
    xi2 = (pair.line_of_action_length - (pair.s_end - pair.base_pitch)) / pair.base_radius2
    return TipRelief(amount, start_roll_angle=xi1), TipRelief(amount, start_roll_angle=xi2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("figures"))
    out: Path = parser.parse_args().out
    out.mkdir(parents=True, exist_ok=True)
    pair = table1_consistent().check()
    title = f"{pair.name}, z = {pair.z1}/{pair.z2}, m = {pair.module * 1e3:g} mm"

    mc = mesh_cycle(pair, TORQUE)
    fig, ax = plt.subplots(figsize=(6.4, 4.0), layout="constrained")
    plot_ste(ax, mc)
    ax.set_title(f"Fig. 1: static transmission error, {title}", fontsize=9)
    ax.legend(loc="upper left", fontsize=8)
    fig.savefig(out / "fig01_ste.png", dpi=150)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6.4, 4.0), layout="constrained")
    plot_load_sharing(ax, mc)
    ax.set_title(
        f"Fig. 2: load sharing, z = {pair.z1}/{pair.z2}, contact ratio {pair.contact_ratio:.2f}, "
        f"T = {TORQUE:g} N m",
        fontsize=9,
    )
    fig.savefig(out / "fig02_load_sharing.png", dpi=150)
    plt.close(fig)

    k0 = fourier(mc.mesh_stiffness, 1)[0][0]
    fig, ax = plt.subplots(figsize=(6.4, 4.0), layout="constrained")
    plot_backlash_stiffness(ax, k0, pair.backlash_loa, mean_force=mc.load)
    ax.set_title(
        f"Fig. 3: mesh force with backlash (k = k0, backlash {pair.backlash_loa * 1e3:.3g} mm "
        "along the line of action)",
        fontsize=9,
    )
    fig.savefig(out / "fig03_backlash_stiffness.png", dpi=150)
    plt.close(fig)

    torques = np.linspace(2.0, 150.0, 50)
    relief = design_relief(pair, RELIEF)
    fig, ax = plt.subplots(figsize=(6.4, 4.0), layout="constrained")
    for tip_relief, label in ((None, "no relief"), (relief, f"{RELIEF * 1e6:g} um tip relief")):
        cycles = mesh_cycles(pair, torques, tip_relief=tip_relief)
        pp = [np.ptp(c.ste) for c in cycles]
        a1 = [fourier(c.ste, 1)[0][1] for c in cycles]
        plot_ste_vs_load(ax, torques, pp, a1, label=label, design_torque=TORQUE)
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(f"STE versus load, {title}", fontsize=9)
    fig.savefig(out / "mesh_ste_vs_load.png", dpi=150)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6.4, 4.0), layout="constrained")
    plot_tip_relief(ax, mc, mesh_cycle(pair, TORQUE, tip_relief=relief))
    ax.set_title(
        f"Linear tip relief {RELIEF * 1e6:g} um on both gears from the single-contact bounds, "
        f"T = {TORQUE:g} N m",
        fontsize=9,
    )
    ax.legend(fontsize=8)
    fig.savefig(out / "mesh_tip_relief.png", dpi=150)
    plt.close(fig)


if __name__ == "__main__":
    main()
