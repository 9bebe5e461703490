"""Blossomquad in Gmsh's graphical interface: a ONELAB client.

Gmsh starts a ONELAB client as ``EXECUTABLE -onelab NAME ADDRESS`` and talks to it over a
socket. This module is such a client, written with the standard library alone: it adds a
"Blossomquad" panel (the main job's options) to Gmsh's solver tree, and on **Run** it

1. has Gmsh save its current mesh (all elements) into a temporary directory, meshing the
   model in 2D first when it holds no mesh;
2. recombines it with :func:`blossomquad.recombine_file`;
3. has Gmsh replace its mesh by the result (``Delete Meshes; Delete Physicals; Merge``),
   removing the quality views of an earlier run;
4. publishes read-only results (triangles in, quads out, worst and mean eta, minimum
   scaled Jacobian, regular vertices) in the panel.

Errors go to Gmsh's message console as errors. Nothing is written beside the model: the
client sets ``Solver.AutoMesh = 0`` (Gmsh itself would otherwise mesh and save
``MODEL.msh`` on Run) and ``Solver.AutoSaveDatabase = 0`` (``MODEL.db``).

Registration: ``python -m blossomquad.gmsh_gui --install`` adds the solver to Gmsh's
options file (``~/.gmsh-options``); ``--print`` shows the lines instead. Without
registration, ``gmsh model.geo /path/to/blossomquad/gmsh_gui.py`` also works (Gmsh runs a
``.py`` file with ``Solver.PythonInterpreter``, which must see the package).
"""

from __future__ import annotations

import json
import os
import re
import socket
import struct
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

# --- ONELAB's socket protocol -----------------------------------------------------------
# A message is a header of two native-endian C ints (type, body length) and the body.
# Parameters travel as fields separated by NUL characters (ONELAB version 1.3).

START, STOP = 1, 2
INFO, WARNING, ERROR, PROGRESS = 10, 11, 12, 13
PARSE_STRING = 21
PARAMETER, PARAMETER_QUERY, PARAMETER_NOT_FOUND = 23, 24, 29
ONELAB_VERSION = "1.3"
CHANGED_DEFAULT = 31  # ONELAB's "changed" value of a parameter that can change
NAME = "Blossomquad"


def _num(x: float) -> str:
    """A number as ONELAB's fields write it (integers without a decimal point)."""
    return str(int(x)) if float(x).is_integer() and abs(x) < 1e15 else repr(float(x))


class Parameter:
    """A ONELAB number or string parameter (the fields the client uses)."""

    def __init__(self, kind: str, name: str, values: Sequence[Any], **fields: Any) -> None:
        self.kind = kind  # "number" or "string"
        self.name = name
        self.values = list(values)
        self.label: str = fields.get("label", "")
        self.help: str = fields.get("help", "")
        self.changed_value: int = fields.get("changed_value", CHANGED_DEFAULT)
        self.visible: bool = fields.get("visible", True)
        self.read_only: bool = fields.get("read_only", False)
        self.attributes: Dict[str, str] = dict(fields.get("attributes", {}))
        self.min: float = fields.get("min", -1e200)
        self.max: float = fields.get("max", 1e200)
        self.step: float = fields.get("step", 0.0)
        self.choices: List[Any] = list(fields.get("choices", []))
        self.value_labels: Dict[float, str] = dict(fields.get("value_labels", {}))
        self.string_kind: str = fields.get("string_kind", "generic")

    def encode(self) -> bytes:
        def clean(s: str) -> str:
            return str(s).replace("\0", " ")

        f = [ONELAB_VERSION, self.kind, clean(self.name), clean(self.label), clean(self.help)]
        f += [str(self.changed_value), str(int(self.visible)), str(int(self.read_only))]
        f.append(str(len(self.attributes)))
        for key, value in sorted(self.attributes.items()):
            f += [clean(key), clean(value)]
        f.append("0")  # clients: the server adds this one
        f.append(str(len(self.values)))
        if self.kind == "number":
            f += [_num(v) for v in self.values]
            f += [_num(self.min), _num(self.max), _num(self.step), "-1"]
            f.append(str(len(self.choices)))
            f += [_num(c) for c in self.choices]
            f.append(str(len(self.value_labels)))
            for value, label in sorted(self.value_labels.items()):
                f += [_num(value), clean(label)]
        else:
            f += [clean(v) for v in self.values]
            f += [clean(self.string_kind), str(len(self.choices))]
            f += [clean(c) for c in self.choices]
        return ("\0".join(f) + "\0").encode("utf-8")

    @classmethod
    def decode(cls, body: bytes) -> "Parameter":
        fields = body.decode("utf-8", "replace").split("\0")
        it = iter(fields)

        def take() -> str:
            return next(it, "")

        version, kind, name = take(), take(), take()
        if version != ONELAB_VERSION:
            raise ProtocolError(f"ONELAB version {version!r} (expected {ONELAB_VERSION})")
        p = cls(kind, name, [])
        p.label, p.help = take(), take()
        p.changed_value = int(take() or 0)
        p.visible, p.read_only = take() != "0", take() == "1"
        for _ in range(int(take() or 0)):
            key = take()
            p.attributes[key] = take()
        for _ in range(int(take() or 0)):
            take(), take()  # clients
        n = int(take() or 0)
        if kind == "number":
            p.values = [float(take()) for _ in range(n)]
            p.min, p.max, p.step = float(take()), float(take()), float(take())
            take()  # loop index
            p.choices = [float(take()) for _ in range(int(take() or 0))]
            for _ in range(int(take() or 0)):
                value = float(take())
                p.value_labels[value] = take()
        else:
            p.values = [take() for _ in range(n)]
            p.string_kind = take()
            p.choices = [take() for _ in range(int(take() or 0))]
        return p


