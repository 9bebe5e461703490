#!/usr/bin/env python3
"""The fallback's footprint on the robustness corpus, against Gmsh's recombination.

    scripts/footprint.py [--sizes coarse,fine] [--models NAME,...] [--jobs N] [--repeat N]
                         [--dir WORKDIR] [--out BENCHMARKS.md | --no-write] [--json FILE]
                         [--tool PATH]
    scripts/footprint.py --from-json FILE [--out BENCHMARKS.md | --no-write]
    scripts/footprint.py --wall-bound MESH.msh

For every model of corpus/models.tsv and every size:

  1. Gmsh meshes the model into MSH 4.1 (`gmsh -2`, surfaces only; the input);
  2. the input's triangles and quads are counted (`blossomquad quality --json`) and its
     wall-corner bound is computed: at every boundary node of a surface (a node on an edge
     that only one of the surface's triangles has), the sum of the surface's triangle
     angles there, divided by 90 degrees; the bound is the smallest such value over the
     model's surfaces, capped at 1 (a quad with a corner of that angle has eta at most
     the bound, eq. 3); none (shown "–", the goal is then 0.2) for closed surfaces;
  3. `blossomquad IN -o OUT` runs (wall and CPU time, user + system over all threads, of
     the whole process, read and write included); its log gives the fallback's rounds, triangles split into three quads
     and quads priced out of the matching (see `fallback_of`);
     `tests/check_mesh.py IN OUT` says whether the output is valid;
  4. `blossomquad quality --json OUT` gives the quads, eta_w (worst quad, eq. 3) and the
     mean eta; new quads per input triangle = (output quads - input quads) / input
     triangles (0.5 when every triangle pairs with a neighbour);
  5. Gmsh recombines the same model from the CAD (`Mesh.RecombineAll = 1`,
     `Mesh.RecombinationAlgorithm = 1`, blossom), measured the same way (triangles left,
     eta_w, mean eta); Gmsh's time is its "Done meshing 2D" wall and CPU time with
     recombination minus the same without (Gmsh's own clock, inside the process; Gmsh
     runs one thread, and on a loaded machine the CPU figures are the steadier).

A row fails the goals (flag column) when the tool refuses, crashes or writes an invalid
mesh; when the model has at least 500 input triangles and more than 0.6 new quads per
input triangle; when eta_w < min(0.2, the wall-corner bound) by more than 0.001 (the
tool's own margin for a worst quad at that bound: on a curved face a quad's corner at a
sharp wall corner can fall a few millionths under the sum of the triangles' angles there);
or when a quad has a
corner with a scaled Jacobian <= 0 about its own normal (`sj_min` of `blossomquad
quality`).

The table is written into the Markdown file (default BENCHMARKS.md) between the markers
`<!-- footprint-table:begin -->` and `<!-- footprint-table:end -->` (appended with the
markers when they are missing), so rerunning replaces only that section; `--no-write`
prints it instead. `--jobs N` runs N models at once (default 1: serial, so the times mean
something); `--repeat N` runs each timed command N times and keeps the median. `--json
FILE` writes the run's settings and then one JSON object per row; `--from-json FILE`
rebuilds the table from such a file without running anything.
"""

import argparse
import concurrent.futures
import datetime
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import corpus  # noqa: E402  (scripts/corpus.py)

BEGIN = "<!-- footprint-table:begin -->"
END = "<!-- footprint-table:end -->"
MIN_TRIANGLES = 500
MAX_QUADS_PER_TRIANGLE = 0.6
ETA_GOAL = 0.2
# a worst quad this close under min(ETA_GOAL, bound) is at the bound (the tool's RAISE_MIN)
ETA_TOLERANCE = 1e-3
GMSH_RECOMBINE = [("Mesh.RecombineAll", "1"), ("Mesh.RecombinationAlgorithm", "1")]
FALLBACK_LINE = re.compile(r"^fallback round (\d+):")
SPLIT_COUNT = re.compile(r"(\d+) triangle\(s\) split into three quads")
PRICED_OUT = re.compile(r"(\d+) quad\(s\) priced out of the matching")
MESH_2D = re.compile(r"Done meshing 2D \(Wall ([0-9.eE+-]+)s, CPU ([0-9.eE+-]+)s")


