"""The result of a co-simulation, whichever master ran it: the outputs of every instance at the communication
points, and their CSV."""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass
class CosimResult:
    """Time series at the communication points: t (n,), columns {"instance.variable": (n,)}."""

    t: np.ndarray
    columns: dict
    step: float
    scheme: str
    master: str
    slaves: dict = field(default_factory=dict)      # library backend: name -> LibrarySlave (final state)
    extra: dict = field(default_factory=dict)        # library backend: per-step extra records

    def __getitem__(self, key: str) -> np.ndarray:
        return self.columns[key]

    def write_csv(self, path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        names = list(self.columns)
        table = np.column_stack([self.t] + [self.columns[n] for n in names])
        with path.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["time"] + names)
            for row in table:
                w.writerow([repr(float(x)) for x in row])
        return path