class ProtocolError(RuntimeError):
    """Gmsh answered something this client does not understand."""


class Connection:
    """The client's end of the socket Gmsh listens on: a Unix socket path, or
    ``host:port`` for TCP (Gmsh's choice on Windows)."""

    def __init__(self, address: str) -> None:
        if "/" in address or "\\" in address or ":" not in address:
            self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            self.sock.connect(address)
        else:
            host, port = address.rsplit(":", 1)
            self.sock = socket.create_connection((host or "localhost", int(port)))
            self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)

    def send(self, kind: int, body: bytes | str) -> None:
        if isinstance(body, str):
            body = body.encode("utf-8")
        self.sock.sendall(struct.pack("=ii", kind, len(body)) + body)

    def _exactly(self, n: int) -> bytes:
        data = b""
        while len(data) < n:
            chunk = self.sock.recv(n - len(data))
            if not chunk:
                raise ProtocolError("Gmsh closed the connection")
            data += chunk
        return data

    def receive(self) -> Tuple[int, bytes]:
        header = self._exactly(8)
        kind, length = struct.unpack("=ii", header)
        if kind > 65535 or kind < 0:  # the other byte order
            kind, length = struct.unpack("<ii" if sys.byteorder == "big" else ">ii", header)
        return kind, self._exactly(length)

    def close(self) -> None:
        self.sock.close()


class Client:
    """A ONELAB client connection to Gmsh: queries, parameters, messages."""

    def __init__(self, name: str, address: str) -> None:
        self.name = name
        self.conn = Connection(address)
        self.conn.send(START, str(os.getpid()))

    def query(self, kind: str, name: str) -> Optional[Parameter]:
        """The parameter ``name`` (``kind`` "number" or "string") as Gmsh holds it, or
        None. Names such as ``Mesh.NbTriangles`` read Gmsh's options."""
        self.conn.send(PARAMETER_QUERY, Parameter(kind, name, []).encode())
        while True:
            reply, body = self.conn.receive()
            if reply == PARAMETER:
                return Parameter.decode(body)
            if reply == PARAMETER_NOT_FOUND:
                return None
            if reply == STOP:
                raise ProtocolError("Gmsh stopped the client")

    def number(self, name: str, default: float = 0.0) -> float:
        p = self.query("number", name)
        return p.values[0] if p and p.values else default

    def string(self, name: str, default: str = "") -> str:
        p = self.query("string", name)
        return p.values[0] if p and p.values else default

    def set(self, p: Parameter) -> None:
        self.conn.send(PARAMETER, p.encode())

    def set_option(self, name: str, value: float) -> None:
        """Sets Gmsh's number option ``name`` (e.g. ``Solver.AutoMesh``)."""
        self.set(Parameter("number", name, [value]))

    def parse(self, code: str) -> None:
        """Has Gmsh run ``code`` (its .geo language) on the model it shows, and waits
        until it has."""
        self.conn.send(PARSE_STRING, code)
        self.number("General.Terminal")  # a round trip: the code ran before the reply

    def info(self, text: str) -> None:
        self.conn.send(INFO, text)

    def error(self, text: str) -> None:
        self.conn.send(ERROR, text)

    def progress(self, text: str) -> None:
        self.conn.send(PROGRESS, text)

    def stop(self) -> None:
        try:
            self.conn.send(STOP, "Goodbye!")
        finally:
            self.conn.close()


