#!/usr/bin/env python3
"""Scale and peer benchmark: time and memory from 1e6 triangles up, Gmsh and LEMON. Not a test.

Four parts, each printed as a Markdown table on stdout (progress on stderr):

  scale   the rectangle fixture (geo/rectangle.geo, `size` S, S/2, S/4 with
          S = 0.04233: ~1e6, ~4e6, ~1.6e7 triangles) generated with
          `gmsh -2 ... -format msh41 -bin`, then the whole run
          `blossomquad IN -o OUT --quiet` under `/usr/bin/time -f "%e %U %S %M"`;
          repeats interleaved across sizes; wall (best, spread), CPU, peak RSS,
          MB per 1e6 triangles, growth ratios of the best wall times.
  multi   a grid of NX x NY unit squares, each its own plane surface sharing
          its curves with its neighbours (~1e4 triangles each, ~1e6 in all),
          run with RAYON_NUM_THREADS=1 and =2, interleaved: per-surface
          parallelism.
  gmsh    Gmsh's blossom recombination against the whole blossomquad run at
          ~1e5 triangles: scripts/bench_vs_gmsh.py as it is (BENCH_TARGETS=1e5,
          its report written to the work dir), run REPEATS times; each run
          times Gmsh and blossomquad one after the other, so the pairs are
          interleaved. Median and spread of each time and of the ratio.
  lemon   the matching alone against LEMON: scripts/lemon/compare.sh as it is
          on 1e6-node graphs (examples/gen_matching_graph lattice and random,
          and the real matching graph of the 1e6 rectangle dumped with
          BLOSSOMQUAD_DUMP_GRAPHS), the file list repeated REPEATS times so
          the (ours, LEMON) pairs are interleaved. Median and spread.

Usage: scripts/bench_scale.py [--parts scale,multi,gmsh,lemon] [--dir DIR]
       [--reps N] [--reps-big N] [--sizes 1,2,4] [--refine 4] [--gen-timeout SECONDS]

Generated meshes and outputs go to DIR (default: a new temporary directory,
never the repository); an existing mesh in DIR is reused, not regenerated.
Needs the release binary and examples (`cargo build --release --examples`, then
`cargo build --release` again: a binary built together with the examples gets the
dev-dependencies' features and peaks higher, see BENCHMARKS.md), `gmsh`,
`/usr/bin/time`, and for `lemon` Debian's liblemon-dev.
"""

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIZE_1E6 = 0.04233  # the 1e6 row of BENCHMARKS.md's rectangle fixture
TIME_FMT = "%e %U %S %M"


def log(msg):
    print(f"[{time.strftime('%H:%M:%S')}] {msg}", file=sys.stderr, flush=True)


def load():
    try:
        with open("/proc/loadavg") as f:
            return float(f.read().split()[0])
    except (OSError, ValueError, IndexError):
        return float("nan")


def timed(cmd, env=None, timeout=None, out_log=None):
    """Runs cmd under /usr/bin/time; returns dict(ok, wall, cpu, rss_mb, load0, load1, err)."""
    fd, tfile = tempfile.mkstemp(prefix="time-", suffix=".txt")
    os.close(fd)
    load0 = load()
    try:
        with open(out_log or os.devnull, "wb") as sink:
            proc = subprocess.run(["/usr/bin/time", "-f", TIME_FMT, "-o", tfile, *cmd],
                                  stdout=sink, stderr=subprocess.PIPE, env=env, timeout=timeout)
        err = proc.stderr.decode(errors="replace")
        code = proc.returncode
    except subprocess.TimeoutExpired:
        os.unlink(tfile)
        return {"ok": False, "err": f"timeout after {timeout} s", "load0": load0, "load1": load()}
    with open(tfile) as f:
        fields = f.read().split()
    os.unlink(tfile)
    res = {"ok": code == 0, "err": err.strip()[-300:], "load0": load0, "load1": load()}
    try:
        wall, user, sys_, rss_kb = (float(x) for x in fields[-4:])
        res.update(wall=wall, cpu=user + sys_, rss_mb=rss_kb / 1024.0)
    except ValueError:
        res["ok"] = False
    return res