def wall_bound(path):
    """The input's wall-corner bound (see the module doc) and the surface where it is
    smallest: (bound, surface) or (None, None) without a boundary node."""
    import gmsh

    gmsh.initialize(["footprint"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.open(path)
    tags, coords, _ = gmsh.model.mesh.getNodes()
    xyz = {int(t): (coords[3 * i], coords[3 * i + 1], coords[3 * i + 2]) for i, t in enumerate(tags)}
    best, where = None, None
    for _, surface in gmsh.model.getEntities(2):
        types, _, nodes = gmsh.model.mesh.getElements(2, surface)
        tris = []
        for etype, conn in zip(types, nodes):
            _, edim, _, nn, _, ncorner = gmsh.model.mesh.getElementProperties(etype)
            if ncorner != 3:
                continue
            conn = [int(n) for n in conn]
            tris += [conn[i:i + 3] for i in range(0, len(conn), nn)]
        if not tris:
            continue
        edges = {}
        angle = {}
        for tri in tris:
            for k in range(3):
                a, b, c = tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]
                key = (min(a, b), max(a, b))
                edges[key] = edges.get(key, 0) + 1
                angle[a] = angle.get(a, 0.0) + corner_angle(xyz[a], xyz[b], xyz[c])
        boundary = {n for e, count in edges.items() if count != 2 for n in e}
        for n in boundary:
            value = min(1.0, angle[n] / 90.0)
            if best is None or value < best:
                best, where = value, surface
    gmsh.finalize()
    return best, where


def corner_angle(p, q, r):
    """The angle at p of the triangle p q r, in degrees."""
    u = [q[i] - p[i] for i in range(3)]
    v = [r[i] - p[i] for i in range(3)]
    nu, nv = math.sqrt(sum(x * x for x in u)), math.sqrt(sum(x * x for x in v))
    if nu == 0 or nv == 0:
        return 0.0
    c = sum(u[i] * v[i] for i in range(3)) / (nu * nv)
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def quality(tool, path):
    p = subprocess.run([tool, "quality", path, "--json"], capture_output=True, timeout=corpus.TIMEOUT)
    if p.returncode != 0:
        return None
    try:
        return json.loads(p.stdout)["total"]
    except (ValueError, KeyError):
        return None


def run_timed(cmd):
    """Runs cmd; returns (exit code or None on a timeout, stderr text, wall seconds, CPU
    seconds of the process and its threads: user + system)."""
    with tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err)
        timer = threading.Timer(corpus.TIMEOUT, p.kill)
        timer.start()
        _, status, usage = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
        timer.cancel()
        p.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        text = err.read().decode("utf-8", "replace")
    code = p.returncode if p.returncode >= 0 else None
    return code, text, wall, usage.ru_utime + usage.ru_stime


def gmsh_mesh(name, size, out, extra=()):
    """Meshes one model in MSH 4.1 with Gmsh's log on; returns (ok, (wall, CPU) seconds
    of the 2D meshing by Gmsh's own clock, or None)."""
    cmd = corpus.mesh_command(name, size, corpus.VARIANTS["msh41"] + list(extra), out)
    return gmsh_run(cmd, out, env=dict(os.environ, CORPUS_VERBOSE="1"))


