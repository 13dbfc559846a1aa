"""Fig. 5 with the Table 1 gear pair's k(t) (studies/fig05_waterfall_mesh.yaml).

Writes figures/fig05_waterfall_mesh.png and figures/fig05_campbell_mesh.png. Run from the
repository root after ``gearsweep run studies/fig05_waterfall_mesh.yaml``:

    python scripts/fig05_waterfall_mesh.py [--results results] [--figures figures]
"""

from __future__ import annotations

from _common import open_result, parse
from fig05_waterfall import draw

args = parse(__doc__.splitlines()[0])
draw(open_result(args.results, "fig05_waterfall_mesh"), args.figures, "_mesh")
