"""The Gmsh GUI entry (blossomquad.gmsh_gui): the ONELAB client driven by a real Gmsh with
no display, through the `gmsh` module (the same server code as the GUI's Run button) and
through the `gmsh` executable in batch mode (`gmsh model.geo gmsh_gui.py -run`)."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from blossomquad import gmsh_gui

gmsh = pytest.importorskip("gmsh")

PLATE = """SetFactory("OpenCASCADE");
Rectangle(1) = {0, 0, 0, 2, 1};
Disk(2) = {1, 0.5, 0, 0.25};
BooleanDifference{ Surface{1}; Delete; }{ Surface{2}; Delete; }
Physical Surface("plate") = {1};
Physical Curve("hole") = {5};
Mesh.MeshSizeMax = 0.1;
"""

BLOCK = """SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Mesh.MeshSizeMax = 0.4;
"""

COMMAND = f'"{sys.executable}" -m blossomquad.gmsh_gui'


def parameters():
    return {p["name"]: p for p in json.loads(gmsh.onelab.get())["onelab"]["parameters"]}


def run(action="compute"):
    """One run of the client as the GUI's Run button makes it (action "compute")."""
    gmsh.onelab.setString("Blossomquad/Action", [action])
    gmsh.onelab.run("Blossomquad", COMMAND)


@pytest.fixture
def model(tmp_path, monkeypatch):
    """A model open in Gmsh from a .geo in its own directory."""
    monkeypatch.chdir(tmp_path)

    def open_geo(text, name="plate.geo"):
        (tmp_path / name).write_text(text)
        gmsh.initialize(readConfigFiles=False)
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.logger.start()
        gmsh.open(str(tmp_path / name))
        return tmp_path

    yield open_geo
    if gmsh.isInitialized():
        gmsh.finalize()


def surface_types():
    return sorted({int(t) for _, s in gmsh.model.getEntities(2)
                   for t in gmsh.model.mesh.getElementTypes(2, s)})


def test_run_recombines_the_mesh_gmsh_shows_and_publishes_results(model):
    folder = model(PLATE)
    gmsh.model.mesh.generate(2)
    triangles = len(gmsh.model.mesh.getElementsByType(2)[0])
    groups = sorted(gmsh.model.getPhysicalGroups())
    gmsh.onelab.setNumber("Blossomquad/0Options/8QualityViews", [1])
    run()
    assert surface_types() == [3], gmsh.logger.get()
    quads = len(gmsh.model.mesh.getElementsByType(3)[0])
    p = parameters()
    results = {k.split("/")[-1]: v for k, v in p.items() if k.startswith("Blossomquad/1Results/")}
    assert results["1Triangles"]["values"] == [triangles]
    assert results["2Quads"]["values"] == [quads]
    assert 0.3 < results["3EtaWorst"]["values"][0] <= results["4EtaMean"]["values"][0] <= 1
    assert 0 < results["5SJMin"]["values"][0] <= 1
    assert 0 < results["6Regular"]["values"][0] <= 100
    assert all(r["readOnly"] for r in results.values())
    # physical groups once each, with their names
    assert sorted(gmsh.model.getPhysicalGroups()) == groups
    assert len(groups) == 2
    for dim, tag in groups:
        for entity in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
            assert list(gmsh.model.getPhysicalGroupsForEntity(dim, entity)) == [tag]
    assert gmsh.model.getPhysicalName(2, groups[1][1]) == "plate"
    names = [gmsh.view.option.getString(t, "Name") for t in gmsh.view.getTags()]
    assert sorted(names) == sorted(gmsh_gui.QUALITY_VIEWS)
    # a second run (options changed, the model meshed again) replaces the views
    gmsh.onelab.setNumber("Blossomquad/0Options/4Refine", [1])
    gmsh.model.mesh.clear()
    gmsh.model.mesh.generate(2)
    run()
    assert surface_types() == [3]
    assert len(gmsh.model.mesh.getElementsByType(3)[0]) > 3 * quads
    assert len(gmsh.view.getTags()) == 3
    # Gmsh writes nothing beside the model (it would save plate.msh and plate.db on Run)
    assert gmsh.option.getNumber("Solver.AutoMesh") == 0
    assert gmsh.option.getNumber("Solver.AutoSaveDatabase") == 0
    assert sorted(os.listdir(folder)) == ["plate.geo"]