def gmsh_run(cmd, out, env=None, cwd=None):
    """Runs a Gmsh meshing command that writes `out`; returns (ok, (wall, CPU) seconds of
    the 2D meshing by Gmsh's own clock, or None): not ok when Gmsh fails, times out, logs
    an error or writes no file."""
    if os.path.exists(out):
        os.remove(out)
    try:
        p = subprocess.run(cmd, capture_output=True, timeout=corpus.TIMEOUT, env=env, cwd=cwd)
    except subprocess.TimeoutExpired:
        return False, None
    log = p.stdout.decode("utf-8", "replace") + p.stderr.decode("utf-8", "replace")
    errors = [line for line in log.splitlines() if line.startswith("Error") or "Exception" in line]
    if p.returncode != 0 or errors or not os.path.isfile(out):
        return False, None
    found = [(float(m.group(1)), float(m.group(2))) for m in MESH_2D.finditer(log)]
    if not found:
        return True, None
    return True, (sum(w for w, _ in found), sum(c for _, c in found))


def median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def fallback_of(log):
    """(rounds, triangles split, quads priced out) from the tool's log: rounds are the
    distinct N of its `fallback round N: ...` lines, the triangles split the last
    `K triangle(s) split into three quads` count (a round's splits include the earlier
    rounds'), the quads priced out the sum of the `M quad(s) priced out of the matching`
    counts (each round's new ones)."""
    rounds, split, removed = set(), 0, 0
    for line in log.splitlines():
        m = FALLBACK_LINE.match(line)
        if not m:
            continue
        rounds.add(int(m.group(1)))
        s = SPLIT_COUNT.search(line)
        split = int(s.group(1)) if s else split
        r = PRICED_OUT.search(line)
        removed += int(r.group(1)) if r else 0
    return len(rounds), split, removed


def goal_failures(row):
    """The goals a row fails (see the module doc), as short words."""
    status = row.get("status")
    if status != "pass":
        return [status or "?"]
    fails = []
    tris = row.get("triangles") or 0
    qpt = row.get("quads_per_triangle")
    if tris >= MIN_TRIANGLES and qpt is not None and qpt > MAX_QUADS_PER_TRIANGLE:
        fails.append("quads/tri")
    bound = row.get("bound")
    goal = ETA_GOAL if bound is None else min(ETA_GOAL, bound)
    if row.get("eta_w") is not None and row["eta_w"] < goal - ETA_TOLERANCE:
        fails.append("η_w")
    if row.get("sj_min") is not None and row["sj_min"] <= 0:
        fails.append("sj")
    return fails


def one(name, cls, level, size, workdir, tool, repeat, mesh=gmsh_mesh):
    """One row: `mesh(name, size, out, extra)` meshes the model (`gmsh_mesh`'s contract)."""
    base = os.path.join(workdir, f"{name.replace('/', '_')}-{level}")
    tri, out, gq = base + ".msh", base + ".quads.msh", base + ".gmsh-quads.msh"
    tag_map = base + ".tag-map.json"
    row = {"model": name, "class": cls, "size": level, "size_value": size}
    plain = []
    for _ in range(repeat):
        ok, secs = mesh(name, size, tri)
        if not ok:
            row["status"] = "mesh-fail"
            return row
        plain.append(secs)
    qin = quality(tool, tri)
    row["triangles"] = qin["triangles"] if qin else None
    row["input_quads"] = qin["quads"] if qin else 0
    b = subprocess.run([sys.executable, os.path.abspath(__file__), "--wall-bound", tri],
                       capture_output=True, timeout=corpus.TIMEOUT)
    try:
        bound = json.loads(b.stdout)
        row["bound"], row["bound_surface"] = bound["bound"], bound["surface"]
    except ValueError:
        row["bound"] = None
    walls, cpus, code, log = [], [], None, ""
    for _ in range(repeat):
        if os.path.exists(out):
            os.remove(out)
        # -v: the log holds the fallback's lines; the tag map lets the checker compare the
        # output (numbered 1..N) with the input
        code, log, wall, cpu = run_timed([tool, tri, "-o", out, "-v", "--tag-map", tag_map])
        walls.append(wall)
        cpus.append(cpu)
    row["seconds"], row["cpu_seconds"] = median(walls), median(cpus)
    row["rounds"], row["split"], row["pairs_removed"] = fallback_of(log)
    if code == 1:
        row["status"] = "refused"
        row["message"] = log.strip().splitlines()[-1][:300] if log.strip() else ""
    elif code != 0:
        row["status"] = "crash"
    else:
        c = subprocess.run([sys.executable, corpus.CHECKER, tri, out, "--tag-map=" + tag_map],
                           capture_output=True, timeout=corpus.TIMEOUT)
        row["status"] = "pass" if c.returncode == 0 else "invalid"
        q = quality(tool, out)
        if q and row["triangles"]:
            row.update(quads=q["quads"], eta_w=q["eta_worst"], eta_mean=q["eta_mean"], sj_min=q["sj_min"])
            row["quads_per_triangle"] = (q["quads"] - row["input_quads"]) / row["triangles"]
    recombined = []
    for _ in range(repeat):
        ok, gsecs = mesh(name, size, gq, extra=GMSH_RECOMBINE)
        if not ok:
            row["gmsh_fail"] = True
            break
        recombined.append(gsecs)
    if not row.get("gmsh_fail"):
        g = quality(tool, gq)
        if g:
            row.update(gmsh_tris=g["triangles"], gmsh_quads=g["quads"], gmsh_eta_w=g["eta_worst"],
                       gmsh_eta_mean=g["eta_mean"])
        for key, k in (("gmsh_seconds", 0), ("gmsh_cpu_seconds", 1)):
            with_r = median([s[k] for s in recombined if s is not None])
            without = median([s[k] for s in plain if s is not None])
            if with_r is not None and without is not None:
                row[key] = max(0.0, with_r - without)
    row["fails"] = goal_failures(row)
    return row


