#!/usr/bin/env python3
"""The Python package against Gmsh's own recombination, in one process, on the rectangle
fixture: `blossomquad.recombine_gmsh()` on the loaded model vs `gmsh.model.mesh.recombine()`
on the same model, vs writing the mesh, running the `blossomquad` command and reading the
result back. Prints wall seconds per run (best and spread over REPEAT runs, interleaved),
and the phases of the first and last: for `recombine_gmsh`, reading the model through the
API, converting to and from the library's mesh, the pipeline, writing the model back; for
the file, `gmsh.write`, the command, `gmsh.clear` + `gmsh.open`.

    python3 scripts/bench_python.py [SIZE] [REPEAT] [--no-gmsh]
        # size 0.1336: ~1e5 triangles, 0.04233: ~1e6 (--no-gmsh skips Gmsh's recombine,
        # which takes minutes there)
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


def secs(d):
    return d["secs"] + d["nanos"] * 1e-9


def spread(v):
    return f"best {min(v):7.3f} s   spread {min(v):.3f}-{max(v):.3f} s"


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    size = float(args[0]) if len(args) > 0 else 0.1336
    repeat = int(args[1]) if len(args) > 1 else 3
    with_gmsh = "--no-gmsh" not in sys.argv
    gmsh.initialize(["-v", "0"])
    times = {"recombine_gmsh": [], "file + CLI + read": []}
    if with_gmsh:
        times["gmsh recombine"] = []
    phases = {"recombine_gmsh": {}, "file + CLI + read": {}}

    def phase(run, name, value):
        phases[run].setdefault(name, []).append(value)

    n = 0
    with tempfile.TemporaryDirectory() as d:
        for _ in range(repeat):
            mesh(size)
            n = triangles()
            t = time.perf_counter()
            report = blossomquad.recombine_gmsh()
            times["recombine_gmsh"].append(time.perf_counter() - t)
            phase("recombine_gmsh", "pipeline", sum(secs(v) for v in report["times"].values()))
            m = report.get("model")  # versions before the phases were reported have none
            if m:
                phase("recombine_gmsh", "read the model (API)", m["read_secs"])
                phase("recombine_gmsh", "convert to/from the library", m["convert_secs"])
                phase("recombine_gmsh", "write the model (API)", m["write_secs"])

            if with_gmsh:
                mesh(size)
                t = time.perf_counter()
                gmsh.model.mesh.recombine()
                times["gmsh recombine"].append(time.perf_counter() - t)

            mesh(size)
            src, out = os.path.join(d, "in.msh"), os.path.join(d, "out.msh")
            t = time.perf_counter()
            gmsh.option.setNumber("Mesh.Binary", 1)
            gmsh.write(src)
            t1 = time.perf_counter()
            subprocess.run(["blossomquad", src, "-o", out, "--quiet"], check=True)
            t2 = time.perf_counter()
            gmsh.clear()
            gmsh.open(out)
            t3 = time.perf_counter()
            times["file + CLI + read"].append(t3 - t)
            phase("file + CLI + read", "gmsh.write (binary)", t1 - t)
            phase("file + CLI + read", "blossomquad command", t2 - t1)
            phase("file + CLI + read", "gmsh.clear + gmsh.open", t3 - t2)
    gmsh.finalize()
    print(f"rectangle, size {size}: {n} triangles, {repeat} interleaved runs each")
    for k, v in times.items():
        print(f"  {k:20s} {spread(v)}")
        for name, p in phases.get(k, {}).items():
            print(f"    {name:30s} {spread(p)}")


if __name__ == "__main__":
    main()
