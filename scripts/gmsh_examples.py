#!/usr/bin/env python3
"""blossomquad on Gmsh's own example models: the .geo files of a Gmsh source tree.

    scripts/gmsh_examples.py GMSH_SOURCE [--dirs tutorials,examples/boolean,...]
                             [--dir WORKDIR] [--out BENCHMARKS.md | --no-write]
                             [--json FILE] [--tool PATH]
    scripts/gmsh_examples.py --from-json FILE [--out BENCHMARKS.md | --no-write]

GMSH_SOURCE is a checkout of Gmsh's sources (https://gitlab.onelab.info/gmsh/gmsh, or a
mirror of it); the models are the .geo files directly in each of --dirs (by default the
tutorials, the OpenCASCADE examples `examples/boolean` and the built-in kernel's
`examples/simple_geo` and `examples/struct`). Each is meshed in its own directory, since
they read files beside them, with its own settings: `gmsh FILE.geo -2 -format msh41`, as
a Gmsh user meshes them. Every row is then measured as `scripts/footprint.py` measures a
corpus run: the same columns and goals (see its doc), Gmsh's recombination being the same
command with `Mesh.RecombineAll = 1` and `Mesh.RecombinationAlgorithm = 1`. A model whose
surface mesh file holds no surface element (its physical groups are all volumes or
curves, so Gmsh saves no triangle, or it meshes nothing) has the status `no surface` and
no goal: blossomquad refuses it, saying why; nor has a model Gmsh fails on (`mesh-fail`).

The table goes into the Markdown file (default BENCHMARKS.md) between the markers
`<!-- gmsh-examples:begin -->` and `<!-- gmsh-examples:end -->` (appended with the markers
when they are missing); `--no-write` prints it instead. The models run one after the
other, so the times mean something. `--json FILE` writes the run's settings and then one
JSON object per row; `--from-json FILE` rebuilds the table from such a file, the goals
judged again, without running anything.
"""

import argparse
import datetime
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import corpus  # noqa: E402  (scripts/corpus.py)
import footprint  # noqa: E402  (scripts/footprint.py)

BEGIN = "<!-- gmsh-examples:begin -->"
END = "<!-- gmsh-examples:end -->"
DIRS = "tutorials,examples/boolean,examples/simple_geo,examples/struct"


def geo_mesher(path):
    """A `footprint.gmsh_mesh` for one .geo file: Gmsh run in the file's directory."""
    def mesh(_name, _size, out, extra=()):
        cmd = [os.environ.get("GMSH", "gmsh"), os.path.basename(path), "-2", "-format", "msh41"]
        for k, v in extra:
            cmd += ["-setnumber", k, v]
        return footprint.gmsh_run(cmd + ["-o", os.path.abspath(out)], out, cwd=os.path.dirname(path))
    return mesh


def judged(r):
    """Row `r` with its goals judged (`footprint.goal_failures`): a model whose file holds
    no surface element has the status `no surface`, and it and a model Gmsh fails to mesh
    (`mesh-fail`) have no goal."""
    if r.get("status") == "refused" and "nothing to recombine" in r.get("message", ""):
        r["status"] = "no surface"
    r["fails"] = [] if r.get("status") in ("no surface", "mesh-fail") else footprint.goal_failures(r)
    return r


def section(rows, dirs, load, date):
    heading = (
        BEGIN, END, "Gmsh's own example models",
        "Regenerate: `scripts/gmsh_examples.py GMSH_SOURCE` (a checkout of Gmsh's sources; "
        "needs `cargo build --release`).",
        "Input: each .geo file of Gmsh's `" + "`, `".join(dirs.split(",")) + "` meshed in its own "
        "directory with its own settings (`gmsh FILE.geo -2 -format msh41`); `no surface`: the file "
        "holds no surface element (physical groups on volumes or curves only), refused; "
        "`mesh-fail`: Gmsh fails on the model; neither has a goal.")
    return footprint.table(rows, 1, 1, load, date, heading=heading)


def write(a, section_text, rows):
    if a.no_write:
        print(section_text)
    else:
        corpus.write_section(a.out, section_text, BEGIN, END)
    print(footprint.summary(rows))


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source", nargs="?", help="a checkout of Gmsh's sources")
    ap.add_argument("--from-json", default="")
    ap.add_argument("--dirs", default=DIRS)
    ap.add_argument("--dir", default=os.path.join(corpus.REPO, "target", "gmsh-examples"))
    ap.add_argument("--out", default=os.path.join(corpus.REPO, "BENCHMARKS.md"))
    ap.add_argument("--no-write", action="store_true")
    ap.add_argument("--json", default="")
    ap.add_argument("--tool", default=os.environ.get("BLOSSOMQUAD", os.path.join(corpus.REPO, "target", "release", "blossomquad")))
    a = ap.parse_args(argv[1:])
    if a.from_json:
        with open(a.from_json) as f:
            header = json.loads(f.readline())
            rows = [judged(json.loads(line)) for line in f if line.strip()]
        write(a, section(rows, header["dirs"], header["load"], header["date"]), rows)
        return 0
    if not a.source:
        ap.error("give GMSH_SOURCE, or --from-json FILE")
    if not os.access(a.tool, os.X_OK):
        ap.error(f"{a.tool} is not an executable (run `cargo build --release` or pass --tool)")
    models = []
    for d in a.dirs.split(","):
        folder = os.path.join(a.source, d)
        if not os.path.isdir(folder):
            ap.error(f"{folder}: no such directory (is {a.source} a Gmsh source tree?)")
        models += sorted(os.path.join(d, f[:-4]) for f in os.listdir(folder) if f.endswith(".geo"))
    os.makedirs(a.dir, exist_ok=True)
    load = os.getloadavg()[0]
    date = datetime.date.today().isoformat()
    rows = []
    out_json = open(a.json, "w") if a.json else None
    if out_json:
        out_json.write(json.dumps({"dirs": a.dirs, "load": load, "date": date}) + "\n")
    for name in models:
        path = os.path.join(a.source, name + ".geo")
        r = judged(footprint.one(name, "gmsh", "default", None, a.dir, a.tool, 1, mesh=geo_mesher(path)))
        rows.append(r)
        footprint.report_row(r, out_json)
    if out_json:
        out_json.close()
    write(a, section(rows, a.dirs, load, date), rows)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