def fmt(x, digits=3):
    if x is None:
        return "–"
    if isinstance(x, float):
        return f"{x:.{digits}f}"
    return str(x)


def summary(rows):
    """Summary sentences: fallback, worst eta_w, goals, slowest model."""
    # the runs that wrote a mesh (a refused run's rounds are in its row, not in the sums)
    written = [r for r in rows if r.get("status") in ("pass", "invalid")]
    hit = [r for r in written if (r.get("rounds") or 0) > 0]
    split = sum(r.get("split") or 0 for r in written)
    tris = sum(r.get("triangles") or 0 for r in hit)
    worst = [r for r in rows if r.get("eta_w") is not None]
    worst = min(worst, key=lambda r: r["eta_w"]) if worst else None
    big = [r for r in rows if (r.get("triangles") or 0) >= MIN_TRIANGLES and r.get("quads_per_triangle") is not None]
    over = [r for r in big if r["quads_per_triangle"] > MAX_QUADS_PER_TRIANGLE]
    low = [r for r in rows if "η_w" in r.get("fails", [])]
    low_big = [r for r in low if (r.get("triangles") or 0) >= MIN_TRIANGLES]
    folded = [r for r in rows if "sj" in r.get("fails", [])]
    refused = [r for r in rows if r.get("status") in ("refused", "crash")]
    invalid = [r for r in rows if r.get("status") == "invalid"]
    timed = [r for r in rows if r.get("seconds") is not None]
    slow = max(timed, key=lambda r: r["seconds"]) if timed else None
    text = [
        f"{len(rows)} runs; the fallback ran on {len(hit)} of them and split {split} triangles "
        f"(of the {tris} triangles of those models) into three quads each.",
        f"Goals: {len(over)} of the {len(big)} runs with ≥ {MIN_TRIANGLES} triangles end above "
        f"{MAX_QUADS_PER_TRIANGLE} new quads per input triangle"
        + (f" (up to {max(r['quads_per_triangle'] for r in over):.2f})" if over else "")
        + f"; {len(low)} runs end below min({ETA_GOAL}, wall-corner bound) "
        f"({len(low_big)} with ≥ {MIN_TRIANGLES} triangles); "
        f"{len(folded)} runs have a quad with sj_min ≤ 0; "
        f"{len(refused)} refused or crashed; {len(invalid)} invalid outputs.",
    ]
    if worst:
        text.append(f"Worst η_w: {worst['eta_w']:.3f} on {worst['model']} ({worst['size']}), "
                    f"wall-corner bound {fmt(worst.get('bound'))}.")
    if slow:
        text.append(f"Slowest run: {slow['model']} ({slow['size']}), {slow['seconds']:.2f} s wall, "
                    f"{fmt(slow.get('cpu_seconds'), 2)} s CPU, against Gmsh's recombination "
                    f"{fmt(slow.get('gmsh_seconds'), 2)} s wall, {fmt(slow.get('gmsh_cpu_seconds'), 2)} s CPU.")
    return " ".join(text)


