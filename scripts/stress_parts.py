#!/usr/bin/env python3
"""Random CAD parts through blossomquad and the independent checker: a robustness sweep.

    scripts/stress_parts.py [--seeds 0:199] [--dir WORKDIR] [--tool PATH] [--timeout 600]
                            [--options]

Each seed builds one OpenCASCADE part with the Gmsh Python API, from one of eight
families picked by the seed: a plate with polygonal holes fragmented by rectangles, a box
with some edges filleted, cylinders fused on a slab, a box cut, fused or fragmented with
spheres and tilted cylinders, an extruded polygon with a hole, a revolved profile, a torus
fused with a cone, thin pins or cylinders on a slab. The seed also picks the mesh size
(coarse to fine for the part), Gmsh's 2D algorithm (MeshAdapt, Delaunay, Frontal-Delaunay),
sizes from curvature or not, MSH 2.2 or 4.1, ASCII or binary, and a physical group on
every surface or none (then Gmsh writes no line elements). The part is meshed with
`gmsh -2` semantics (surfaces only) in its own process, then

  1. `blossomquad IN -o OUT --tag-map MAP` runs (wall time measured, `--timeout` seconds at
     most);
  2. when it writes OUT, `tests/check_mesh.py IN OUT --tag-map=MAP` must pass.

With `--options` the seed also picks the tool's options (the same part, other switches):
none, or one or two of `--refine 1` (the checker then runs with `--refined=1`),
`--keep-tags` (then without `--tag-map`), `--format msh22` or `--format msh41`, `--binary` or `--ascii`,
`--cross-field 0`, `--cross-field 0.3 --harmonic-cross-field`, `--no-conformal-multigrid`,
`--no-topology`, `--smooth 3`, `--no-optimize` (see `tool_options`); results.tsv then
has one more column, the options.

Every run is one line of WORKDIR/results.tsv: seed, family, size, triangles, status (ok,
refused, checker, crash, timeout; genfail where Gmsh could not mesh the part, e.g. made no
surface element), new quads per input triangle (counted before refinement on a refined
run), worst and mean η, seconds, and the tool's last line. The summary at the end counts
each status and lists the runs of 500 triangles or more above 0.6 quads per triangle, the
refusals and anything worse.
Inputs are kept in WORKDIR (in-SEED.msh) and generated once, so a second tool can be run
on the same parts. Needs the `gmsh` Python module (`source scripts/ensure_gmsh.sh`).
"""

import argparse
import math
import os
import random
import re
import subprocess
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FAMILIES = ["plate_holes", "fillet_box", "cylinders", "boolean", "extrusion", "revolution",
            "torus_cone", "pins"]