def test_run_meshes_an_unmeshed_model_and_check_clamps_the_options(model):
    model(PLATE)
    gmsh.onelab.setNumber("Blossomquad/0Options/4Refine", [7])
    gmsh.onelab.setNumber("Blossomquad/0Options/3Smooth", [-2.5])
    gmsh.onelab.setNumber("Blossomquad/0Options/1Optimize", [0.7])
    run("check")
    p = parameters()
    assert p["Blossomquad/0Options/4Refine"]["values"] == [3]
    assert p["Blossomquad/0Options/3Smooth"]["values"] == [0]
    assert p["Blossomquad/0Options/1Optimize"]["values"] == [1]
    assert "Blossomquad/1Results/2Quads" not in p  # check computes nothing
    assert surface_types() == []
    gmsh.onelab.setNumber("Blossomquad/0Options/4Refine", [0])
    run()
    assert surface_types() == [3]


def test_errors_go_to_gmsh_and_volumes_follow_the_option(model):
    model(BLOCK, "block.geo")
    gmsh.model.mesh.generate(3)
    gmsh.logger.get()
    with pytest.raises(Exception, match="Blossomquad - the mesh has .* volume elements"):
        run()  # the gmsh module raises Gmsh's errors; the GUI shows them
    errors = [m for m in gmsh.logger.get() if m.startswith("Error")]
    assert len(errors) == 1 and '(tick "Drop volume elements")' in errors[0], errors
    assert 2 in surface_types()  # the model is unchanged
    gmsh.onelab.setNumber("Blossomquad/0Options/7DropVolumes", [1])
    run()
    assert surface_types() == [3]
    assert list(gmsh.model.mesh.getElementTypes(3)) == []


def test_gmsh_batch_runs_the_client_file(tmp_path):
    """`gmsh model.geo .../gmsh_gui.py -run`: Gmsh's own way of starting a .py client."""
    exe = shutil.which("gmsh")
    if sys.platform == "win32":
        pytest.skip("Gmsh opens a .py file with the shell on Windows, not an interpreter")
    if exe is None:
        pytest.skip("no gmsh executable on PATH")
    (tmp_path / "plate.geo").write_text(PLATE)
    run = subprocess.run(
        [exe, "plate.geo", gmsh_gui.__file__, "-run", "-setstring",
         "Solver.PythonInterpreter", sys.executable],
        cwd=tmp_path, capture_output=True, text=True, timeout=300)
    out = run.stdout + run.stderr
    assert run.returncode == 0, out
    assert "gmsh_gui - no mesh: meshing in 2D first" in out
    assert "gmsh_gui - 1 surface, " in out and " quads (quality eta: worst " in out, out
    assert "Error" not in out, out
    assert sorted(os.listdir(tmp_path)) == ["plate.geo"]


def test_install_adds_a_solver_and_keeps_the_others(tmp_path, monkeypatch):
    options = tmp_path / ".gmsh-options"
    options.write_text(
        'General.Terminal = 1;\nSolver.Name1 = "Elmer";\nSolver.Executable1 = "elmer";\n')
    path, slot = gmsh_gui.install(options, "/opt/bq/bin/blossomquad-gmsh")
    assert (path, slot) == (options, 2)
    text = options.read_text()
    assert 'Solver.Name1 = "Elmer";' in text and "General.Terminal = 1;" in text
    assert 'Solver.Name2 = "Blossomquad";' in text
    assert 'Solver.Executable2 = "/opt/bq/bin/blossomquad-gmsh";' in text
    # again: the same slot, updated, no duplicate
    gmsh_gui.install(options, "/other/blossomquad-gmsh")
    text = options.read_text()
    assert text.count("Blossomquad") == 1 and '"/other/blossomquad-gmsh"' in text
    monkeypatch.setenv("GMSH_HOME", str(tmp_path))
    assert gmsh_gui.options_file() == options
    # Gmsh reads the lines: the solver is there at start-up (in a process of its own:
    # Gmsh reads GMSH_HOME once per process)
    code = ("import gmsh; gmsh.initialize(); "
            "print(gmsh.option.getString('Solver.Name1'), gmsh.option.getString('Solver.Name2'))")
    seen = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=dict(os.environ, GMSH_HOME=str(tmp_path)))
    assert seen.stdout.split() == ["Elmer", "Blossomquad"], seen.stderr


def test_command_line(tmp_path, monkeypatch):
    monkeypatch.setenv("GMSH_HOME", str(tmp_path))
    py = [sys.executable, "-m", "blossomquad.gmsh_gui"]
    printed = subprocess.run(py + ["--print"], capture_output=True, text=True)
    assert printed.returncode == 0
    assert printed.stdout.startswith('Solver.Name1 = "Blossomquad";\nSolver.Executable1 = "')
    installed = subprocess.run(py + ["--install"], capture_output=True, text=True)
    assert installed.returncode == 0, installed.stderr
    assert (tmp_path / ".gmsh-options").read_text() == printed.stdout
    assert subprocess.run(py, capture_output=True).returncode == 2