def table(rows, jobs, repeat, load, date, heading=None):
    """The Markdown section; `heading` = (begin marker, end marker, title, regenerate
    sentence, input sentence), the corpus's by default."""
    cmd = "scripts/footprint.py" + (f" --jobs {jobs}" if jobs != 1 else "") + (f" --repeat {repeat}" if repeat != 1 else "")
    begin, end, title, regenerate, source = heading or (
        BEGIN, END, "Fallback footprint on the robustness corpus",
        f"Regenerate: `{cmd}` (needs `cargo build --release`; `--sizes coarse` for the coarse half).",
        "Input: `gmsh -2` in MSH 4.1.")
    timing = "single run" if repeat == 1 else f"median of {repeat} runs"
    lines = [
        begin,
        "",
        f"## {title}",
        "",
        regenerate,
        "",
        f"Generated on {date}, {len(rows)} runs, {jobs} job(s) at once, "
        f"times are a {timing} (load average {load:.1f} at the start). {source} "
        "tris: input triangles; q/t: new quads per input triangle (0.5 when every triangle pairs); "
        "split: triangles the fallback split into three quads; rm: quads the fallback priced out of "
        "the matching (their triangles paired otherwise); rnd: fallback rounds; bound: the "
        "input's wall-corner bound (smallest sum of a surface's triangle angles at a boundary node, "
        "/ 90°, capped at 1); η_w, η̄: worst and mean quad quality (eq. 3, `blossomquad quality`); "
        "sj_min: the smallest scaled Jacobian of a quad corner about the quad's own normal; "
        "time, CPU: wall and CPU (user + system, all threads) seconds of the whole "
        "`blossomquad IN -o OUT` run, read and write included. Gmsh: the same model recombined from "
        "the CAD (`Mesh.RecombineAll = 1`, blossom): tris left, η_w, η̄, and the wall and CPU "
        "seconds of its 2D meshing with recombination minus without, by Gmsh's own clock (Gmsh "
        "runs one thread; on a loaded machine the CPU columns are the steadier). goals: ✗ when refused or invalid, when q/t > 0.6 with "
        "≥ 500 triangles, when η_w < min(0.2, bound) − 0.001, or when sj_min ≤ 0.",
        "",
        "| model | size | tris | status | q/t | split | rm | rnd | bound | η_w | η̄ | sj_min | time s | CPU s "
        "| Gmsh tris | Gmsh η_w | Gmsh η̄ | Gmsh s | Gmsh CPU s | goals |",
        "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        fails = r.get("fails", [])
        lines.append(
            f"| {r['model']} | {r['size']} | {fmt(r.get('triangles'))} | {r.get('status')} | "
            f"{fmt(r.get('quads_per_triangle'), 2)} | {fmt(r.get('split'))} | {fmt(r.get('pairs_removed', 0))} | "
            f"{fmt(r.get('rounds'))} | "
            f"{fmt(r.get('bound'), 2)} | {fmt(r.get('eta_w'))} | {fmt(r.get('eta_mean'))} | {fmt(r.get('sj_min'))} | "
            f"{fmt(r.get('seconds'), 2)} | {fmt(r.get('cpu_seconds'), 2)} | {fmt(r.get('gmsh_tris'))} | "
            f"{fmt(r.get('gmsh_eta_w'))} | {fmt(r.get('gmsh_eta_mean'))} | {fmt(r.get('gmsh_seconds'), 3)} | "
            f"{fmt(r.get('gmsh_cpu_seconds'), 3)} | "
            f"{('✗ ' + ', '.join(fails)) if fails else 'ok'} |")
    lines += ["", summary(rows), "", end]
    return "\n".join(lines) + "\n"


def report_row(r, out_json=None):
    """Prints one row's progress line, and writes it to the open --json file if any."""
    print(f"{r['model']:<26} {r['size']:<6} {r.get('status'):<9} tris {fmt(r.get('triangles'))} "
          f"q/t {fmt(r.get('quads_per_triangle'), 2)} split {fmt(r.get('split'))} "
          f"rounds {fmt(r.get('rounds'))} bound {fmt(r.get('bound'), 2)} eta_w {fmt(r.get('eta_w'))} "
          f"t {fmt(r.get('seconds'), 2)}/{fmt(r.get('cpu_seconds'), 2)} "
          f"gmsh {fmt(r.get('gmsh_seconds'), 3)}/{fmt(r.get('gmsh_cpu_seconds'), 3)} "
          f"{' '.join(r.get('fails', []))}", flush=True)
    if out_json:
        out_json.write(json.dumps(r) + "\n")
        out_json.flush()


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="coarse,fine")
    ap.add_argument("--models", default="")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--dir", default=os.path.join(corpus.REPO, "target", "footprint"))
    ap.add_argument("--out", default=os.path.join(corpus.REPO, "BENCHMARKS.md"))
    ap.add_argument("--no-write", action="store_true")
    ap.add_argument("--json", default="")
    ap.add_argument("--tool", default=os.environ.get("BLOSSOMQUAD", os.path.join(corpus.REPO, "target", "release", "blossomquad")))
    ap.add_argument("--from-json", default="")
    ap.add_argument("--wall-bound", default="", help=argparse.SUPPRESS)
    a = ap.parse_args(argv[1:])
    if a.from_json:
        with open(a.from_json) as f:
            header = json.loads(f.readline())
            rows = [json.loads(line) for line in f if line.strip()]
        section = table(rows, header["jobs"], header["repeat"], header["load"], header["date"])
        if a.no_write:
            print(section)
        else:
            corpus.write_section(a.out, section, BEGIN, END)
        print(summary(rows))
        return 0
    if a.wall_bound:
        bound, surface = wall_bound(a.wall_bound)
        print(json.dumps({"bound": bound, "surface": surface}))
        return 0
    if a.jobs < 1 or a.repeat < 1:
        ap.error("--jobs and --repeat must be at least 1")
    if not os.access(a.tool, os.X_OK):
        ap.error(f"{a.tool} is not an executable (run `cargo build --release` or pass --tool)")
    os.makedirs(a.dir, exist_ok=True)
    models = corpus.read_models()
    if a.models:
        wanted = set(a.models.split(","))
        unknown = wanted - {m[0] for m in models}
        if unknown:
            ap.error(f"unknown models: {', '.join(sorted(unknown))}")
        models = [m for m in models if m[0] in wanted]
    jobs = [(name, cls, level, sizes[level]) for level in a.sizes.split(",") for name, cls, sizes in models]
    load = os.getloadavg()[0]
    rows = []
    out_json = open(a.json, "w") if a.json else None
    date = datetime.date.today().isoformat()
    if out_json:
        out_json.write(json.dumps({"jobs": a.jobs, "repeat": a.repeat, "load": load, "date": date}) + "\n")
    with concurrent.futures.ThreadPoolExecutor(max_workers=a.jobs) as pool:
        futures = [pool.submit(one, n, c, lv, s, a.dir, a.tool, a.repeat) for n, c, lv, s in jobs]
        for f in futures:
            r = f.result()
            rows.append(r)
            report_row(r, out_json)
    if out_json:
        out_json.close()
    section = table(rows, a.jobs, a.repeat, load, date)
    if a.no_write:
        print(section)
    else:
        corpus.write_section(a.out, section, BEGIN, END)
    print(summary(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
