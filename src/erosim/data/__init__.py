"""Data shipped inside the package: published reference measurements (``erosim/data/reference/``).

Found through :mod:`importlib.resources`, so an installed wheel reads them from wherever it was
installed; nothing is read from outside the package. ``reference/README.md`` names each file's
source, the table or figure it was digitised from, and its units.
"""

from __future__ import annotations

import csv
from importlib import resources

import numpy as np

from erosim.core.errors import InputError

#: The reference files the code reads (a test checks each is in the installed package).
MARTIN_MOYCE_SURGE = "martin_moyce_1952_n2_2_a2.25in_surge_front_Ocellaris.csv"
MARTIN_MOYCE_COLUMN = "martin_moyce_1952_n2_2_a2.25in_column_height_Ocellaris.csv"
MARTIN_MOYCE_FIG3 = "martin_moyce_1952_n2_2_surge_front_PySPH_fig3.csv"
KOSHIZUKA_OKA = "koshizuka_oka_1996_dam_break.csv"
SPHERIC2 = "spheric2_kleefsman2005_marin.csv"
DROP_CRATER_SCALING = "drop_impact_crater_scaling_exponents.csv"
REFERENCE_FILES = (MARTIN_MOYCE_SURGE, MARTIN_MOYCE_COLUMN, MARTIN_MOYCE_FIG3, KOSHIZUKA_OKA, SPHERIC2,
                   DROP_CRATER_SCALING)  # fmt: skip


def reference_text(name: str) -> str:
    """The text of a reference file shipped in ``erosim/data/reference``."""
    res = resources.files(__name__).joinpath("reference", name)
    if not res.is_file():
        raise InputError(
            f"Reference file '{name}' is not in the installed erosim package; reinstall erosim "
            "(its wheel carries erosim/data/reference)."
        )
    return res.read_text(encoding="utf-8")


def reference_csv(name: str) -> dict[str, np.ndarray]:
    """Columns of a reference CSV (``#`` comment lines skipped) by header name; numeric columns as float64."""
    lines = [ln for ln in reference_text(name).splitlines() if ln.strip() and not ln.startswith("#")]
    rows = list(csv.reader(lines))
    cols: dict[str, np.ndarray] = {}
    for j, header in enumerate(rows[0]):
        values = [r[j].strip() for r in rows[1:]]
        try:
            cols[header.strip()] = np.array(values, dtype=np.float64)
        except ValueError:
            cols[header.strip()] = np.array(values)
    return cols
