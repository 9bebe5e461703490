#!/usr/bin/env python3
"""Runs the robustness corpus (corpus/models.tsv) through blossomquad and the checker.

    scripts/corpus.py OUTDIR [--sizes coarse,fine] [--variants msh41,msh22-all,msh22-noall]
                             [--models NAME,NAME...] [--classes CLASS,...] [--jobs N]
                             [--tool PATH] [--json FILE] [--report FILE]
    scripts/corpus.py --from-json FILE --report FILE

For every model, size and variant it meshes the model with Gmsh (surfaces only) into
OUTDIR/<model>-<size>-<variant>.msh, runs `blossomquad IN -o OUT` (OUT is
OUTDIR/<model>-<size>-<variant>.quads.msh) and then `tests/check_mesh.py IN OUT`, and
prints one line per (model, size, variant):

    pass      the tool exited 0 and the checker accepts the output
    refused   the tool exited 1 (its message follows)
    invalid   the tool exited 0 but the checker rejects the output (its violations follow)
    crash     the tool died (signal or exit code other than 0 and 1)
    mesh-fail Gmsh could not mesh the model (a corpus defect, not a tool failure)

Variants (the model's physical groups are on surfaces only):
    msh41        MSH 4.1 as `gmsh -2` writes it by default (Mesh.SaveAll = 0)
    msh22-all    MSH 2.2 with Mesh.SaveAll = 1 (every element, curve line elements included)
    msh22-noall  MSH 2.2 with Mesh.SaveAll = 0 (only the physical surfaces' triangles:
                 no line element at all)

At most --jobs (default 2) models run at once. With --json FILE, one JSON object per
run is written to FILE (commands, exit codes, messages, timings). Exit status: 0 when
every run passed, 1 otherwise. With --report FILE, a Markdown list of the failing runs
(class of failure, the commands reproducing it, the tool's or the checker's message) is
written to FILE; --from-json FILE rebuilds that report from an earlier --json file
without running anything.
"""

import argparse
import concurrent.futures
import json
import os
import shlex
import subprocess
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CORPUS = os.path.join(REPO, "corpus")
CHECKER = os.path.join(REPO, "tests", "check_mesh.py")
VARIANTS = {
    "msh41": [("Mesh.MshFileVersion", "4.1")],
    "msh22-all": [("Mesh.MshFileVersion", "2.2"), ("Mesh.SaveAll", "1")],
    "msh22-noall": [("Mesh.MshFileVersion", "2.2"), ("Mesh.SaveAll", "0")],
}
TIMEOUT = 600


def write_section(path, section, begin, end):
    """Puts `section` (which starts with `begin` and ends with `end`) into the file at
    `path` in place of the text between those markers, or at its end when it has none."""
    text = open(path).read() if os.path.exists(path) else ""
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        _, tail = rest.split(end, 1)
        text = head + section.rstrip("\n") + tail
    else:
        text = text.rstrip("\n") + "\n\n" + section
    with open(path, "w") as f:
        f.write(text)


def read_models(path=os.path.join(CORPUS, "models.tsv")):
    """[(name, class, {"coarse": size, "fine": size})] from corpus/models.tsv."""
    models = []
    with open(path) as f:
        for line in f:
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            name, cls, coarse, fine = fields[:4]
            models.append((name, cls, {"coarse": float(coarse), "fine": float(fine)}))
    return models


def model_file(name):
    """corpus/NAME.geo or corpus/NAME.py; a name with a slash is a path in the repository
    without its extension (geo/rectangle: geo/rectangle.geo)."""
    base = os.path.join(REPO, name) if "/" in name else os.path.join(CORPUS, name)
    for ext in (".geo", ".py"):
        p = base + ext
        if os.path.isfile(p):
            return p
    raise FileNotFoundError(f"model {name}: no {base}.geo or {base}.py")


def mesh_command(name, size, options, out):
    """The command meshing model `name` at `size` with Gmsh `options` [(name, value)] into out."""
    src = model_file(name)
    if src.endswith(".geo"):
        cmd = [os.environ.get("GMSH", "gmsh"), "-2", src, "-setnumber", "size", repr(size)]
        for k, v in options:
            cmd += ["-setnumber", k, v]
        return cmd + ["-o", out]
    return [os.environ.get("PYTHON", sys.executable), src, repr(size), out] + [f"{k}={v}" for k, v in options]


def run(cmd, timeout=TIMEOUT):
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, timeout=timeout)
        code, out, err = p.returncode, p.stdout.decode("utf-8", "replace"), p.stderr.decode("utf-8", "replace")
    except subprocess.TimeoutExpired:
        code, out, err = None, "", f"timed out after {timeout} s"
    return code, out, err, time.perf_counter() - t0


