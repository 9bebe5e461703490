#!/usr/bin/env python3
"""blossomquad against Gmsh's own recombination on the robustness corpus (corpus/).

    scripts/bench_corpus.py [--sizes coarse,fine] [--models NAME,...] [--dir WORKDIR]
                            [--out BENCHMARKS.md] [--tool PATH]

For every model of corpus/models.tsv and every size, one after the other (never in
parallel, so the times mean something):

  1. the model is meshed by Gmsh into MSH 4.1 (`gmsh -2`, surfaces only);
  2. `blossomquad IN -o OUT` runs (wall time measured), then `tests/check_mesh.py IN OUT`
     says whether the output is valid;
  3. the same model is meshed by Gmsh with `Mesh.RecombineAll = 1` (Gmsh's own
     recombination from the CAD, default recombination algorithm);
  4. OUR `blossomquad quality --json` measures the input (triangle count), our output
     (eta_w = worst quad quality, eta mean, d4 = share of regular interior vertices) and
     Gmsh's output (triangles left, eta_w, eta mean).

The table and a summary line (medians over the runs where both tools gave a result,
counts of refusals and invalid outputs) are written into the Markdown file between
the markers `<!-- corpus-table:begin -->` and `<!-- corpus-table:end -->` (appended
with the markers when they are missing), so rerunning replaces only that section.

Speed against Gmsh's recombination step, instead of the table above:

    scripts/bench_corpus.py --speed [--min-triangles 5000] [--reps 3] [--models ...]
    scripts/bench_corpus.py --cases MODEL:SIZE,... [--per-triangle-vs MODEL] [--reps 3]

`--speed` takes the corpus models whose fine size has at least --min-triangles
triangles; `--cases` takes the given models at the given sizes (corpus names, or paths in
the repository without extension such as geo/rectangle). Each model is meshed once into
MSH 4.1 (the input). Then, --reps times, every model in turn (so the runs of the two
tools interleave): `gmsh -2` (triangles) and `gmsh -2` with `Mesh.RecombineAll = 1`,
`Mesh.RecombinationAlgorithm = 1` (Blossom) are timed, their difference being Gmsh's
recombination step (recombination and its smoothing), and `blossomquad IN -o OUT --quiet`
(the whole run: read, recombine, optimize, checks, write). The table gives medians with
the smallest and largest value, the speed-up (Gmsh's step / our run) per repetition, our
time per triangle and, with --per-triangle-vs, its ratio to that model's. `--speed`
writes between `<!-- corpus-speed:begin -->` and `<!-- corpus-speed:end -->`, `--cases`
between `<!-- speed-cases:begin -->` and `<!-- speed-cases:end -->`.
"""

import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import corpus  # noqa: E402  (scripts/corpus.py)

BEGIN = "<!-- corpus-table:begin -->"
END = "<!-- corpus-table:end -->"
SPEED = ("<!-- corpus-speed:begin -->", "<!-- corpus-speed:end -->")
CASES = ("<!-- speed-cases:begin -->", "<!-- speed-cases:end -->")
RECOMBINE = [("Mesh.RecombineAll", "1"), ("Mesh.RecombinationAlgorithm", "1")]


def quality(tool, path):
    p = subprocess.run([tool, "quality", path, "--json"], capture_output=True, timeout=corpus.TIMEOUT)
    if p.returncode != 0:
        return None
    try:
        return json.loads(p.stdout)["total"]
    except (ValueError, KeyError):
        return None


def fmt(x, digits=3):
    if x is None:
        return "–"
    if isinstance(x, float):
        return f"{x:.{digits}f}"
    return str(x)


def bench_one(name, cls, level, size, workdir, tool):
    base = os.path.join(workdir, f"{name}-{level}")
    tri, out, gq = base + ".msh", base + ".quads.msh", base + ".gmsh-quads.msh"
    row = {"model": name, "class": cls, "size": level}
    ok, msg, _ = corpus.mesh(name, size, "msh41", tri)
    if not ok:
        row["status"] = "mesh-fail"
        return row
    qin = quality(tool, tri)
    row["triangles"] = qin["triangles"] if qin else None
    if os.path.exists(out):
        os.remove(out)
    t0 = time.perf_counter()
    tag_map = out + ".tag-map.json"
    p = subprocess.run([tool, tri, "-o", out, "--tag-map", tag_map], capture_output=True,
                       timeout=corpus.TIMEOUT)
    row["seconds"] = time.perf_counter() - t0
    if p.returncode == 1:
        row["status"] = "refused"
    elif p.returncode != 0:
        row["status"] = "crash"
    else:
        # through the tag map: the output is numbered 1..N
        c = subprocess.run([sys.executable, corpus.CHECKER, tri, out, "--tag-map=" + tag_map],
                           capture_output=True, timeout=corpus.TIMEOUT)
        row["status"] = "pass" if c.returncode == 0 else "invalid"
        q = quality(tool, out)
        if q:
            row.update(eta_w=q["eta_worst"], eta_mean=q["eta_mean"], d4=q["d4_percent"])
    ok, _, _ = corpus.mesh(name, size, "msh41", gq, extra=[("Mesh.RecombineAll", "1")])
    if ok:
        g = quality(tool, gq)
        if g:
            row.update(gmsh_tris=g["triangles"], gmsh_eta_w=g["eta_worst"], gmsh_eta_mean=g["eta_mean"])
    else:
        row["gmsh_fail"] = True
    return row


