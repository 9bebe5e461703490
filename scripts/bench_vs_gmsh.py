#!/usr/bin/env python3
"""blossomquad against Gmsh's own recombination on the geo/ fixtures.

Run through scripts/bench_vs_gmsh.sh (which builds the release binary). For each
fixture and each target triangle count, in one run:

  gmsh -2                 the triangle mesh (timed), written as MSH 4.1 binary;
  Gmsh blossom (CAD)      `gmsh -2 -setnumber Mesh.RecombineAll 1
                          -setnumber Mesh.RecombinationAlgorithm 1` on the same
                          .geo; recombination time = this run minus the plain
                          triangulation run;
  Gmsh full-quad (CAD)    the same with Mesh.RecombinationAlgorithm 3;
  Gmsh API on MSH         the triangle file loaded through the Python API, then
                          gmsh.model.mesh.recombine() (only that call is timed);
  blossomquad             `blossomquad tri.msh -o out.msh`, the whole run (read,
                          recombine, optimise, write).

Every output (and the input triangulation) is measured by OUR
`blossomquad quality --json`. Peak memory is the process's maximum resident set
size (os.wait4). Writes a Markdown report (default BENCHMARKS.md).

Environment: BENCH_TARGETS (default "1e4 1e5"; add 1e6 for the large row),
BENCH_FIXTURES (default all four), BENCH_DIR (work dir, default bench-out),
BENCH_OUT (report, default BENCHMARKS.md: its generated head is replaced, the sections
after the head's "Reproduce:" line are kept), BENCH_TIMEOUT (seconds per process,
default 1800), BLOSSOMQUAD (binary, default target/release/blossomquad).
"""

import datetime
import json
import math
import os
import platform
import re
import shlex
import signal
import subprocess
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
GEO = os.path.join(REPO, "geo")

# Triangles at size = 1 (measured with Gmsh 4.15.2); the count grows like 1 / size^2.
BASE_TRIANGLES = {
    "rectangle": 1792,
    "square_hole": 72324,
    "cad_solid": 6068,
    "even_curves": 2542,
}
# Exact size fields, for tau, as functions of the fixture's `size` parameter.
SIZE_FIELDS = {
    "rectangle": lambda s: f"{s!r}*(0.1+0.08*sin(3*x)*cos(6*y))",
}
QUALITY_KEYS = ["quads", "triangles", "eta_min", "eta_mean", "tau", "d4_percent", "d_min", "d_max"]

API_RECOMBINE = r"""
import json, resource, sys, time
import gmsh
src, dst = sys.argv[1], sys.argv[2]
gmsh.initialize(["bench"], readConfigFiles=False)
gmsh.option.setNumber("General.Terminal", 0)
t0 = time.perf_counter()
gmsh.open(src)
t1 = time.perf_counter()
gmsh.model.mesh.recombine()
t2 = time.perf_counter()
gmsh.option.setNumber("Mesh.Binary", 1)
gmsh.write(dst)
print(json.dumps({"load": t1 - t0, "recombine": t2 - t1}))
"""


def run(cmd, timeout, stdout_path=None):
    """Runs cmd; returns dict(code, wall, maxrss_mb, out, err, timeout)."""
    out_f = open(stdout_path, "wb") if stdout_path else subprocess.PIPE
    t0 = time.perf_counter()
    try:
        proc = subprocess.Popen(cmd, stdout=out_f, stderr=subprocess.PIPE, start_new_session=True)
    except OSError as exc:
        if stdout_path:
            out_f.close()
        return {"code": 127, "wall": 0.0, "maxrss_mb": 0.0, "out": "", "err": str(exc), "timeout": False}
    timed_out = False
    deadline = t0 + timeout
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid != 0:
            break
        if time.perf_counter() > deadline:
            os.killpg(proc.pid, signal.SIGKILL)
            pid, status, usage = os.wait4(proc.pid, 0)
            timed_out = True
            break
        time.sleep(0.01)
    wall = time.perf_counter() - t0
    out = b"" if stdout_path else proc.stdout.read()
    err = proc.stderr.read()
    if stdout_path:
        out_f.close()
    code = os.waitstatus_to_exitcode(status)
    return {
        "code": code,
        "wall": wall,
        "maxrss_mb": usage.ru_maxrss / 1024.0,
        "out": out.decode(errors="replace"),
        "err": err.decode(errors="replace"),
        "timeout": timed_out,
    }


