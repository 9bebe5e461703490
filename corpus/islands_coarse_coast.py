"""The island domain (`_shapes.island_domain`, seed 3: about 60 random polygonal islands)
with a coarse coast: the coastal size is half the open-sea size (a sixth in
`islands.py`), so island vertices have few triangles and wall corners get flat pairs.
About 2,600 triangles at the coarse size 12.

    python3 corpus/islands_coarse_coast.py SIZE OUTPUT.msh [Option.Name=VALUE ...]
"""

import gmsh

import _model
import _shapes

size, output, tmp = _model.start("islands_coarse_coast")
sea = _shapes.island_domain(3, size, coast_ratio=2.0)
gmsh.model.addPhysicalGroup(2, [sea], name="ocean")
_model.finish(output, tmp)
