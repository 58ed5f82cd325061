"""How far VB-MAESKF's DVL noise estimate R̂ sits above the true variance in nominal periods.

For simulated missions (``adaptnav simulate``): each used DVL reading's R̂ (the run's ``noise``
table) divided by the simulator's true variance of that reading (``sigma_m_s²``), over the
readings outside noise segments (``noise_factor == 1``), for VB-MAESKF as the paper specifies
it, behind a gate on the nominal R, and with Student-t readings. Prints one Markdown table:
median ratio per DVL axis and the share of readings with a ratio above 3.

    python scripts/vb_noise.py MISSION [MISSION ...]
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from adaptnav import api
from adaptnav.mission import load_mission
from adaptnav.viz.pages import markdown_table

VARIANTS: dict[str, dict[str, Any]] = {
    "VB-MAESKF (the paper's)": {},
    "VB-MAESKF, gate q = 2600 on the nominal R": {
        "gate_q": {"vb": 2600.0},
        "gate_reference": "nominal",
    },
    "VB-MAESKF, Student-t ν = 4": {"vb_dof": 4.0},
}


def ratios(mission: Path, variant: dict[str, Any]) -> np.ndarray:
    """R̂ / σ_true² (n, 3) of the used DVL readings in nominal periods."""
    m = load_mission(mission)
    dvl = m.tables["dvl"]
    settings = m.config.filter_settings().updated(kind="vb", **variant)
    result = api.run(m, "vb", settings=settings)
    used = result.ledger[(result.ledger["sensor"] == "dvl") & (result.ledger["fate"] == "used")]
    noise = result.noise[result.noise["sensor"] == "dvl"]
    r_hat = noise.pivot_table(index="t_s", columns="component", values="r_hat")
    r = r_hat.reindex(used["t"].to_numpy()).to_numpy(dtype=float)
    rows = used["row"].to_numpy(dtype=int)
    var = dvl["sigma_m_s"].to_numpy(dtype=float)[rows] ** 2
    nominal = dvl["noise_factor"].to_numpy(dtype=float)[rows] == 1.0
    return np.asarray(r[nominal] / var[nominal, None], dtype=float)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("missions", nargs="+", type=Path)
    a = p.parse_args(argv)
    rows = []
    for name, variant in VARIANTS.items():
        r = np.vstack([ratios(mission, variant) for mission in a.missions])
        med = " / ".join(f"{v:.2f}" for v in np.nanmedian(r, axis=0))
        above = " / ".join(f"{100 * v:.0f}" for v in np.mean(r > 3.0, axis=0))
        rows.append([name, str(r.shape[0]), med, above])
    header = ["filter", "readings", "median R̂ / σ² (x / y / z)", "% above 3 (x / y / z)"]
    print(f"missions: {', '.join(str(m) for m in a.missions)}")
    print(markdown_table(header, rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