def gmsh_ok(res):
    return res["code"] == 0 and not res["timeout"] and "Error" not in res["out"] + res["err"]


def quality(binary, path, size_expr, reference, timeout):
    """Our `quality --json` of PATH; tau from the exact size field when known, else
    estimated from the triangle mesh REFERENCE (the same for every output)."""
    cmd = [binary, "quality", path, "--json"]
    cmd += ["--size", size_expr] if size_expr else ["--reference", reference]
    res = run(cmd, timeout)
    if res["code"] != 0:
        if size_expr:  # fall back to the estimated size field
            return quality(binary, path, None, reference, timeout)
        return None
    try:
        total = json.loads(res["out"])["total"]
    except (ValueError, KeyError, TypeError):
        return None
    return {"quads": total.get("quads"), "triangles": total.get("triangles"),
            "eta_min": total.get("eta_worst"), "eta_mean": total.get("eta_mean"),
            "tau": total.get("tau_percent"), "d4_percent": total.get("d4_percent"),
            "d_min": total.get("d_min"), "d_max": total.get("d_max")}


def fmt(value, digits=3):
    if value is None:
        return "-"
    if isinstance(value, float):
        if value != value:
            return "-"
        if abs(value) >= 100 or value == int(value):
            return f"{value:.0f}" if abs(value - round(value)) < 1e-9 else f"{value:.1f}"
        return f"{value:.{digits}f}"
    return str(value)


def case(binary, fixture, target, work, timeout):
    size = math.sqrt(BASE_TRIANGLES[fixture] / target)
    geo = os.path.join(GEO, f"{fixture}.geo")
    stem = os.path.join(work, f"{fixture}-{target:.0e}")
    setsize = ["-setnumber", "size", repr(size)]
    rows = []
    size_expr = SIZE_FIELDS[fixture](size) if fixture in SIZE_FIELDS else None

    tri = stem + "-tri.msh"
    t = run(["gmsh", "-2", geo, *setsize, "-format", "msh41", "-bin", "-o", tri], timeout)
    if not gmsh_ok(t):
        return [{"method": "gmsh -2 (triangles)", "note": "failed: " + (t["err"] or t["out"])[-200:]}], size
    tri_time = t["wall"]
    rows.append({"method": "gmsh -2 (triangles)", "time": tri_time, "mem": t["maxrss_mb"], "file": tri})

    for alg, label in [(1, "Gmsh blossom from CAD"), (3, "Gmsh full-quad from CAD")]:
        out = f"{stem}-gmsh-alg{alg}.msh"
        r = run(["gmsh", "-2", geo, *setsize, "-setnumber", "Mesh.RecombineAll", "1",
                 "-setnumber", "Mesh.RecombinationAlgorithm", str(alg),
                 "-format", "msh41", "-bin", "-o", out], timeout)
        if r["code"] != 0 or r["timeout"] or not os.path.exists(out):
            rows.append({"method": label, "note": "timeout" if r["timeout"] else "failed"})
            continue
        log = r["out"] + r["err"]
        matching = sum(float(line.split("(Wall ")[1].split("s")[0])
                       for line in log.splitlines() if "Blossom recombination completed (Wall " in line)
        errors = sorted({line.split(":", 1)[1].strip() for line in log.splitlines()
                         if line.startswith("Error") and not re.search(
                             r"^Error\s*:\s*(\d+ (warnings|errors)|-+$|Check the full log|Mesh generation error)",
                             line)})
        if alg == 1:
            row = {"method": label, "time": max(r["wall"] - tri_time, 0.0),
                   "note": f"total {r['wall']:.2f} s minus triangulation; Blossom matching {matching:.2f} s"}
        else:
            row = {"method": label, "time": r["wall"],
                   "note": "whole run (full-quad re-triangulates at double size)"}
        if errors:
            row["note"] += "; Gmsh errors: " + " / ".join(errors)
        row.update({"mem": r["maxrss_mb"], "file": out})
        rows.append(row)

    out = stem + "-gmsh-api.msh"
    r = run([sys.executable, "-c", API_RECOMBINE, tri, out], timeout)
    if r["code"] == 0 and not r["timeout"]:
        info = json.loads(r["out"].strip().splitlines()[-1])
        rows.append({"method": "Gmsh API recombine() on MSH", "time": info["recombine"], "mem": r["maxrss_mb"],
                     "file": out, "note": f"load {info['load']:.2f} s not counted"})
    else:
        rows.append({"method": "Gmsh API recombine() on MSH", "note": "timeout" if r["timeout"] else "failed"})

    for label, extra, note in [
        ("blossomquad --no-optimize", ["--no-optimize"], "matching only"),
        ("blossomquad", [], "whole run: read, recombine, optimise, write"),
    ]:
        out = f"{stem}-{label.replace(' ', '').replace('--', '-')}.msh"
        r = run([binary, tri, "-o", out, "--quiet", *extra], timeout)
        if r["code"] == 0 and not r["timeout"]:
            rows.append({"method": label, "time": r["wall"], "mem": r["maxrss_mb"], "file": out, "note": note})
        else:
            rows.append({"method": label, "note": "timeout" if r["timeout"] else
                         "failed: " + r["err"].strip()[-200:]})

    for row in rows:
        if "file" in row:
            row["quality"] = quality(binary, row["file"], size_expr, tri, timeout)
    reference = next((r.get("time") for r in rows if r["method"] == "Gmsh blossom from CAD"), None)
    for row in rows:
        if reference and row.get("time") and row["method"] != "gmsh -2 (triangles)":
            row["ratio"] = reference / row["time"]
    return rows, size


