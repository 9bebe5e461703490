"""Shared command line of the corpus's Python models (see corpus/README.md).

A model script is run as

    python3 corpus/NAME.py SIZE OUTPUT.msh [Option.Name=VALUE ...]

SIZE is the model's size parameter (the same meaning as `size` in the .geo models),
OUTPUT the mesh file to write, and each Option.Name=VALUE a Gmsh option set before
meshing (e.g. Mesh.MshFileVersion=2.2, Mesh.SaveAll=0, Mesh.RecombineAll=1).
The model builds its geometry with the `gmsh` Python API, meshes surfaces only
(`generate(2)`) and writes OUTPUT.
"""

import os
import sys
import tempfile

import gmsh


def start(name):
    """Parses the command line, initializes Gmsh; returns (size, output, tmpdir)."""
    if len(sys.argv) < 3:
        print(f"usage: {sys.argv[0]} SIZE OUTPUT.msh [Option.Name=VALUE ...]", file=sys.stderr)
        sys.exit(2)
    try:
        size = float(sys.argv[1])
    except ValueError:
        print(f"{sys.argv[0]}: SIZE must be a number, got {sys.argv[1]!r}", file=sys.stderr)
        sys.exit(2)
    output = sys.argv[2]
    options = []
    for arg in sys.argv[3:]:
        if "=" not in arg:
            print(f"{sys.argv[0]}: expected Option.Name=VALUE, got {arg!r}", file=sys.stderr)
            sys.exit(2)
        options.append(arg.split("=", 1))
    gmsh.initialize(["corpus"], readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 1 if __import__("os").environ.get("CORPUS_VERBOSE") else 0)
    gmsh.model.add(name)
    start.options = options
    return size, output, tempfile.mkdtemp(prefix="corpus-")


def set_options():
    """Applies the command line's Gmsh options (after the model's own)."""
    for name, value in start.options:
        try:
            gmsh.option.setNumber(name, float(value))
        except ValueError:
            gmsh.option.setString(name, value)


def finish(output, tmpdir=None, mesh=True):
    """Meshes the surfaces (unless mesh=False: already meshed), writes OUTPUT, exits."""
    set_options()
    if mesh:
        gmsh.model.mesh.generate(2)
    gmsh.write(output)
    gmsh.finalize()
    if tmpdir is not None:
        for f in os.listdir(tmpdir):
            os.remove(os.path.join(tmpdir, f))
        os.rmdir(tmpdir)
