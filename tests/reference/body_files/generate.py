"""Writes the two body files of this folder: a free and a clamped steel rod (1 m, 10 mm, 4 Euler-Bernoulli
elements, 2 modes, one interface at the tip), with flexfmu's FlexBody.save.  Run once, with the flexfmu of commit
0ed88ee (when a body's kind was the string field FlexBody.kind), so that the tests load files written before the
free and clamped bodies became classes: ``PYTHONPATH=<that checkout>/model python generate.py``."""
import dataclasses
from pathlib import Path

import numpy as np

from flexfmu.body.build import build_body
from flexfmu.ffr.assembly import build_beam_model
from flexfmu.ffr.scene import scene_from_dict

HERE = Path(__file__).parent
ROD = {"name": "rod", "points": [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], "section": {"shape": "circle", "diameter": 0.01},
       "material": {"E": 200e9, "nu": 0.29, "rho": 7850.0}}

if __name__ == "__main__":
    rod = build_beam_model(scene_from_dict(ROD), "free", 4).structure()
    rod = dataclasses.replace(rod, node_sets={"root": np.array([0])})
    tip = [{"name": "tip", "point": [1.0, 0.0, 0.0]}]
    build_body(rod, interfaces=tip, n_modes=2).save(HERE / "free_rod.npz")
    build_body(rod, interfaces=tip, clamp="root", n_modes=2).save(HERE / "clamped_rod.npz")