def machine():
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = "?"
    try:
        with open("/proc/meminfo") as f:
            kb = int(f.readline().split()[1])
            mem = f"{kb / 1024 / 1024:.0f} GB"
    except (OSError, ValueError, IndexError):
        pass

    def version(cmd):
        try:
            return subprocess.run(cmd, capture_output=True, text=True, timeout=60).stdout.strip() or \
                subprocess.run(cmd, capture_output=True, text=True, timeout=60).stderr.strip()
        except (OSError, subprocess.SubprocessError):
            return "?"

    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "memory": mem,
        "os": platform.platform(),
        "gmsh": version(["gmsh", "--version"]),
        "rustc": version(["rustc", "--version"]),
        "commit": version(["git", "-C", REPO, "rev-parse", "--short", "HEAD"]),
    }


def main():
    binary = os.environ.get("BLOSSOMQUAD", os.path.join(REPO, "target", "release", "blossomquad"))
    targets = [int(float(t)) for t in os.environ.get("BENCH_TARGETS", "1e4 1e5").split()]
    fixtures = os.environ.get("BENCH_FIXTURES", " ".join(BASE_TRIANGLES)).split()
    work = os.environ.get("BENCH_DIR", os.path.join(REPO, "bench-out"))
    report = os.environ.get("BENCH_OUT", os.path.join(REPO, "BENCHMARKS.md"))
    timeout = float(os.environ.get("BENCH_TIMEOUT", "1800"))
    os.makedirs(work, exist_ok=True)
    started = datetime.datetime.now(datetime.timezone.utc)

    sections = []
    for fixture in fixtures:
        for target in targets:
            print(f"bench: {fixture} ~{target:.0e} triangles", file=sys.stderr, flush=True)
            rows, size = case(binary, fixture, target, work, timeout)
            sections.append((fixture, target, size, rows))
            for row in rows:
                q = row.get("quality") or {}
                print(f"  {row['method']:<30} {fmt(row.get('time'))} s  {fmt(row.get('mem'))} MB  "
                      f"quads {fmt(q.get('quads'))} tris {fmt(q.get('triangles'))} "
                      f"eta_w {fmt(q.get('eta_min'))} eta {fmt(q.get('eta_mean'))} {row.get('note', '')}",
                      file=sys.stderr, flush=True)

    m = machine()
    lines = [
        "# Benchmarks: blossomquad vs Gmsh's recombination",
        "",
        f"Generated by `scripts/bench_vs_gmsh.sh` on {started:%Y-%m-%d %H:%M} UTC "
        f"(BENCH_TARGETS=\"{' '.join(f'{t:.0e}' for t in targets)}\").",
        "",
        f"Machine: {m['cpu']}, {m['cores']} cores, {m['memory']}; {m['os']}; "
        f"Gmsh {m['gmsh']} (PyPI wheel); {m['rustc']}; blossomquad commit {m['commit']}.",
        "",
        "How each row is obtained (all on the same .geo at the same `size`):",
        "",
        "- **gmsh -2 (triangles)**: `gmsh -2 geo/F.geo -setnumber size S -format msh41 -bin -o tri.msh`; "
        "this file is the input of the last two rows.",
        "- **Gmsh blossom from CAD**: the same command with `-setnumber Mesh.RecombineAll 1 "
        "-setnumber Mesh.RecombinationAlgorithm 1`; time = that run minus the triangulation run "
        "(recombination and Gmsh's CAD-based smoothing).",
        "- **Gmsh full-quad from CAD**: the same with `Mesh.RecombinationAlgorithm 3`; whole run "
        "(it meshes at double size, recombines and splits, so there is no triangulation to subtract).",
        "- **Gmsh API recombine() on MSH**: `gmsh.open(tri.msh); gmsh.model.mesh.recombine()`; only "
        "the `recombine()` call is timed.",
        "- **blossomquad**: `blossomquad tri.msh -o out.msh --quiet`, the whole process "
        "(read, recombine, optimise, write); **--no-optimize**: the same without smoothing and "
        "topological operations (the optimal matching as is).",
        "- Quality columns: our `blossomquad quality OUT --json` on every output "
        "(η_w = worst η, η̄ = mean η, eq. 3; τ eq. 2, with the exact size field for the rectangle "
        "(`--size`), otherwise the size field estimated from the triangle mesh (`--reference tri.msh`); "
        "d4 = % interior vertices with 4 quads). "
        "Peak memory: maximum resident set size of the process. "
        "Speed-up = Gmsh blossom-from-CAD time / row time.",
        "",
    ]
    for fixture, target, size, rows in sections:
        lines += [f"## {fixture}, ~{target:.0e} triangles (size = {size:.4g})", "",
                  "| method | time (s) | speed-up | peak MB | quads | triangles | η_w | η̄ | τ | d4 % | d_min | d_max | note |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for row in rows:
            q = row.get("quality") or {}
            lines.append("| " + " | ".join([
                row["method"], fmt(row.get("time")), fmt(row.get("ratio"), 1), fmt(row.get("mem"), 0),
                fmt(q.get("quads")), fmt(q.get("triangles")), fmt(q.get("eta_min")), fmt(q.get("eta_mean")),
                fmt(q.get("tau"), 1), fmt(q.get("d4_percent"), 1), fmt(q.get("d_min")), fmt(q.get("d_max")),
                row.get("note", "").replace("|", "/").replace("\n", " "),
            ]) + " |")
        lines.append("")
    lines += ["Reproduce: `" + " ".join(shlex.quote(a) for a in ["scripts/bench_vs_gmsh.sh"]) +
              "` (set `BENCH_TARGETS=\"1e4 1e5 1e6\"` for the 1e6 rows).", ""]
    # the generated tables replace only the report's own head: what follows its
    # "Reproduce:" line (hand-written sections of BENCHMARKS.md) is kept
    kept = ""
    if os.path.isfile(report):
        with open(report) as f:
            old = f.read()
        marker = old.find("Reproduce: `scripts/bench_vs_gmsh.sh`")
        if marker >= 0:
            end = old.find("\n", marker)
            kept = old[end + 1:] if end >= 0 else ""
    with open(report, "w") as f:
        f.write("\n".join(lines) + kept)
    print(f"bench: wrote {report}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
