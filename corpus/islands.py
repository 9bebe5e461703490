"""Ocean-like island domain (the paper's section 8.4 use): a planar rectangle with about
60 random non-overlapping polygonal islands of 5 to 11 vertices, some with very short
edges and sharp corners, meshed with a distance-based size field (fine near the coasts).

    python3 corpus/islands.py SIZE OUTPUT.msh [Option.Name=VALUE ...]

SIZE is the open-sea mesh size: 12 gives about 1e4 triangles, 2.2 about 1e5. The islands
come from a seeded RNG (seed 11), so every run builds the same domain.
"""

import gmsh

import _model
import _shapes

size, output, tmp = _model.start("islands")
sea = _shapes.island_domain(11, size)
gmsh.model.addPhysicalGroup(2, [sea], name="ocean")
_model.finish(output, tmp)
