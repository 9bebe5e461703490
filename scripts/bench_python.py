#!/usr/bin/env python3
"""The Python package against Gmsh's own recombination, in one process, on the rectangle
fixture: `blossomquad.recombine_gmsh()` on the loaded model vs `gmsh.model.mesh.recombine()`
on the same model, vs writing the mesh, running the `blossomquad` command and reading the
result back. Prints wall seconds per run (best and spread over REPEAT runs, interleaved).

    python3 scripts/bench_python.py [SIZE] [REPEAT]     # size 0.1336: ~1e5 triangles
"""

import os
import subprocess
import sys
import tempfile
import time

import gmsh

import blossomquad

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))


def mesh(size):
    gmsh.clear()
    gmsh.onelab.setNumber("Parameters/size", [size])
    gmsh.open(os.path.join(REPO, "geo", "rectangle.geo"))
    gmsh.model.mesh.generate(2)


def triangles():
    return sum(len(t) for t in gmsh.model.mesh.getElements(2)[1])


def main():
    size = float(sys.argv[1]) if len(sys.argv) > 1 else 0.1336
    repeat = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    gmsh.initialize(["-v", "0"])
    times = {"recombine_gmsh": [], "gmsh recombine": [], "file + CLI + read": []}
    n = 0
    with tempfile.TemporaryDirectory() as d:
        for _ in range(repeat):
            mesh(size)
            n = triangles()
            t = time.perf_counter()
            blossomquad.recombine_gmsh()
            times["recombine_gmsh"].append(time.perf_counter() - t)

            mesh(size)
            t = time.perf_counter()
            gmsh.model.mesh.recombine()
            times["gmsh recombine"].append(time.perf_counter() - t)

            mesh(size)
            src, out = os.path.join(d, "in.msh"), os.path.join(d, "out.msh")
            t = time.perf_counter()
            gmsh.option.setNumber("Mesh.Binary", 1)
            gmsh.write(src)
            subprocess.run(["blossomquad", src, "-o", out, "--quiet"], check=True)
            gmsh.clear()
            gmsh.open(out)
            times["file + CLI + read"].append(time.perf_counter() - t)
    gmsh.finalize()
    print(f"rectangle, size {size}: {n} triangles, {repeat} interleaved runs each")
    for k, v in times.items():
        print(f"  {k:20s} best {min(v):7.3f} s   spread {min(v):.3f}-{max(v):.3f} s")


if __name__ == "__main__":
    main()