def mesh(name, size, variant, out, extra=()):
    """Meshes one model; returns (ok, message, command)."""
    cmd = mesh_command(name, size, VARIANTS[variant] + list(extra), out)
    if os.path.exists(out):
        os.remove(out)
    code, so, se, _ = run(cmd)
    log = so + se
    errors = [l for l in log.splitlines() if l.startswith("Error") or "Exception" in l]
    if code != 0 or errors or not os.path.isfile(out):
        return False, (errors or log.strip().splitlines()[-3:] or [f"exit {code}"])[0], cmd
    return True, "", cmd


def first_lines(text, n=3):
    lines = [l for l in text.strip().splitlines() if l.strip()]
    return " | ".join(lines[:n])


def run_one(name, level, size, variant, outdir, tool):
    base = os.path.join(outdir, f"{name}-{level}-{variant}")
    inp, outp = base + ".msh", base + ".quads.msh"
    rec = {"model": name, "size": level, "size_value": size, "variant": variant,
           "input": inp, "output": outp}
    ok, msg, cmd = mesh(name, size, variant, inp)
    rec["mesh_cmd"] = shlex.join(cmd)
    if not ok:
        rec.update(status="mesh-fail", message=msg)
        return rec
    if os.path.exists(outp):
        os.remove(outp)
    # the tag map lets the checker compare the output (numbered 1..N) with the input
    tag_map = outp + ".tag-map.json"
    tcmd = [tool, inp, "-o", outp, "--tag-map", tag_map]
    code, so, se, secs = run(tcmd)
    rec.update(tool_cmd=shlex.join(tcmd), tool_exit=code, tool_seconds=round(secs, 3), tool_stderr=se.strip())
    if code == 1:
        rec.update(status="refused", message=first_lines(se))
        return rec
    if code != 0:
        rec.update(status="crash", message=f"exit {code}: {first_lines(se)}")
        return rec
    ccmd = [os.environ.get("PYTHON", sys.executable), CHECKER, inp, outp, "--tag-map=" + tag_map]
    code, so, se, _ = run(ccmd)
    rec["check_cmd"] = shlex.join(ccmd)
    try:
        report = json.loads(so.strip().splitlines()[-1])
    except (ValueError, IndexError):
        report = {"ok": False, "violations": [f"checker output unreadable (exit {code}): {first_lines(so + se)}"]}
    rec["check"] = report
    if code == 0 and report.get("ok"):
        rec.update(status="pass", message="")
    else:
        rec.update(status="invalid", message="; ".join(report.get("violations", [])[:6]) or first_lines(so + se))
    return rec


def failure_class(rec):
    """A short name for what went wrong in one run."""
    status = rec["status"]
    if status in ("refused", "crash", "mesh-fail"):
        if status == "refused":
            m = rec.get("message", "")
            if "is periodic" in m:
                return "refusal: periodic surface"
            if "even" in m or "odd" in m.lower():
                return "refusal: parity (odd regions)"
            return "refusal"
        return status
    report = rec.get("check", {})
    failed = [k for k, v in report.get("checks", {}).items() if not v]
    text = " ".join(report.get("violations", []))
    kinds = []
    if "quad_valid" in failed:
        if "reflex corner" in text or "flat corner" in text:
            kinds.append("flat/reflex quad (eta = 0)")
        if "inverted" in text:
            kinds.append("inverted quad")
        if "zero-length edge" in text:
            kinds.append("zero-length edge")
    if "faces_valid" in failed:
        kinds.append("degenerate face (repeated or missing node)")
    if "orientation" in failed and "inverted quad" not in kinds:
        kinds.append("inverted quad")
    if {"shared_edges", "boundary", "conformity", "curve_edges"} & set(failed):
        kinds.append("non-conforming (" + ", ".join(sorted({"shared_edges", "boundary", "conformity", "curve_edges"} & set(failed))) + ")")
    if "periodic" in failed:
        kinds.append("periodic links broken")
    rest = [k for k in failed if k not in ("quad_valid", "faces_valid", "orientation", "shared_edges", "boundary",
                                           "conformity", "curve_edges", "periodic")]
    kinds += rest
    return ", ".join(kinds) or "invalid"


