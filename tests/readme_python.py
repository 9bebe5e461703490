#!/usr/bin/env python3
"""Runs the Python examples of README.md and python/README.md verbatim in a fresh venv.

    python3 tests/readme_python.py [--venv DIR]

The code blocks are read from the two READMEs (every ```python block), so the examples
cannot drift from what is tested. For each block:

- the extras it needs are the ones its imports name (`gmsh`, `meshio`), and the README text
  before the block (since the previous code block) must name them in a
  `pip install "./python[...]"` command, so the text says what each example needs;
- it runs in a venv made from scratch (DIR, default target/readme-venv, removed first) with
  the package installed as the README says, `pip install "./python[EXTRAS]"` (maturin
  builds it; CARGO_TARGET_DIR=target/python as scripts/test.sh uses), extras added
  before the first example that needs them;
- it runs with its working directory a temporary copy of the repository's `geo/`
  (the examples name files as seen from the repository's root), must exit 0, and every
  file it writes must be a mesh without triangles: `.msh` files are measured by the
  installed `blossomquad quality --json` (no triangle left, quads present), `.vtu` files
  read back with meshio (quads only).

Exits 1 with the failing example and its output on the first failure.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
READMES = ["README.md", os.path.join("python", "README.md")]
EXTRAS = ("gmsh", "meshio")


def fail(msg: str) -> None:
    print(f"readme_python: FAILED: {msg}", file=sys.stderr)
    sys.exit(1)


def examples(readme: str):
    """(line, code, text before it) of every ```python block of `readme`."""
    with open(os.path.join(ROOT, readme), encoding="utf-8") as f:
        text = f.read()
    blocks = []
    last_end = 0
    for m in re.finditer(r"^```(\w*)\n(.*?)^```$", text, re.M | re.S):
        if m.group(1) == "python":
            line = text.count("\n", 0, m.start()) + 1
            blocks.append((f"{readme}:{line}", m.group(2), text[last_end : m.start()]))
        last_end = m.end()
    return blocks


def needed_extras(code: str) -> set:
    imported = set()
    for m in re.finditer(r"^\s*(?:import|from)\s+([\w., ]+)", code, re.M):
        for name in m.group(1).replace(" import ", ",").split(","):
            imported.add(name.strip().split(".")[0].split(" ")[0])
    return {e for e in EXTRAS if e in imported}


def named_extras(before: str) -> set:
    named = set()
    for m in re.finditer(r'pip install "\./python\[([\w,]+)\]"', before):
        named.update(m.group(1).split(","))
    return named


def run(cmd, **kw):
    print("readme_python: $", " ".join(cmd), file=sys.stderr)
    return subprocess.run(cmd, **kw)


def check_outputs(workdir: str, before: set, venv_bin: str, where: str) -> int:
    written = sorted(set(os.listdir(workdir)) - before)
    if not written:
        fail(f"{where}: the example wrote no file")
    for name in written:
        path = os.path.join(workdir, name)
        if name.endswith(".msh"):
            q = subprocess.run(
                [os.path.join(venv_bin, "blossomquad"), "quality", path, "--json"],
                capture_output=True,
                text=True,
            )
            if q.returncode != 0:
                fail(f"{where}: blossomquad quality {name}: {q.stderr}")
            total = json.loads(q.stdout)["total"]
            if total["triangles"] != 0 or total["quads"] == 0:
                fail(f"{where}: {name} has {total['triangles']} triangles, {total['quads']} quads")
        elif name.endswith(".vtu"):
            code = (
                "import meshio, sys\n"
                "m = meshio.read(sys.argv[1])\n"
                "kinds = {c.type for c in m.cells}\n"
                "assert kinds == {'quad'}, kinds\n"
                "assert sum(len(c.data) for c in m.cells) > 0\n"
            )
            r = subprocess.run([os.path.join(venv_bin, "python"), "-c", code, path])
            if r.returncode != 0:
                fail(f"{where}: {name} is not a quad mesh")
        else:
            fail(f"{where}: unexpected file {name}")
    return len(written)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--venv", default=os.path.join(ROOT, "target", "readme-venv"))
    args = ap.parse_args()
    # the examples run in a temporary directory: the venv is named from the repository
    args.venv = os.path.abspath(args.venv)

    blocks = [b for r in READMES for b in examples(r)]
    # the solver examples need DOLFINx (Python >= 3.12, its own venv): their calls are the
    # ones python/tests/test_dolfinx.py and test_skfem.py run (through python/tests/poisson.py)
    solver = [b for b in blocks if re.search(r"^\s*(?:from|import)\s+(?:dolfinx|mpi4py)\b", b[1], re.M)]
    for where, _, _ in solver:
        print(f"readme_python: {where} needs DOLFINx: run by python/tests/test_dolfinx.py")
    blocks = [b for b in blocks if b not in solver]
    if len(blocks) < 3:
        fail(f"only {len(blocks)} Python examples found in {READMES}")
    for where, code, before in blocks:
        need = needed_extras(code)
        missing = need - named_extras(before)
        if missing:
            fail(
                f"{where}: the example imports {sorted(need)} but the text before it does "
                f'not say pip install "./python[{",".join(sorted(missing))}]"'
            )

    if os.path.exists(args.venv):
        shutil.rmtree(args.venv)
    run([sys.executable, "-m", "venv", args.venv], check=True)
    venv_bin = os.path.join(args.venv, "bin")
    py = os.path.join(venv_bin, "python")
    env = dict(os.environ, CARGO_TARGET_DIR=os.path.join(ROOT, "target", "python"))
    env.pop("PYTHONPATH", None)
    installed: set = set()
    pip = [py, "-m", "pip", "install", "-q", "--disable-pip-version-check"]

    with tempfile.TemporaryDirectory(prefix="readme-python-") as tmp:
        for i, (where, code, _) in enumerate(blocks):
            need = needed_extras(code)
            if i == 0 or not need <= installed:
                extras = ",".join(sorted(need - installed))
                # as the README says it, from the repository's root
                spec = f"./python[{extras}]" if extras else "./python"
                run(pip + [spec], check=True, env=env, cwd=ROOT)
                installed |= need
            workdir = os.path.join(tmp, f"example-{i}")
            shutil.copytree(os.path.join(ROOT, "geo"), os.path.join(workdir, "geo"))
            script = os.path.join(tmp, f"example-{i}.py")
            with open(script, "w", encoding="utf-8") as f:
                f.write(code)
            before = set(os.listdir(workdir))
            r = run([py, script], cwd=workdir, capture_output=True, text=True, env=env)
            if r.returncode != 0:
                fail(f"{where} exited {r.returncode}:\n{code}\n{r.stdout}{r.stderr}")
            n = check_outputs(workdir, before, venv_bin, where)
            print(f"readme_python: ok {where} (extras {sorted(need)}, {n} file(s) checked)")
    print(f"readme_python: all {len(blocks)} examples ran in a fresh venv")


if __name__ == "__main__":
    main()