def generate(seed, out):
    """Builds and meshes the part of `seed` into `out` (run in a child process)."""
    sys.path.insert(0, os.path.join(REPO, "corpus"))
    import gmsh
    import _shapes

    rng = random.Random(seed * 7919 + 13)
    gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(f"stress{seed}")
    occ = gmsh.model.occ
    family = seed % len(FAMILIES)
    if family == 0:
        _shapes.plate_with_holes(seed, holes=rng.randint(1, 4), rectangles=rng.randint(0, 4))
        size = rng.choice([0.05, 0.1, 0.2, 0.4, 0.8])
    elif family == 1:
        _shapes.filleted_box(seed, edges=rng.randint(1, 8))
        size = rng.choice([0.03, 0.08, 0.15, 0.3, 0.6])
    elif family == 2:
        _shapes.cylinders(seed, count=rng.randint(1, 4))
        size = rng.choice([0.05, 0.1, 0.2, 0.4, 0.8])
    elif family == 3:
        box = occ.addBox(0, 0, 0, rng.uniform(1, 3), rng.uniform(1, 2), rng.uniform(0.5, 1.5))
        tools = []
        for _ in range(rng.randint(1, 4)):
            if rng.random() < 0.5:
                tools.append((3, occ.addSphere(rng.uniform(0, 3), rng.uniform(0, 2),
                                               rng.uniform(0, 1.5), rng.uniform(0.2, 0.7))))
            else:
                tools.append((3, occ.addCylinder(rng.uniform(0, 3), rng.uniform(0, 2), -0.5,
                                                 rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5),
                                                 3, rng.uniform(0.1, 0.5))))
        getattr(occ, rng.choice(["cut", "fuse", "fragment"]))([(3, box)], tools)
        occ.synchronize()
        size = rng.choice([0.04, 0.08, 0.15, 0.3, 0.6])
    elif family == 4:
        outer = _shapes.polygon(occ, rng, 0, 0, 1.0, rng.randint(5, 9))
        hole = _shapes.polygon(occ, rng, rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), 0.3,
                               rng.randint(3, 6))
        face, _ = occ.cut([(2, outer)], [(2, hole)])
        occ.extrude(face, 0, 0, rng.uniform(0.1, 1.5))
        occ.synchronize()
        size = rng.choice([0.03, 0.06, 0.12, 0.25, 0.5])
    elif family == 5:
        count = rng.randint(3, 6)
        pts = [occ.addPoint(0.2 + rng.uniform(0, 0.8) * (i % 2), 0, 0.3 * i) for i in range(count)]
        pts = [occ.addPoint(0, 0, 0)] + pts + [occ.addPoint(0, 0, 0.3 * (count - 1))]
        lines = [occ.addLine(pts[i], pts[i + 1]) for i in range(len(pts) - 1)]
        lines.append(occ.addLine(pts[-1], pts[0]))
        face = occ.addPlaneSurface([occ.addCurveLoop(lines)])
        occ.revolve([(2, face)], 0, 0, 0, 0, 0, 1, rng.choice([math.pi / 2, math.pi, 2 * math.pi]))
        occ.synchronize()
        size = rng.choice([0.03, 0.06, 0.12, 0.25, 0.5])
    elif family == 6:
        torus = occ.addTorus(0, 0, 0, 1.0, rng.uniform(0.1, 0.4))
        cone = occ.addCone(0, 0, -1, 0, 0, 2, rng.uniform(0.2, 0.8), rng.uniform(0, 0.3))
        occ.fuse([(3, torus)], [(3, cone)])
        occ.synchronize()
        size = rng.choice([0.04, 0.08, 0.15, 0.3, 0.6])
    else:
        if rng.random() < 0.3:
            _shapes.thin_pins(seed, count=rng.randint(1, 4))
        else:
            _shapes.cylinders(seed, count=2)
        size = rng.choice([0.03, 0.06, 0.1, 0.2])
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.Algorithm", rng.choice([1, 5, 6, 6]))
    if rng.random() < 0.4:
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", rng.choice([6, 12, 20]))
    gmsh.option.setNumber("Mesh.MshFileVersion", rng.choice([2.2, 4.1, 4.1]))
    gmsh.option.setNumber("Mesh.Binary", rng.choice([0, 1]))
    if rng.random() < 0.5:
        gmsh.model.addPhysicalGroup(2, [t for _, t in gmsh.model.getEntities(2)], name="skin")
    gmsh.model.mesh.generate(2)
    # a part Gmsh failed to mesh (no surface element) is the generator's failure, not a
    # refusal of the tool
    if not any(len(tags) for tags in gmsh.model.mesh.getElements(2)[1]):
        gmsh.finalize()
        sys.exit(f"seed {seed}: Gmsh made no surface element ({FAMILIES[family]}, size {size})")
    gmsh.write(out)
    gmsh.finalize()
    print(f"{FAMILIES[family]} {size}")


# The tool's switches a seed may pick with --options: each entry is one choice.
OPTION_CHOICES = [
    ["--refine", "1"],
    ["--keep-tags"],
    ["--format", "msh22"],
    ["--format", "msh41"],
    ["--binary"],
    ["--ascii"],
    ["--cross-field", "0"],
    ["--cross-field", "0.3", "--harmonic-cross-field"],
    ["--no-conformal-multigrid"],
    ["--no-topology"],
    ["--smooth", "3"],
    ["--no-optimize"],
]


def tool_options(seed):
    """The tool's options for `seed` with --options: none for one seed in four, else one or
    two choices of OPTION_CHOICES (not both of a pair that excludes the other: two formats,
    binary and ASCII, two cross-field weights)."""
    rng = random.Random(1_000_003 * seed + 17)
    if rng.random() < 0.25:
        return []
    picks = rng.sample(range(len(OPTION_CHOICES)), rng.choice([1, 2]))
    if any(pair <= set(picks) for pair in ({2, 3}, {4, 5}, {6, 7})):
        picks = picks[:1]
    return [x for i in sorted(picks) for x in OPTION_CHOICES[i]]


SUMMARY = re.compile(r"(\d+) triangles -> (\d+) quads \(quality eta: worst ([\d.]+), mean ([\d.]+)\)")


