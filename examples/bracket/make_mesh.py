#!/usr/bin/env python3
"""Write bracket.msh: an L-shaped steel bracket, bolted to its support through two holes in its
base, loaded at the top of its arm.  Lengths in millimetres (bracket.json says so).

Made with gmsh's own Python API (``pip install gmsh``; not a flexfmu dependency: the .msh is shipped).
Physical groups (node sets for flexfmu export): volume "bracket"; surfaces "bolt_1", "bolt_2" (the
hole walls) and "arm_top" (the top face of the arm).

    python examples/bracket/make_mesh.py [--size 6] [--order 2]
"""
import argparse
from pathlib import Path

import gmsh

BASE = (80.0, 40.0, 5.0)      # base plate: length x, width y, thickness z (mm)
ARM = (5.0, 40.0, 60.0)       # arm at x = 0 .. 5: thickness x, width y, height z above the base (mm)
HOLE_RADIUS = 4.0
HOLES = ((50.0, 20.0), (70.0, 20.0))


def make(path: Path, size: float, order: int) -> None:
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("bracket")
    occ = gmsh.model.occ
    base = occ.addBox(0, 0, 0, *BASE)
    arm = occ.addBox(0, 0, BASE[2], ARM[0], ARM[1], ARM[2])
    holes = [occ.addCylinder(x, y, -1, 0, 0, BASE[2] + 2, HOLE_RADIUS) for x, y in HOLES]
    body, _ = occ.fuse([(3, base)], [(3, arm)])
    body, _ = occ.cut(body, [(3, h) for h in holes])
    occ.synchronize()
    volume = body[0][1]
    gmsh.model.addPhysicalGroup(3, [volume], name="bracket")
    eps = 1e-3
    for k, (x, y) in enumerate(HOLES, start=1):
        walls = gmsh.model.getEntitiesInBoundingBox(x - HOLE_RADIUS - eps, y - HOLE_RADIUS - eps, -eps,
                                                    x + HOLE_RADIUS + eps, y + HOLE_RADIUS + eps, BASE[2] + eps, 2)
        walls = [tag for dim, tag in walls if abs(gmsh.model.occ.getMass(2, tag) - 2 * 3.141592653589793
                                                     * HOLE_RADIUS * BASE[2]) < 1.0]
        gmsh.model.addPhysicalGroup(2, walls, name=f"bolt_{k}")
    top_z = BASE[2] + ARM[2]
    top = gmsh.model.getEntitiesInBoundingBox(-eps, -eps, top_z - eps, ARM[0] + eps, ARM[1] + eps, top_z + eps, 2)
    gmsh.model.addPhysicalGroup(2, [tag for _, tag in top], name="arm_top")
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.MeshSizeMin", size / 2)
    gmsh.model.mesh.generate(3)
    gmsh.model.mesh.setOrder(order)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.write(str(path))
    gmsh.finalize()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=float, default=6.0, help="largest element size, mm (default 6)")
    parser.add_argument("--order", type=int, default=2, choices=(1, 2),
                        help="element order (default 2; linear tetrahedra are far too stiff in bending)")
    parser.add_argument("--out", type=Path, default=Path(__file__).with_name("bracket.msh"))
    args = parser.parse_args()
    make(args.out, args.size, args.order)
    print(f"wrote {args.out}")