def triangles(binary, path):
    """Triangle count of a mesh (sum over surfaces of `blossomquad info`)."""
    out = subprocess.run([binary, "info", path], capture_output=True, text=True).stdout
    return sum(int(m) for m in re.findall(r"^surface \d+: (\d+) tri3", out, re.M)), \
        len(re.findall(r"^surface \d+:", out, re.M))


def spread(values):
    return (max(values) - min(values)) if values else float("nan")


def fmt_s(values, digits=2):
    """'median (min-max)' of a list of seconds."""
    if not values:
        return "-"
    if len(values) == 1:
        return f"{values[0]:.{digits}f}"
    return f"{statistics.median(values):.{digits}f} ({min(values):.{digits}f}-{max(values):.{digits}f})"


def gen_rectangle(path, size, timeout):
    if os.path.exists(path):
        log(f"reuse {path}")
        return {"ok": True, "reused": True}
    log(f"gmsh: rectangle size {size} -> {path}")
    tmp = path + ".part.msh"
    res = timed(["gmsh", "-2", os.path.join(REPO, "geo", "rectangle.geo"), "-setnumber", "size", repr(size),
                 "-format", "msh41", "-bin", "-o", tmp], timeout=timeout, out_log=path + ".gmsh.log")
    if res["ok"] and os.path.exists(tmp):
        os.replace(tmp, path)
    elif os.path.exists(tmp):
        os.unlink(tmp)
    log(f"gmsh: {res.get('wall', '-')} s, {res.get('rss_mb', 0):.0f} MB, ok={res['ok']} {res['err'][-120:]}")
    return res


GRID_GEO = """// NX x NY unit squares, one plane surface each, neighbours share curves.
DefineConstant[ nx = {10}, ny = {10}, h = {0.0152} ];
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Mesh.MeshSizeExtendFromBoundary = 0;
For j In {0:ny}
  For i In {0:nx}
    Point(1 + j * (nx + 1) + i) = {i, j, 0};
  EndFor
EndFor
// horizontal curves: 1 + j * nx + i; vertical curves: H + 1 + j * (nx + 1) + i
H = (ny + 1) * nx;
For j In {0:ny}
  For i In {0:nx-1}
    Line(1 + j * nx + i) = {1 + j * (nx + 1) + i, 2 + j * (nx + 1) + i};
  EndFor
EndFor
For j In {0:ny-1}
  For i In {0:nx}
    Line(H + 1 + j * (nx + 1) + i) = {1 + j * (nx + 1) + i, 1 + (j + 1) * (nx + 1) + i};
  EndFor
EndFor
For j In {0:ny-1}
  For i In {0:nx-1}
    s = 1 + j * nx + i;
    Curve Loop(s) = {1 + j * nx + i, H + 2 + j * (nx + 1) + i, -(1 + (j + 1) * nx + i), -(H + 1 + j * (nx + 1) + i)};
    Plane Surface(s) = {s};
  EndFor
EndFor
Physical Surface("grid", 1) = Surface{:};
// a gently varying size, so surfaces differ (Gmsh's MathEval)
Field[1] = MathEval;
Field[1].F = Sprintf("%.17g * (1 + 0.3 * sin(0.7 * x) * cos(0.9 * y))", h);
Background Field = 1;
// odd node count on every curve (even triangle count per surface), as geo/rectangle.geo
Mesh.RecombineAll = 1;
Mesh 1;
Mesh.RecombineAll = 0;
"""