def table(rows, tool):
    lines = [
        BEGIN,
        "",
        "## Robustness corpus: blossomquad vs Gmsh's recombination",
        "",
        f"Generated by `scripts/bench_corpus.py` on {datetime.date.today().isoformat()} "
        f"({len(rows)} runs; models in `corpus/`, sizes in `corpus/models.tsv`). "
        "Input: `gmsh -2` in MSH 4.1; ours: `blossomquad IN -o OUT` (status from "
        "`tests/check_mesh.py`); Gmsh: the same model meshed with `Mesh.RecombineAll = 1`. "
        "All figures by `blossomquad quality --json` (eta_w worst quad quality, eta mean, "
        "d4 share of regular interior vertices); time is the whole blossomquad run.",
        "",
        "| model | class | size | triangles | status | η_w | η̄ | d4 % | time s | Gmsh tris left | Gmsh η_w | Gmsh η̄ |",
        "|---|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['model']} | {r['class']} | {r['size']} | {fmt(r.get('triangles'))} | {r.get('status')} | "
            f"{fmt(r.get('eta_w'))} | {fmt(r.get('eta_mean'))} | {fmt(r.get('d4'), 1)} | {fmt(r.get('seconds'), 2)} | "
            f"{fmt(r.get('gmsh_tris'))} | {fmt(r.get('gmsh_eta_w'))} | {fmt(r.get('gmsh_eta_mean'))} |")
    both = [r for r in rows if r.get("eta_mean") is not None and r.get("gmsh_eta_mean") is not None]
    count = {}
    for r in rows:
        count[r.get("status")] = count.get(r.get("status"), 0) + 1

    def med(key, rs):
        vals = [r[key] for r in rs if r.get(key) is not None]
        return fmt(statistics.median(vals)) if vals else "–"

    gmsh_left = sum(1 for r in rows if (r.get("gmsh_tris") or 0) > 0)
    lines += [
        "",
        f"Summary: {len(rows)} runs: " + ", ".join(f"{k} {v}" for k, v in sorted(count.items())) +
        f". Over the {len(both)} runs where both tools gave quads: median η̄ {med('eta_mean', both)} (ours) vs "
        f"{med('gmsh_eta_mean', both)} (Gmsh), median η_w {med('eta_w', both)} vs {med('gmsh_eta_w', both)}; "
        f"Gmsh leaves triangles on {gmsh_left} of {len(rows)} runs. "
        f"Runs with η_w = 0: {sum(1 for r in rows if r.get('eta_w') == 0)}.",
        "",
        END,
    ]
    return "\n".join(lines) + "\n"


def spread(values, digits=2):
    """`median [min-max]` of values."""
    if not values:
        return "–"
    return (f"{statistics.median(values):.{digits}f} [{min(values):.{digits}f}–"
            f"{max(values):.{digits}f}]")


def timed(cmd):
    """Wall seconds of cmd, or None when it fails."""
    code, _, _, secs = corpus.run(cmd)
    return secs if code == 0 else None


def speed(cases, reps, workdir, tool):
    """Interleaved timings of Gmsh's recombination step and of our whole run on each
    (label, model, size) of cases; returns one row per case."""
    rows = []
    load = os.getloadavg()[0]
    for label, model, size in cases:
        base = os.path.join(workdir, f"speed-{label.replace('/', '_')}-{size}")
        row = {"label": label, "model": model, "size": size, "tri": base + ".msh",
               "gmsh": [], "ours": [], "ratio": []}
        ok, _, _ = corpus.mesh(model, size, "msh41", row["tri"])
        q = quality(tool, row["tri"]) if ok else None
        row["triangles"] = q["triangles"] if q else None
        rows.append(row)
    for rep in range(reps):
        for row in rows:
            if not row["triangles"]:
                continue
            base = row["tri"][:-4]
            t_tri = timed(corpus.mesh_command(row["model"], row["size"], corpus.VARIANTS["msh41"],
                                              base + ".gmsh-tri.msh"))
            t_rec = timed(corpus.mesh_command(row["model"], row["size"],
                                              corpus.VARIANTS["msh41"] + RECOMBINE,
                                              base + ".gmsh-quads.msh"))
            t_ours = timed([tool, row["tri"], "-o", base + ".quads.msh", "--quiet"])
            if t_ours is not None:
                row["ours"].append(t_ours)
            if t_tri is not None and t_rec is not None:
                row["gmsh"].append(max(t_rec - t_tri, 0.0))
                if t_ours:
                    row["ratio"].append(max(t_rec - t_tri, 0.0) / t_ours)
            print(f"speed {rep + 1}/{reps} {row['label']:<28} tris {row['triangles']} "
                  f"ours {fmt(t_ours, 3)} s, Gmsh step {fmt(row['gmsh'][-1] if row['gmsh'] else None, 3)} s",
                  flush=True)
    for row in rows:
        row["load"] = (load, os.getloadavg()[0])
    return rows