def run(seed, args):
    """One seed: generate (once), run the tool and the checker; returns the result row."""
    inp = os.path.join(args.dir, f"in-{seed}.msh")
    info = os.path.join(args.dir, f"in-{seed}.txt")
    if not (os.path.exists(inp) and os.path.exists(info)):
        g = subprocess.run([sys.executable, os.path.abspath(__file__), "--generate", str(seed), inp],
                           capture_output=True, text=True, timeout=args.timeout)
        if g.returncode != 0:
            row = [seed, "-", "-", 0, "genfail", "", "", "", "", g.stderr.strip()[-200:]]
            return row + [""] if args.options else row
        with open(info, "w") as f:
            f.write(g.stdout.strip())
    family, size = open(info).read().split()
    out = os.path.join(args.dir, f"out-{seed}.msh")
    tag_map = os.path.join(args.dir, f"map-{seed}.json")
    for f in (out, tag_map):
        if os.path.exists(f):
            os.remove(f)
    extra = tool_options(seed) if args.options else []
    # the tags kept as they are: no map (the tool refuses both)
    mapping = [] if "--keep-tags" in extra else ["--tag-map", tag_map]
    start = time.time()
    try:
        r = subprocess.run([args.tool, inp, "-o", out] + mapping + extra,
                           capture_output=True, text=True, timeout=args.timeout)
        code, text = r.returncode, (r.stdout + r.stderr).strip()
    except subprocess.TimeoutExpired:
        code, text = None, "timeout"
    wall = time.time() - start
    last = text.splitlines()[-1][:300] if text else ""
    m = SUMMARY.search(text)
    tris = int(m.group(1)) if m else 0
    # quads before refinement: a refined run has four times the quads per level
    per_level = 4 if "--refine" in extra else 1
    qt = f"{int(m.group(2)) / per_level / tris:.3f}" if m and tris else ""
    worst, mean = (m.group(3), m.group(4)) if m else ("", "")
    if code is None:
        status = "timeout"
    elif code == 0:
        refined = ["--refined=1"] if "--refine" in extra else []
        mapped = [f"--tag-map={tag_map}"] if mapping else []
        c = subprocess.run([sys.executable, os.path.join(REPO, "tests", "check_mesh.py"), inp, out]
                           + mapped + refined, capture_output=True, text=True)
        status = "ok" if c.returncode == 0 else "checker"
        if status == "checker":
            last = c.stdout.strip()[-300:]
    elif code == 1 and "error:" in text and "panicked" not in text:
        status = "refused"
    else:
        status = "crash"
    row = [seed, family, size, tris, status, qt, worst, mean, f"{wall:.2f}", last]
    return row + [" ".join(extra)] if args.options else row


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "--generate":
        generate(int(sys.argv[2]), sys.argv[3])
        return 0
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", default="0:199", help="FIRST:LAST, both included")
    ap.add_argument("--dir", default=os.path.join(REPO, "target", "stress-parts"))
    ap.add_argument("--tool", default=os.environ.get(
        "BLOSSOMQUAD", os.path.join(REPO, "target", "release", "blossomquad")))
    ap.add_argument("--timeout", type=float, default=600.0)
    ap.add_argument("--options", action="store_true",
                    help="each seed also picks the tool's options (see tool_options)")
    args = ap.parse_args()
    first, last = (int(x) for x in args.seeds.split(":"))
    os.makedirs(args.dir, exist_ok=True)
    rows = []
    with open(os.path.join(args.dir, "results.tsv"), "w") as f:
        f.write("seed\tfamily\tsize\ttriangles\tstatus\tquads_per_triangle\teta_w\teta_mean\tseconds\tlast"
                + ("\toptions" if args.options else "") + "\n")
        for seed in range(first, last + 1):
            row = run(seed, args)
            rows.append(row)
            f.write("\t".join(str(x) for x in row) + "\n")
            f.flush()
            print(f"seed {seed:4d} {row[1]:12s} {row[3]:7d} triangles  {row[4]:8s} "
                  f"q/t {row[5] or '-':6s} eta_w {row[6] or '-':6s} {row[8]} s"
                  + (f"  [{row[10]}]" if args.options else ""), flush=True)
    counts = {}
    for r in rows:
        counts[r[4]] = counts.get(r[4], 0) + 1
    print("\n" + ", ".join(f"{k}: {v}" for k, v in sorted(counts.items())))
    over = [r for r in rows if r[4] == "ok" and r[3] >= 500 and float(r[5]) > 0.6]
    print(f"{len(over)} run(s) of 500 triangles or more above 0.6 quads per triangle: "
          + ", ".join(f"{r[0]} ({r[1]}, {r[5]})" for r in over))
    for r in rows:
        if r[4] not in ("ok",):
            opts = f", options {r[10] or 'none'}" if args.options else ""
            print(f"seed {r[0]} ({r[1]}, size {r[2]}{opts}): {r[4]}: {r[9]}")
    bad = sum(1 for r in rows if r[4] in ("checker", "crash", "timeout", "genfail"))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
