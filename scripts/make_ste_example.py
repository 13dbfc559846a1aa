"""Write studies/data/ste_table1.csv: the example of a scene's ``excitation: {file: ...}``.

The loaded STE and the mesh stiffness of the Table 1 pair (``table1_consistent``, unmodified
teeth) at 50 N m over one mesh cycle, 200 positions, as ``gearsweep.gear.mesh_cycle`` computes
them, with a little measurement-like noise (Gaussian, 0.02 um on the STE and 0.2 N/um on the
stiffness, fixed seed), in the units an LTCA export would use::

    python scripts/make_ste_example.py            # -> studies/data/ste_table1.csv
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from gearsweep.gear import mesh_cycle, table1_consistent

TORQUE = 50.0  # N m on the driving 48-tooth gear


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).parents[1] / "studies/data/ste_table1.csv"))
    args = ap.parse_args()
    pair = table1_consistent().check()
    mc = mesh_cycle(pair, TORQUE, n=200)
    rng = np.random.default_rng(26)
    ste_um = mc.ste * 1e6 + rng.normal(0.0, 0.02, mc.phase.size)
    k_n_mm = mc.mesh_stiffness * 1e-3 + rng.normal(0.0, 200.0, mc.phase.size)
    lines = [
        "# Loaded static transmission error and mesh stiffness over one mesh cycle",
        (f"# Table 1 pair (gearsweep table1_consistent, unmodified), {TORQUE:g} N m on the driving"
        f" gear ({pair.z1} teeth), base radius {pair.base_radius1 * 1e3:.4f} mm,"
        f" mean force {mc.load:.2f} N"),
        "# computed by gearsweep.gear.mesh_cycle, plus Gaussian noise (0.02 um, 0.2 N/um), seed 26",
        "# mesh_phase 0 = a tooth pair enters contact; written by scripts/make_ste_example.py",
        "mesh_phase [1], ste [um], mesh_stiffness [N/mm]",
    ]
    lines += [f"{p:.4f}, {e:.5f}, {k:.1f}" for p, e, k in zip(mc.phase, ste_um, k_n_mm,
                                                             strict=True)]
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(args.out)


if __name__ == "__main__":
    main()