# --- the panel --------------------------------------------------------------------------

# (keyword, parameter name, label, default, fields): the main job's options, as numbers
# (a checkbox is the choices 0/1)
_CHECK = {"choices": [0, 1]}
OPTIONS: List[Tuple[str, str, str, float, Dict[str, Any]]] = [
    ("optimize", "1Optimize", "Optimize the quads", 1, dict(_CHECK, help=(
        "smoothing and topological optimization after the matching (off: the optimal "
        "matching as is)"))),
    ("topology", "2Topology", "Topological operators", 1, dict(_CHECK, help=(
        "quad-vertex merge, doublet collapse and edge rotation"))),
    ("smooth", "3Smooth", "Smoothing sweeps", 5, {"min": 0, "max": 50, "step": 1, "help": (
        "sweeps per smoothing phase (0: no smoothing)")}),
    ("refine", "4Refine", "Refinement levels", 0, {"min": 0, "max": 3, "step": 1, "help": (
        "split every quad into four N times: mesh the triangles at 2^N times the size you "
        "want")}),
    ("cross_field", "5CrossField", "Cross-field weight", 0.05, {
        "min": 0, "max": 5, "step": 0.05, "help": (
            "weight of the alignment with a cross field added to the quality cost")}),
    ("parity", "6Parity", "Odd surfaces", 0, {"choices": [0, 1], "value_labels": {
        0: "repair", 1: "refuse"}, "help": (
            "a surface with an odd number of triangles: split a boundary segment (repair) "
            "or refuse the mesh")}),
    ("drop_volumes", "7DropVolumes", "Drop volume elements", 0, dict(_CHECK, help=(
        "a 3D mesh is refused unless its volume elements are dropped"))),
    ("quality_view", "8QualityViews", "Quality views", 0, dict(_CHECK, help=(
        "add the views eta, scaled jacobian and valence (replacing an earlier run's)"))),
]
OPTIONS_PATH = "0Options"
RESULTS_PATH = "1Results"
QUALITY_VIEWS = ("eta", "scaled jacobian", "valence")


def _clamp(value: float, default: float, fields: Dict[str, Any]) -> float:
    if value != value:  # NaN
        return default
    if "choices" in fields:
        return min(fields["choices"], key=lambda c: abs(c - value))
    value = min(max(value, fields["min"]), fields["max"])
    return round(value) if fields["step"] == 1 else value


def define_options(client: Client) -> Dict[str, Any]:
    """Shows the options in the panel (Gmsh's values where it has them, clamped to their
    ranges) and returns them as :func:`blossomquad.recombine_file` keywords."""
    out: Dict[str, Any] = {}
    for keyword, key, label, default, fields in OPTIONS:
        name = f"{client.name}/{OPTIONS_PATH}/{key}"
        held = client.query("number", name)
        value = held.values[0] if held and held.values else default
        value = _clamp(value, default, fields)
        client.set(Parameter("number", name, [value], label=label, **fields))
        if keyword == "parity":
            out[keyword] = "error" if value else "repair"
        elif keyword == "cross_field":
            out[keyword] = float(value)
        elif keyword in ("smooth", "refine"):
            out[keyword] = int(value)
        else:
            out[keyword] = bool(value)
    return out


def publish(client: Client, results: Sequence[Tuple[str, str, float]]) -> None:
    """Shows ``(key, label, value)`` results as read-only numbers in the panel."""
    for key, label, value in results:
        client.set(Parameter(
            "number", f"{client.name}/{RESULTS_PATH}/{key}", [value], label=label,
            read_only=True, changed_value=0, attributes={"Highlight": "AliceBlue"}))


class GuiError(Exception):
    """A run that cannot go on, said in words for Gmsh's error messages."""


def _geo_string(path: Path) -> str:
    text = path.as_posix()
    if '"' in text:
        raise GuiError(f"cannot hand Gmsh a path holding a double quote: {text}")
    return f'"{text}"'


def _quality(path: Path) -> Dict[str, Any]:
    """``blossomquad quality PATH --json``'s totals."""
    run = subprocess.run(
        [sys.executable, "-m", "blossomquad", "quality", str(path), "--json"],
        capture_output=True, text=True, check=False)
    if run.returncode != 0:
        raise GuiError(run.stderr.strip() or "blossomquad quality failed")
    return json.loads(run.stdout)["total"]