def refine_rectangle(path, coarse, timeout):
    """PATH = the mesh COARSE with every triangle split in four (`gmsh -refine`): 4x the
    triangles, for sizes Gmsh's mesher cannot make in time."""
    if os.path.exists(path):
        log(f"reuse {path}")
        return {"ok": True, "reused": True}
    log(f"gmsh: refine {coarse} -> {path}")
    tmp = path + ".part.msh"
    res = timed(["gmsh", coarse, "-refine", "-format", "msh41", "-bin", "-o", tmp], timeout=timeout,
                out_log=path + ".gmsh.log")
    if res["ok"] and os.path.exists(tmp):
        os.replace(tmp, path)
    elif os.path.exists(tmp):
        os.unlink(tmp)
    return res


def part_scale(args, binary, work):
    sizes = [(int(k), SIZE_1E6 / k) for k in args.sizes]
    files = {}
    gen = {}
    for k, s in sizes:
        if k in args.refine and k % 2 == 0 and (k // 2) in files:
            path = os.path.join(work, f"rect-x{k // 2}-refined.msh")
            gen[k] = refine_rectangle(path, files[k // 2], args.gen_timeout)
            gen[k]["refined"] = True
        else:
            path = os.path.join(work, f"rect-x{k}.msh")
            gen[k] = gen_rectangle(path, s, args.gen_timeout)
        if gen[k]["ok"]:
            files[k] = path
        else:
            log(f"scale: size S/{k} could not be generated: {gen[k]['err']}")
    counts = {k: triangles(binary, p)[0] for k, p in files.items()}
    runs = {k: [] for k in files}
    reps = {k: (args.reps if k <= 2 else args.reps_big) for k in files}
    for rep in range(max(reps.values(), default=0)):
        for k, path in files.items():
            if rep >= reps[k]:
                continue
            out = os.path.join(work, f"rect-x{k}-quad.msh")
            log(f"scale: S/{k} ({counts[k]} triangles) rep {rep + 1}")
            r = timed(["nice", "-n", str(args.nice), binary, path, "-o", out, "--quiet"])
            log(f"  wall {r.get('wall')} cpu {r.get('cpu')} rss {r.get('rss_mb')} load {r['load0']}->{r['load1']}"
                f" ok={r['ok']} {r['err'][-200:] if not r['ok'] else ''}")
            if r["ok"]:
                runs[k].append(r)
            if os.path.exists(out):
                os.unlink(out)
    lines = ["| size | triangles | Gmsh to make it (s, MB) | runs | wall best (s) | wall spread (s) | CPU of best (s) "
             "| peak RSS (MB) | MB per 10^6 tri | load during |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    best = {}
    for k, s in sizes:
        g = gen[k]
        gtxt = ("S/" + str(k // 2) + " refined once (gmsh -refine); " if g.get("refined") else "") + \
            ("reused" if g.get("reused") else (f"{g['wall']:.0f}, {g['rss_mb']:.0f}" if g["ok"] else
                                                  "failed: " + g["err"][-80:].replace("|", "/")))
        rs = runs.get(k, [])
        if not rs:
            lines.append(f"| S/{k} = {s:.5g} | {counts.get(k, '-')} | {gtxt} | 0 | - | - | - | - | - | - |")
            continue
        b = min(rs, key=lambda r: r["wall"])
        best[k] = b["wall"]
        rss = max(r["rss_mb"] for r in rs)
        loads = [x for r in rs for x in (r["load0"], r["load1"])]
        lines.append(f"| S/{k} = {s:.5g} | {counts[k]} | {gtxt} | {len(rs)} | {b['wall']:.2f} | "
                     f"{spread([r['wall'] for r in rs]):.2f} | {b['cpu']:.2f} | {rss:.0f} | "
                     f"{rss / counts[k] * 1e6:.0f} | {min(loads):.1f}-{max(loads):.1f} |")
    ks = sorted(best)
    ratios = []
    for a, b in zip(ks, ks[1:]):
        tri = counts[b] / counts[a]
        ratios.append(f"time(S/{b}) / time(S/{a}) = {best[b] / best[a]:.2f} "
                      f"(triangles x{tri:.2f}, per-triangle {best[b] / best[a] / tri:.2f})")
    return lines + [""] + ["Growth (best wall times): " + "; ".join(ratios) if ratios else "Growth: -"]


def part_multi(args, binary, work):
    geo = os.path.join(work, "grid.geo")
    with open(geo, "w") as f:
        f.write(GRID_GEO)
    path = os.path.join(work, f"grid-{args.grid}.msh")
    nx, ny = (int(x) for x in args.grid.split("x"))
    if not os.path.exists(path):
        log(f"gmsh: grid {args.grid} -> {path}")
        tmp = path + ".part.msh"
        g = timed(["gmsh", "-2", geo, "-setnumber", "nx", str(nx), "-setnumber", "ny", str(ny),
                   "-setnumber", "h", repr(args.grid_h), "-format", "msh41", "-bin", "-o", tmp],
                  timeout=args.gen_timeout, out_log=path + ".gmsh.log")
        if not (g["ok"] and os.path.exists(tmp)):
            return [f"multi-surface model: Gmsh failed: {g['err'][-200:]}"]
        os.replace(tmp, path)
    tri, nsurf = triangles(binary, path)
    runs = {1: [], 2: []}
    for rep in range(args.reps):
        for threads in (1, 2):
            env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
            out = os.path.join(work, "grid-quad.msh")
            log(f"multi: {nsurf} surfaces, {tri} triangles, {threads} thread(s), rep {rep + 1}")
            r = timed(["nice", "-n", str(args.nice), binary, path, "-o", out, "--quiet"], env=env)
            log(f"  wall {r.get('wall')} cpu {r.get('cpu')} rss {r.get('rss_mb')} load {r['load0']}->{r['load1']}")
            if r["ok"]:
                runs[threads].append(r)
            if os.path.exists(out):
                os.unlink(out)
    lines = [f"Model: {nx} x {ny} unit squares, {nsurf} surfaces, {tri} triangles "
             f"({tri // max(nsurf, 1)} per surface on average).", "",
             "| RAYON_NUM_THREADS | runs | wall best (s) | wall spread (s) | CPU of best (s) | peak RSS (MB) | load during |",
             "|---|---|---|---|---|---|---|"]
    for threads, rs in runs.items():
        if not rs:
            lines.append(f"| {threads} | 0 | - | - | - | - | - |")
            continue
        b = min(rs, key=lambda r: r["wall"])
        loads = [x for r in rs for x in (r["load0"], r["load1"])]
        lines.append(f"| {threads} | {len(rs)} | {b['wall']:.2f} | {spread([r['wall'] for r in rs]):.2f} | "
                     f"{b['cpu']:.2f} | {max(r['rss_mb'] for r in rs):.0f} | {min(loads):.1f}-{max(loads):.1f} |")
    if runs[1] and runs[2]:
        w1 = min(r["wall"] for r in runs[1])
        w2 = min(r["wall"] for r in runs[2])
        lines += ["", f"Speed-up of 2 threads over 1 (best walls): {w1 / w2:.2f}"]
    return lines


def part_gmsh(args, binary, work):
    per = {"gmsh": [], "ours": [], "ratio": [], "load": []}
    for rep in range(args.reps_peers):
        d = os.path.join(work, f"vs-gmsh-{rep}")
        env = dict(os.environ, BENCH_TARGETS="1e5", BENCH_FIXTURES=args.gmsh_fixture, BENCH_DIR=d,
                   BENCH_OUT=os.path.join(d, "report.md"), BLOSSOMQUAD=binary)
        os.makedirs(d, exist_ok=True)
        log(f"gmsh peer: bench_vs_gmsh.py {args.gmsh_fixture} 1e5 rep {rep + 1}")
        l0 = load()
        p = subprocess.run(["nice", "-n", str(args.nice), sys.executable,
                            os.path.join(REPO, "scripts", "bench_vs_gmsh.py")],
                           env=env, capture_output=True, text=True)
        per["load"] += [l0, load()]
        g = re.search(r"^\s+Gmsh blossom from CAD\s+([\d.]+) s", p.stderr, re.M)
        o = re.search(r"^\s+blossomquad\s+([\d.]+) s", p.stderr, re.M)
        if not (g and o):
            log(f"  failed: {p.stderr[-300:]}")
            continue
        gt, ot = float(g.group(1)), float(o.group(1))
        log(f"  Gmsh blossom {gt} s, blossomquad {ot} s, ratio {gt / ot:.1f}")
        per["gmsh"].append(gt)
        per["ours"].append(ot)
        per["ratio"].append(gt / ot)
        # the tables of the last run, for quality figures
        shutil.copy(os.path.join(d, "report.md"), os.path.join(work, "vs-gmsh-report.md"))
        shutil.rmtree(d, ignore_errors=True)
    return ["| fixture | runs | Gmsh blossom from CAD (s) | blossomquad whole run (s) | ratio | load during |",
            "|---|---|---|---|---|---|",
            f"| {args.gmsh_fixture} ~1e5 | {len(per['ratio'])} | {fmt_s(per['gmsh'])} | {fmt_s(per['ours'])} | "
            f"{fmt_s(per['ratio'], 1)} | {min(per['load'], default=0):.1f}-{max(per['load'], default=0):.1f} |",
            "", "Median (min-max) over the runs; ratio per run, Gmsh's time over ours in the same run."]


def part_lemon(args, binary, work):
    rel = os.path.join(os.path.dirname(binary), "examples")
    gen, solve = os.path.join(rel, "gen_matching_graph"), os.path.join(rel, "solve_matching")
    graphs = {}
    for kind in ("lattice", "random"):
        p = os.path.join(work, f"graph-{kind}-1e6.txt")
        if not os.path.exists(p):
            log(f"lemon: gen_matching_graph {kind} 1000000")
            subprocess.run([gen, kind, "1000000", p], check=True, stdout=subprocess.DEVNULL)
        graphs[kind] = p
    real = os.path.join(work, "graph-rectangle-1e6.txt")
    mesh = os.path.join(work, "rect-x1.msh")
    if not os.path.exists(real) and gen_rectangle(mesh, SIZE_1E6, args.gen_timeout)["ok"]:
        dump = os.path.join(work, "dump")
        os.makedirs(dump, exist_ok=True)
        log("lemon: dumping the 1e6 rectangle's matching graph")
        subprocess.run([binary, mesh, "-o", os.path.join(work, "dump-out.msh"), "--quiet"],
                       env=dict(os.environ, BLOSSOMQUAD_DUMP_GRAPHS=dump), check=False)
        dumped = sorted(os.listdir(dump))
        if dumped:
            os.replace(os.path.join(dump, dumped[0]), real)
        shutil.rmtree(dump, ignore_errors=True)
        if os.path.exists(os.path.join(work, "dump-out.msh")):
            os.unlink(os.path.join(work, "dump-out.msh"))
    if os.path.exists(real):
        graphs["rectangle (real)"] = real
    lemon = subprocess.run([os.path.join(REPO, "scripts", "lemon", "build.sh"),
                            os.path.join(os.path.dirname(os.path.dirname(binary)), "lemon")],
                           capture_output=True, text=True)
    if lemon.returncode != 0:
        return ["LEMON driver did not build (is liblemon-dev installed?): " + lemon.stderr[-200:]]
    files = list(graphs.values()) * args.reps_peers
    log(f"lemon: compare.sh on {len(graphs)} graphs x {args.reps_peers}")
    l0 = load()
    p = subprocess.run(["nice", "-n", str(args.nice), os.path.join(REPO, "scripts", "lemon", "compare.sh"), *files],
                       env=dict(os.environ, SOLVE=solve, LEMON=lemon.stdout.strip().splitlines()[-1]),
                       capture_output=True, text=True)
    l1 = load()
    sys.stderr.write(p.stdout)
    rows = {name: {"ours": [], "cpu": [], "lemon": [], "ratio": [], "same": [], "n": "-", "mb": [], "lmb": []}
            for name in graphs}
    byfile = {os.path.basename(v): k for k, v in graphs.items()}
    for line in p.stdout.splitlines()[1:]:
        f = line.split()
        if len(f) < 9 or f[0] not in byfile:
            continue
        r = rows[byfile[f[0]]]
        try:
            r["n"] = f[1]
            r["ours"].append(float(f[2]))
            r["cpu"].append(float(f[3]))
            r["mb"].append(int(f[4]))
            r["lemon"].append(float(f[5]))
            r["lmb"].append(int(f[6]))
            r["ratio"].append(float(f[5]) / float(f[2]))
            r["same"].append(f[8] + " " + " ".join(f[9:]))
        except (ValueError, ZeroDivisionError):
            continue
    lines = ["| graph | n | pairs | ours (s) | ours CPU (s) | ours MB | LEMON (s) | LEMON MB | LEMON / ours | same cost, verified |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name, r in rows.items():
        same = "; ".join(sorted(set(r["same"]))) or "-"
        lines.append(f"| {name} | {r['n']} | {len(r['ratio'])} | {fmt_s(r['ours'])} | {fmt_s(r['cpu'])} | "
                     f"{max(r['mb'], default=0)} | {fmt_s(r['lemon'])} | {max(r['lmb'], default=0)} | "
                     f"{fmt_s(r['ratio'], 1)} | {same} |")
    return lines + ["", f"Solver time only (no parsing), median (min-max); load {l0:.1f} before, {l1:.1f} after."]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--parts", default="scale,multi,gmsh,lemon")
    ap.add_argument("--dir", help="work dir (default: a new temporary directory)")
    ap.add_argument("--reps", type=int, default=2, help="runs per size at 1e6 and 4e6, and per thread count")
    ap.add_argument("--reps-big", type=int, default=1, help="runs at 1.6e7")
    ap.add_argument("--reps-peers", type=int, default=3, help="runs of each peer comparison")
    ap.add_argument("--sizes", default="1,2,4", help="divisors of S = 0.04233 (triangles x divisor^2)")
    ap.add_argument("--refine", default="", help="divisors (e.g. 4) made by refining the mesh at half "
                    "the divisor once with `gmsh -refine` instead of meshing (Gmsh's mesher takes >20 min "
                    "at 1.6e7 on 2 shared cores)")
    ap.add_argument("--grid", default="10x10", help="multi-surface model: NXxNY unit squares")
    ap.add_argument("--grid-h", type=float, default=0.0152, help="mesh size of the grid (~1e4 triangles/square)")
    ap.add_argument("--gmsh-fixture", default="rectangle")
    ap.add_argument("--gen-timeout", type=float, default=900, help="seconds Gmsh may take per mesh")
    ap.add_argument("--nice", type=int, default=5)
    args = ap.parse_args()
    args.sizes = [int(x) for x in args.sizes.split(",")]
    args.refine = [int(x) for x in args.refine.split(",") if x]
    binary = os.path.abspath(os.environ.get("BLOSSOMQUAD", os.path.join(REPO, "target", "release", "blossomquad")))
    if not os.path.exists(binary):
        sys.exit(f"{binary} missing: cargo build --release --examples")
    work = args.dir or tempfile.mkdtemp(prefix="bench-scale-")
    os.makedirs(work, exist_ok=True)
    log(f"work dir {work}")
    parts = {"scale": part_scale, "multi": part_multi, "gmsh": part_gmsh, "lemon": part_lemon}
    for name in args.parts.split(","):
        lines = parts[name](args, binary, work)
        print(f"\n### {name}\n")
        print("\n".join(lines), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