def write_report(results, path):
    """Markdown report of the failing runs."""
    bad = [r for r in results if r["status"] != "pass"]
    with open(path, "w") as f:
        f.write("# Corpus failures\n\n")
        f.write("Written by scripts/corpus.py --report. Reproduce a run with the three commands under it "
                "(mesh, tool, checker), from the repository root.\n\n")
        counts = {}
        for r in results:
            counts.setdefault(r["variant"], {}).setdefault(r["status"], 0)
            counts[r["variant"]][r["status"]] += 1
        for v, c in counts.items():
            f.write(f"- {v}: " + ", ".join(f"{k} {n}" for k, n in sorted(c.items())) + "\n")
        by_model = {}
        for r in bad:
            by_model.setdefault((r["model"], r["size"]), []).append(r)
        f.write(f"\n{len(bad)} failing runs on {len(by_model)} (model, size) pairs.\n")
        f.write("\n| model | size | variant | class | detail |\n|---|---|---|---|---|\n")
        for r in bad:
            msg = r.get("message", "").replace("|", "/")
            f.write(f"| {r['model']} | {r['size']} | {r['variant']} | {failure_class(r)} | {msg[:160]} |\n")
        for (model, size), runs in by_model.items():
            f.write(f"\n## {model} ({size})\n")
            for r in runs:
                f.write(f"\n### {r['variant']}: {failure_class(r)}\n\n")
                f.write("```sh\n")
                f.write(f"{r['mesh_cmd']}\n")
                if r.get("tool_cmd"):
                    f.write(f"{r['tool_cmd']}\n")
                if r.get("check_cmd"):
                    f.write(f"{r['check_cmd']}\n")
                f.write("```\n\n")
                if r["status"] == "invalid":
                    rep = r.get("check", {})
                    f.write(f"bad quads {rep.get('bad_quads')} of {rep.get('quads_checked')}, "
                            f"worst eta {rep.get('quad_eta_min')}, failed checks: "
                            f"{', '.join(k for k, v in rep.get('checks', {}).items() if not v)}\n\n")
                    for v in rep.get("violations", [])[:8]:
                        f.write(f"- `{v[:300]}`\n")
                else:
                    f.write(f"```\n{(r.get('tool_stderr') or r.get('message', ''))[:1500]}\n```\n")


def line(rec):
    msg = rec.get("message", "")
    if len(msg) > 400:
        msg = msg[:400] + "..."
    return f"{rec['model']:<26} {rec['size']:<6} {rec['variant']:<11} {rec['status']:<9} {msg}".rstrip()


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("outdir", nargs="?")
    ap.add_argument("--sizes", default="coarse")
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--models", default="")
    ap.add_argument("--classes", default="")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--tool", default=os.environ.get("BLOSSOMQUAD", os.path.join(REPO, "target", "release", "blossomquad")))
    ap.add_argument("--json", default="")
    ap.add_argument("--report", default="")
    ap.add_argument("--from-json", default="")
    a = ap.parse_args(argv[1:])
    if a.from_json:
        with open(a.from_json) as f:
            results = [json.loads(l) for l in f if l.strip()]
        if a.report:
            write_report(results, a.report)
        return 0 if all(r["status"] == "pass" for r in results) else 1
    if not a.outdir:
        ap.error("OUTDIR is required (unless --from-json)")
    os.makedirs(a.outdir, exist_ok=True)
    models = read_models()
    if a.models:
        wanted = set(a.models.split(","))
        unknown = wanted - {m[0] for m in models}
        if unknown:
            ap.error(f"unknown models: {', '.join(sorted(unknown))}")
        models = [m for m in models if m[0] in wanted]
    if a.classes:
        models = [m for m in models if m[1] in set(a.classes.split(","))]
    variants = a.variants.split(",")
    for v in variants:
        if v not in VARIANTS:
            ap.error(f"unknown variant {v} (known: {', '.join(VARIANTS)})")
    jobs = [(name, level, sizes[level], v) for name, _, sizes in models
            for level in a.sizes.split(",") for v in variants]
    results = []
    out_json = open(a.json, "w") if a.json else None
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, min(a.jobs, 2))) as pool:
        futures = [pool.submit(run_one, n, l, s, v, a.outdir, a.tool) for n, l, s, v in jobs]
        for f in futures:
            rec = f.result()
            results.append(rec)
            print(line(rec), flush=True)
            if out_json:
                out_json.write(json.dumps(rec) + "\n")
                out_json.flush()
    if out_json:
        out_json.close()
    if a.report:
        write_report(results, a.report)
    counts = {}
    for r in results:
        counts.setdefault(r["variant"], {}).setdefault(r["status"], 0)
        counts[r["variant"]][r["status"]] += 1
    for v in variants:
        c = counts.get(v, {})
        print(f"# {v}: " + ", ".join(f"{k} {c[k]}" for k in sorted(c)))
    return 0 if all(r["status"] == "pass" for r in results) else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