def compute(client: Client, options: Dict[str, Any]) -> None:
    """The Run action: Gmsh's mesh out, recombined, back in; results published."""
    import blossomquad  # here, not at the top: check runs often and needs none of it

    triangles = client.number("Mesh.NbTriangles")
    if triangles == 0:
        if client.number("Mesh.NbQuadrangles") > 0:
            raise GuiError(
                "the mesh has quads and no triangle (recombined already?): mesh the model "
                "again (Mesh > 2D), then Run")
        client.info("no mesh: meshing in 2D first")
        client.parse("Mesh 2;")
        if client.number("Mesh.NbTriangles") == 0:
            raise GuiError("no triangle to recombine: the model gives no 2D mesh")

    with tempfile.TemporaryDirectory(prefix="blossomquad-gmsh-") as tmp:
        source, result = Path(tmp) / "in.msh", Path(tmp) / "out.msh"
        # every element (not only those in physical groups), as MSH 4.1; the user's
        # options are put back afterwards
        save_all = client.number("Mesh.SaveAll")
        version = client.number("Mesh.MshFileVersion", 4.1)
        client.parse(
            f"Mesh.SaveAll = 1; Mesh.MshFileVersion = 4.1; Save {_geo_string(source)}; "
            f"Mesh.SaveAll = {_num(save_all)}; Mesh.MshFileVersion = {_num(version)};")
        if not source.exists():
            raise GuiError("Gmsh did not save its mesh")

        def progress(stage: str, done: int, total: int) -> None:
            client.progress(f"{stage} {100 * done // max(total, 1)}%")

        try:
            report = blossomquad.recombine_file(
                source, result, progress=progress, **options)
        except blossomquad.Error as e:
            message = str(e).replace(f"{source}: ", "").replace(str(source), "the mesh")
            message = message.replace("(drop_volumes=True)", '(tick "Drop volume elements")')
            raise GuiError(message) from None
        total = _quality(result)

        # Gmsh's mesh replaced by the result; the quality views of an earlier run go
        # (they describe a mesh that is no more), whether or not new ones come
        same = " || ".join(f'!StrCmp(View[blossomquad_v].Name, "{v}")' for v in QUALITY_VIEWS)
        client.parse(
            "For blossomquad_v In {PostProcessing.NbViews - 1 : 0 : -1}\n"
            f"  If ({same})\n    Delete View[blossomquad_v];\n  EndIf\nEndFor\n"
            f"Delete Meshes; Delete Physicals; Merge {_geo_string(result)};")

    surfaces = report["recombine"]["surfaces"]
    triangles_in = sum(s["triangles_in"] for s in surfaces)
    results = [
        ("1Triangles", "Triangles in", triangles_in),
        ("2Quads", "Quads out", total["quads"]),
        ("3EtaWorst", "Worst eta", round(total["eta_worst"], 3)),
        ("4EtaMean", "Mean eta", round(total["eta_mean"], 3)),
        ("5SJMin", "Min scaled Jacobian", round(total["sj_min"], 3)),
        ("6Regular", "Regular vertices [%]", round(total["d4_percent"], 1)),
    ]
    publish(client, results)
    line = (
        f"{len(surfaces)} surface{'s' if len(surfaces) != 1 else ''}, {triangles_in} "
        f"triangles -> {total['quads']} quads (quality eta: worst {total['eta_worst']:.3f}, "
        f"mean {total['eta_mean']:.3f}; min scaled Jacobian {total['sj_min']:.3f})")
    for warning in report["warnings"]:
        client.conn.send(WARNING, warning["message"])
    client.info(line)


def run_client(name: str, address: str) -> int:
    """One run of the client, as Gmsh starts it; returns the exit code."""
    client = Client(name, address)
    status = 0
    try:
        action = client.string(f"{name}/Action")
        # Gmsh would otherwise mesh and save MODEL.msh on Run, and save MODEL.db after it
        client.set_option("Solver.AutoMesh", 0)
        client.set_option("Solver.AutoSaveDatabase", 0)
        options = define_options(client)
        if action == "compute":
            compute(client, options)
    except GuiError as e:
        client.error(str(e))
        status = 1
    except Exception as e:  # shown in Gmsh rather than lost on a console
        client.error(f"{type(e).__name__}: {e}")
        status = 1
    finally:
        client.stop()
    return status


# --- registration -----------------------------------------------------------------------