def speed_table(rows, command, markers, per_triangle_vs=None):
    ref = next((r for r in rows if r["label"] == per_triangle_vs and r["ours"]), None)
    ref_us = statistics.median(ref["ours"]) / ref["triangles"] * 1e6 if ref else None
    lines = [
        markers[0],
        "",
        f"`{command}`",
        "",
        "| model | size | triangles | ours s | Gmsh recombination step s | speed-up | ours µs/triangle |"
        + (f" per triangle vs {per_triangle_vs} |" if ref else ""),
        "|---|---:|---:|---:|---:|---:|---:|" + ("---:|" if ref else ""),
    ]
    for r in rows:
        us = statistics.median(r["ours"]) / r["triangles"] * 1e6 if r["ours"] and r["triangles"] else None
        line = (f"| {r['label']} | {r['size']} | {fmt(r['triangles'])} | {spread(r['ours'])} | "
                f"{spread(r['gmsh'])} | {spread(r['ratio'], 1)} | {fmt(us, 2)} |")
        if ref:
            line += f" {fmt(us / ref_us if us else None, 2)} |"
        lines.append(line)
    ratios = [statistics.median(r["ratio"]) for r in rows if r["ratio"]]
    lines += [
        "",
        f"Medians of {max((len(r['ours']) for r in rows), default=0)} interleaved runs "
        "[smallest–largest]; speed-up = Gmsh's step / our whole run, per run. "
        + (f"Load average (1 min) {rows[0]['load'][0]:.1f} before and {rows[0]['load'][1]:.1f} after, "
           f"on {os.cpu_count()} cores. " if rows and "load" in rows[0] else "")
        + (f"Median speed-up over the {len(ratios)} models {statistics.median(ratios):.1f}, "
           f"smallest {min(ratios):.1f}." if ratios else ""),
        "",
        markers[1],
    ]
    return "\n".join(lines) + "\n"


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="coarse,fine")
    ap.add_argument("--models", default="")
    ap.add_argument("--dir", default=os.path.join(corpus.REPO, "target", "bench-corpus"))
    ap.add_argument("--out", default=os.path.join(corpus.REPO, "BENCHMARKS.md"))
    ap.add_argument("--tool", default=os.environ.get("BLOSSOMQUAD", os.path.join(corpus.REPO, "target", "release", "blossomquad")))
    ap.add_argument("--speed", action="store_true", help="the speed table of the fine models")
    ap.add_argument("--min-triangles", type=int, default=5000)
    ap.add_argument("--cases", default="", help="MODEL:SIZE,... timed instead of the corpus")
    ap.add_argument("--per-triangle-vs", default=None)
    ap.add_argument("--reps", type=int, default=3)
    a = ap.parse_args(argv[1:])
    os.makedirs(a.dir, exist_ok=True)
    models = corpus.read_models()
    if a.models:
        models = [m for m in models if m[0] in set(a.models.split(","))]
    if a.cases:
        cases = [(m, m, float(sz)) for m, sz in (c.rsplit(":", 1) for c in a.cases.split(","))]
        rows = speed(cases, a.reps, a.dir, a.tool)
        command = (f"scripts/bench_corpus.py --cases {a.cases} --reps {a.reps}"
                   + (f" --per-triangle-vs {a.per_triangle_vs}" if a.per_triangle_vs else ""))
        corpus.write_section(a.out, speed_table(rows, command, CASES, a.per_triangle_vs), *CASES)
        return 0
    if a.speed:
        cases = [(name, name, sizes["fine"]) for name, _, sizes in models]
        # the models' sizes first (untimed), then only those with enough triangles
        big = []
        for label, model, size in cases:
            tri = os.path.join(a.dir, f"count-{model}.msh")
            ok, _, _ = corpus.mesh(model, size, "msh41", tri)
            q = quality(a.tool, tri) if ok else None
            if q and q["triangles"] >= a.min_triangles:
                big.append((label, model, size))
        rows = speed(big, a.reps, a.dir, a.tool)
        command = f"scripts/bench_corpus.py --speed --min-triangles {a.min_triangles} --reps {a.reps}"
        corpus.write_section(a.out, speed_table(rows, command, SPEED), *SPEED)
        return 0
    rows = []
    for level in a.sizes.split(","):
        for name, cls, sizes in models:
            row = bench_one(name, cls, level, sizes[level], a.dir, a.tool)
            rows.append(row)
            print(f"{name:<26} {level:<6} {row.get('status'):<9} tris {fmt(row.get('triangles'))} "
                  f"eta_w {fmt(row.get('eta_w'))} eta {fmt(row.get('eta_mean'))} "
                  f"gmsh left {fmt(row.get('gmsh_tris'))} eta_w {fmt(row.get('gmsh_eta_w'))}", flush=True)
        corpus.write_section(a.out, table(rows, a.tool), BEGIN, END)  # after each size, so a coarse table survives
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