def options_file() -> Path:
    """Gmsh's options file: ``General.OptionsFileName`` in Gmsh's home directory
    (``$GMSH_HOME``, else ``%APPDATA%`` on Windows or ``$HOME``)."""
    windows = sys.platform.startswith("win")
    home = os.environ.get("GMSH_HOME") or (
        os.environ.get("APPDATA") if windows else os.environ.get("HOME")
    ) or os.environ.get("TMP") or os.environ.get("TEMP") or "."
    return Path(home) / ("gmsh-options" if windows else ".gmsh-options")


def executable() -> str:
    """The command Gmsh should run: the package's ``blossomquad-gmsh`` script beside this
    Python, else this file (a ``.py`` file Gmsh runs with ``Solver.PythonInterpreter``)."""
    import shutil
    import sysconfig

    suffix = ".exe" if sys.platform.startswith("win") else ""
    script = Path(sysconfig.get_path("scripts")) / f"blossomquad-gmsh{suffix}"
    if script.exists():
        return str(script)
    found = shutil.which("blossomquad-gmsh")
    return found or str(Path(__file__).resolve())


_SOLVER_LINE = re.compile(r'^\s*Solver\.(Name|Executable)(\d)\s*=\s*"(.*)"\s*;', re.M)


def install_lines(text: str, exe: str) -> Tuple[str, int]:
    """``text`` (an options file) with the Blossomquad solver added, in the slot it has
    already or the first free one (slot 0 is GetDP's unless the file says otherwise);
    returns the new text and the slot."""
    names: Dict[int, str] = {0: "GetDP"}
    executables: Dict[int, str] = {}
    for what, slot, value in _SOLVER_LINE.findall(text):
        (names if what == "Name" else executables)[int(slot)] = value
    mine = [s for s, n in names.items() if n == NAME]
    if mine:
        slot = mine[0]
    else:
        free = [s for s in range(10) if not names.get(s) and not executables.get(s)]
        if not free:
            raise GuiError("Gmsh's 10 solver slots are all taken in the options file")
        slot = free[0]
    exe = exe.replace("\\", "/")
    lines = [f'Solver.Name{slot} = "{NAME}";', f'Solver.Executable{slot} = "{exe}";']
    kept = [
        line for line in text.splitlines()
        if not re.match(rf'^\s*Solver\.(Name|Executable){slot}\s*=', line)
    ]
    return "\n".join(kept + lines) + "\n", slot


def install(path: Optional[Path] = None, exe: Optional[str] = None) -> Tuple[Path, int]:
    """Adds the solver to Gmsh's options file (created if missing); other solvers and
    options are kept. Returns the file and the slot."""
    path = path or options_file()
    text = path.read_text(encoding="utf-8") if path.exists() else ""
    new, slot = install_lines(text, exe or executable())
    path.write_text(new, encoding="utf-8")
    return path, slot


USAGE = """usage: python -m blossomquad.gmsh_gui --install [--options-file FILE]
       python -m blossomquad.gmsh_gui --print
       (Gmsh runs the client itself as: ... -onelab NAME ADDRESS)

--install   add the "Blossomquad" solver to Gmsh's options file ({file}), keeping the
            solvers already there; open a model in Gmsh, mesh it in 2D, pick Blossomquad
            in the solver tree and press Run
--print     print the options lines instead of writing them"""


def main(argv: Optional[Sequence[str]] = None) -> int:
    args = list(sys.argv[1:] if argv is None else argv)
    if "-onelab" in args:
        i = args.index("-onelab")
        if len(args) < i + 3:
            print("-onelab needs a client name and a socket address", file=sys.stderr)
            return 2
        return run_client(args[i + 1], args[i + 2])
    if args[:1] == ["--print"] and len(args) == 1:
        _text, slot = install_lines("", executable())
        print(_text, end="")
        return 0
    if args[:1] == ["--install"]:
        path = None
        if args[1:2] == ["--options-file"] and len(args) == 3:
            path = Path(args[2])
        elif len(args) != 1:
            print(USAGE.format(file=options_file()), file=sys.stderr)
            return 2
        try:
            written, slot = install(path)
        except (GuiError, OSError) as e:
            print(f"blossomquad.gmsh_gui: {e}", file=sys.stderr)
            return 1
        print(f"{written}: Solver.Name{slot} = \"{NAME}\" added; restart Gmsh to see it")
        return 0
    print(USAGE.format(file=options_file()), file=sys.stderr)
    return 2


if __name__ == "__main__":
    if not __package__:
        # run as a file (Gmsh's Solver.Executable = ".../blossomquad/gmsh_gui.py"): the
        # package is the directory above this one
        sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
        from blossomquad.gmsh_gui import main as _main

        sys.exit(_main())
    sys.exit(main())
